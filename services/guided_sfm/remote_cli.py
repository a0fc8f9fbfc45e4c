"""`guided-sfm remote --url URL ...`: the loop against a running service through guided_sfm.client.

The token comes from GUIDED_SFM_TOKEN (a personal access token), the URL from --url or
GUIDED_SFM_URL. Results go to stdout (a table, or JSON with --json); progress bars to stderr.
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
from collections.abc import Callable
from pathlib import Path

import httpx
from tqdm import tqdm

from guided_sfm.cli import ProgressBar, print_json, print_table, read_json
from guided_sfm.client import ApiError, Client, JobFailed, with_image_ids
from guided_sfm.core.errors import DomainError

IMAGE_SUFFIXES = {".jpg", ".jpeg", ".png"}


def register(subparsers: argparse._SubParsersAction) -> None:
    remote = subparsers.add_parser("remote", help="talk to a running service (token: GUIDED_SFM_TOKEN)")
    remote.add_argument("--url", default=os.environ.get("GUIDED_SFM_URL", "http://127.0.0.1:8000"))
    commands = remote.add_subparsers(dest="remote_command", required=True)
    for name, func, help_, arguments in COMMANDS:
        command = commands.add_parser(name, help=help_, description=help_)
        for spec in arguments:
            command.add_argument(spec[0], **(spec[1] if len(spec) > 1 else {}))
        command.set_defaults(func=_talking(func))


def _talking(func: Callable[[Client, argparse.Namespace], None]) -> Callable[[argparse.Namespace], None]:
    """Run `func` with a client; the server's refusals become the CLI's one-line errors."""

    @functools.wraps(func)
    def run(args: argparse.Namespace) -> None:
        token = os.environ.get("GUIDED_SFM_TOKEN")
        if not token:
            raise DomainError("set GUIDED_SFM_TOKEN to an access token (POST /api/v1/tokens)")
        try:
            with Client(args.url, token) as client:
                func(client, args)
        except (ApiError, JobFailed) as exc:
            raise DomainError(str(exc)) from exc
        except httpx.HTTPError as exc:
            raise DomainError(f"cannot reach {args.url}: {exc}") from exc

    return run


def wait_with_bar(client: Client, job_id: int) -> dict:
    """Wait for the job, one progress bar per stage on stderr."""
    with ProgressBar(sys.stderr.isatty() or os.environ.get("GUIDED_SFM_PROGRESS") == "1") as bar:
        return client.wait(job_id, progress=lambda job: bar(job["stage"] or job["state"], job["progress"]))


def show(args: argparse.Namespace, data: dict, rows: list[tuple[str, object]]) -> None:
    print_json(data) if args.json else print_table(rows)


def cmd_projects(client: Client, args: argparse.Namespace) -> None:
    projects = client.projects()
    if args.json:
        print_json(projects)
    for project in [] if args.json else projects:
        print(f"{project['id']:>5}  {project['role'] or '':<7}  {project['name']}")


def cmd_create(client: Client, args: argparse.Namespace) -> None:
    project = client.create_project(args.name)
    show(args, project, [("project", project["id"]), ("name", project["name"])])


def cmd_upload(client: Client, args: argparse.Namespace) -> None:
    files = [p for arg in args.files for p in _images(Path(arg))]
    if not files:
        raise DomainError("no JPEG or PNG files given")
    with tqdm(total=len(files), desc="upload", unit="file", file=sys.stderr, leave=False) as bar:
        created = client.upload(args.pid, files, args.batch, lambda done, _total: bar.update(done - bar.n),
                                batch_mb=args.batch_mb)
    again = sum(1 for image in created if image.get("already_uploaded"))
    result = {"uploaded": len(created) - again} | ({"already_uploaded": again} if again else {})
    show(args, result, list(result.items()))


def _images(path: Path) -> list[Path]:
    if path.is_dir():
        return sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    return [path]


def cmd_reconstruct(client: Client, args: argparse.Namespace) -> None:
    options = {k: v for k, v in (("matcher", args.matcher), ("mapper", args.mapper)) if v}
    if args.max_image_size is not None:
        options["max_image_size"] = args.max_image_size  # 0 too: COLMAP's own
    job = client.reconstruct(args.pid, **options)
    _finish(client, args, job)


def _finish(client: Client, args: argparse.Namespace, job: dict) -> None:
    """Wait for the job unless --no-wait; print it."""
    if not getattr(args, "no_wait", False):
        job = wait_with_bar(client, job["id"])
    show(args, job, [("job", job["id"]), ("state", job["state"]), ("version", job["version_id"]),
                     ("message", job["message"])])


def cmd_wait(client: Client, args: argparse.Namespace) -> None:
    _finish(client, args, client.job(args.job_id))


def cmd_scene(client: Client, args: argparse.Namespace) -> None:
    vid = args.version or client.head(args.pid)
    if vid is None:
        raise DomainError(f"project {args.pid} has no version yet")
    print_json(client.scene(args.pid, vid))


def cmd_prune(client: Client, args: argparse.Namespace) -> None:
    """Save the edits (names or REST ids) on the head as an edit set, preview it, and unless
    --dry-run apply it without mapping again (`map` maps)."""
    head = client.head(args.pid)
    if head is None:
        raise DomainError(f"project {args.pid} has no version to edit yet")
    body = with_image_ids(_edits(args.edits), client.images(args.pid))
    edit_set = client.create_edit_set(args.pid, head, **body)
    preview = client.preview(args.pid, edit_set["id"])
    record = {"edit_set": edit_set["id"], "base_version": head, **preview}
    if not args.dry_run:
        record["version"] = wait_with_bar(client, client.apply(args.pid, edit_set["id"], remap=False)["id"])[
            "version_id"]
    show(args, record, [("edit set", edit_set["id"]), ("deleted pairs", len(preview["pairs_to_delete"])),
                        ("components before", preview["components_before"]),
                        ("components after", preview["components_after"]),
                        ("version", record.get("version", "(dry run)"))])


def _edits(path: str) -> dict:
    edits = read_json(path)
    if not isinstance(edits, dict):
        raise DomainError(f"{path}: an edit set is a JSON object")
    return edits


def cmd_map(client: Client, args: argparse.Namespace) -> None:
    _finish(client, args, client.apply(args.pid, args.eid, remap=True))


def cmd_export(client: Client, args: argparse.Namespace) -> None:
    vid = args.version or client.head(args.pid)
    data = client.export(args.pid, vid, args.format)
    Path(args.out).write_bytes(data)
    print(args.out)


JSON = ("--json", {"action": "store_true"})
NO_WAIT = ("--no-wait", {"action": "store_true", "help": "print the queued job and return"})
PID = ("pid", {"type": int})
COMMANDS = [
    ("projects", cmd_projects, "the projects you have a role in", [JSON]),
    ("create", cmd_create, "create a project", [("name",), JSON]),
    ("upload", cmd_upload, "upload images (files or folders) in batches",
     [PID, ("files", {"nargs": "+"}), ("--batch", {"type": int, "default": 20}),
      ("--batch-mb", {"type": float, "default": 100.0,
                      "help": "MB per request (under the server's upload cap)"}), JSON]),
    ("reconstruct", cmd_reconstruct, "reconstruct from scratch and wait",
     [PID, ("--matcher", {"default": None}), ("--mapper", {"default": None}),
      ("--max-image-size", {"type": int, "default": None, "metavar": "PIXELS",
                            "help": "SIFT's longest side (default 1600; 0: COLMAP's own, 3200)"}),
      NO_WAIT, JSON]),
    ("wait", cmd_wait, "wait for a job", [("job_id", {"type": int}), JSON]),
    ("scene", cmd_scene, "a version's top-down scene as JSON (default: the head)",
     [PID, ("--version", {"type": int, "default": None})]),
    ("prune", cmd_prune, "save edits.json as an edit set on the head; preview; apply without mapping",
     [PID, ("edits",), ("--dry-run", {"action": "store_true"}), JSON]),
    ("map", cmd_map, "apply an edit set and map again", [PID, ("eid", {"type": int}), NO_WAIT, JSON]),
    ("export", cmd_export, "download a version (default: the head)",
     [PID, ("out",), ("--version", {"type": int, "default": None}),
      ("--format", {"choices": ["colmap", "ply"], "default": "colmap"})]),
]
