"""docs/architecture.md, enforced. Its tables are read here; every module of services/guided_sfm/,
worker/ and migrations/ is found by walking the tree; each part may import only what its row
allows, each never is checked on the import statements (functions included) and, in a fresh
interpreter per row, on what importing the row's modules loads; the editor's modules import only
what their role allows. To change a rule, change the table in the doc."""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from dataclasses import dataclass
from functools import cache
from importlib.util import find_spec
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "architecture.md"
FRONTEND = ROOT / "frontend" / "js"
SOURCES = {"guided_sfm": ROOT / "services", "worker": ROOT, "migrations": ROOT}  # name -> its folder's parent
IMPORTABLE = ("guided_sfm", "worker")  # migrations/ runs inside Alembic: checked statically only
STDLIB = sys.stdlib_module_names | {"__future__"}


# The tree -----------------------------------------------------------------------------------------

@cache
def tree() -> dict[str, Path]:
    """Every module by dotted name (a package by its __init__.py), found on disk."""
    found = {}
    for top, parent in SOURCES.items():
        for path in sorted((parent / top).rglob("*.py")):
            parts = path.relative_to(parent).with_suffix("").parts
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def inside(name: str, prefixes) -> str | None:
    """The first of `prefixes` that `name` is, or is a submodule of."""
    return next((p for p in prefixes if name == p or name.startswith(p + ".")), None)


@dataclass(frozen=True)
class Import:
    module: str
    line: int
    name: str  # dotted, relative imports resolved

    def __str__(self) -> str:
        return f"{tree()[self.module].relative_to(ROOT)}:{self.line} imports {self.name}"


@cache
def imports(module: str) -> tuple[Import, ...]:
    """Every import of a module wherever it stands (functions, TYPE_CHECKING blocks included):
    `from a import b` counts as `a.b` when that is a module of the tree, else as `a`; a literal
    importlib.import_module("x") or __import__("x") counts too."""
    path = tree()[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        for name in _names(node, package):
            found.append(Import(module, node.lineno, name))
    return tuple(found)


def _names(node: ast.AST, package: str) -> list[str]:
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if isinstance(node, ast.ImportFrom):
        base = node.module or ""
        if node.level:
            parents = package.split(".")[: len(package.split(".")) - node.level + 1]
            base = ".".join(parents + ([node.module] if node.module else []))
        return [f"{base}.{a.name}" if f"{base}.{a.name}" in tree() else base for a in node.names]
    if isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
        called = ast.unparse(node.func)
        if called in ("importlib.import_module", "import_module", "__import__"):
            return [str(node.args[0].value)]
    return []


# The doc ------------------------------------------------------------------------------------------

def section(heading: str) -> str:
    text = DOC.read_text()
    assert f"\n## {heading}\n" in text, f"{DOC.name} has no section '## {heading}'"
    return text.split(f"\n## {heading}\n", 1)[1].split("\n## ", 1)[0]


def table(heading: str) -> list[list[str]]:
    """The rows (cells as text) of the first table of a section, header and rule left out."""
    lines = [line for line in section(heading).splitlines() if line.startswith("|")]
    return [[cell.strip() for cell in line.strip().strip("|").split("|")] for line in lines[2:]]


def names(cell: str) -> tuple[str, ...]:
    return tuple(re.findall(r"`([^`]+)`", cell))


@dataclass(frozen=True)
class Part:
    name: str
    packages: tuple[str, ...]
    allowed: tuple[str, ...]


@dataclass(frozen=True)
class Never:
    number: str
    packages: tuple[str, ...]
    banned: tuple[str, ...]


@cache
def parts() -> tuple[Part, ...]:
    return tuple(Part(row[0], names(row[1]), names(row[2])) for row in table("Parts"))


@cache
def nevers() -> tuple[Never, ...]:
    return tuple(Never(row[0], names(row[1]), names(row[2])) for row in table("Nevers"))


def part_of(module: str) -> Part | None:
    """The part whose package is the longest prefix of the module's name."""
    owners = [(len(package), part) for part in parts() for package in part.packages
              if inside(module, [package])]
    return max(owners, key=lambda owner: owner[0])[1] if owners else None


def modules_of(packages: tuple[str, ...]) -> list[str]:
    return [m for m in tree() if inside(m, packages)]


# Parts --------------------------------------------------------------------------------------------

def test_every_module_belongs_to_a_part():
    assert len(tree()) > 80, f"the walk found only {len(tree())} modules"
    homeless = [str(path.relative_to(ROOT)) for m, path in tree().items() if part_of(m) is None]
    assert not homeless, f"no row of '## Parts' in {DOC.name} covers {homeless}"


@pytest.mark.parametrize("part", parts(), ids=lambda p: p.name)
def test_part_imports_only_what_the_doc_allows(part: Part):
    modules = [m for m in tree() if part_of(m) == part]
    if not modules:
        pytest.skip(f"no module under {part.packages} in this tree")
    refused = [str(i) for m in modules for i in imports(m)
               if i.name.split(".")[0] not in STDLIB and not inside(i.name, part.allowed)
               and part_of(i.name) != part]
    assert not refused, f"the part {part.name} may not import these (docs/architecture.md, Parts): {refused}"


# Nevers -------------------------------------------------------------------------------------------

PROBE = """
import importlib, json, sys
before, blame = set(sys.modules), {}
for name in sys.argv[1:]:
    importlib.import_module(name)
    blame.update({loaded: name for loaded in set(sys.modules) - before})
    before = set(sys.modules)
print(json.dumps(blame))
"""


def loaded_by(modules: list[str]) -> dict[str, str]:
    """In a fresh interpreter, import the modules in turn: each module loaded -> whose import did."""
    run = subprocess.run([sys.executable, "-c", PROBE, *modules], capture_output=True, text=True,
                         cwd=ROOT, timeout=300)
    assert run.returncode == 0, f"importing {modules} failed:\n{run.stderr[-3000:]}"
    return json.loads(run.stdout)


def installed(name: str) -> bool:
    """A package exists: loaded already (kombu replaces its module and drops __spec__, which
    find_spec refuses) or findable without importing it."""
    return name in sys.modules or find_spec(name) is not None


def test_the_nevers_name_real_modules_and_packages():
    assert len(nevers()) >= 10, f"{DOC.name} lists only {len(nevers())} nevers"
    unknown = [(n.number, name) for n in nevers() for name in n.banned
               if not (modules_of((name,)) if name.split(".")[0] in SOURCES else installed(name))]
    assert not unknown, f"nevers naming nothing that exists, so they cannot fail: {unknown}"


@pytest.mark.parametrize("never", nevers(), ids=lambda n: f"never-{n.number}")
def test_never(never: Never):
    modules = modules_of(never.packages)
    if not modules:
        pytest.skip(f"no module under {never.packages} in this tree")
    broken = [str(i) for m in modules for i in imports(m) if inside(i.name, never.banned)]
    importable = [m for m in modules if m.split(".")[0] in IMPORTABLE]
    if importable:
        first: dict[str, str] = {}  # banned name -> the module whose import loaded it
        for loaded, by in sorted(loaded_by(importable).items()):
            if banned := inside(loaded, never.banned):
                first.setdefault(banned, by)
        broken += [f"importing {by} loads {banned}" for banned, by in first.items()]
    assert not broken, f"never {never.number} of docs/architecture.md ({', '.join(never.packages)}): {broken}"


def test_newcomer_pointers_exist():
    paths = [p for p in names(section("Where a newcomer starts")) if "/" in p]
    assert len(paths) >= 10
    missing = [p for p in paths if not (ROOT / p).exists()]
    assert not missing, f"'Where a newcomer starts' in {DOC.name} points at files that are gone: {missing}"


# The editor ---------------------------------------------------------------------------------------

JS_IMPORT = re.compile(r"""(?:\bfrom|\bimport)\s*\(?\s*["']\./([\w.-]+\.js)["']""")


def test_editor_modules_import_only_what_their_role_allows():
    rows = table("The editor (`frontend/js/`)")
    role_of = {module: row[0] for row in rows for module in names(row[1])}
    may = {row[0]: set(names(row[2])) for row in rows}
    files = {path.name for path in FRONTEND.glob("*.js")}
    assert files == set(role_of), (f"modules without a role: {sorted(files - set(role_of))}; "
                                   f"roles for missing modules: {sorted(set(role_of) - files)}")
    refused = [f"{name} ({role_of[name]}) imports {target} ({role_of.get(target)})"
               for name in sorted(files) for target in JS_IMPORT.findall((FRONTEND / name).read_text())
               if role_of.get(target) not in may[role_of[name]]]
    assert not refused, f"the editor's roles (docs/architecture.md) refuse: {refused}"
