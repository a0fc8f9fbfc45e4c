"""The domain core stays pure: importing it loads no web, queue or ORM package."""

import subprocess
import sys

FORBIDDEN = ("fastapi", "starlette", "celery", "kombu", "sqlalchemy", "alembic", "redis")


def test_core_imports_no_web_queue_or_orm():
    modules = [
        "colmap_db", "colmap_model", "edits", "errors", "evaluation", "rule.frustum", "geometry",
        "ground_plane", "match_graph", "metrics", "rule.driver", "sfm", "simulated_user", "topdown",
        "truth", "types", "workspace",
    ]
    code = "; ".join(f"import guided_sfm.core.{m}" for m in modules)
    code += "; import guided_sfm.sample, sys; print(' '.join(sorted(sys.modules)))"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    names = {name.split(".")[0] for name in loaded.stdout.split()}
    assert not names & set(FORBIDDEN), f"core imported {sorted(names & set(FORBIDDEN))}"
