"""Reconstruct: every image of the project -> a fresh workspace (database, models, scene)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session

from guided_sfm import jobs
from guided_sfm.actions.context import JobContext, Produced, sfm_options
from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.workspace import Workspace
from guided_sfm.db import queries
from guided_sfm.db.models import Job, Project
from guided_sfm.db.session import session_scope


def queue(session: Session, submit: Callable[[int], None], project: Project, user_id: int,
          params: dict[str, Any]) -> Job:
    """Queue a reconstruction of the project's images; options the worker could not use are refused now."""
    sfm_options(params)  # an unknown camera model is an InvalidInput here, not a failed job later
    return jobs.queue(session, submit, project, "reconstruct", user_id, params, project.head_version_id)


def run(context: JobContext, work: Path) -> Produced:
    # The images the database lists, not the folder's files (a crashed upload may have left some).
    with session_scope(context.sessions) as session:
        names = sorted(row.name for row in queries.images(session, context.job.project_id))
    count = len(names)
    if count < 2:
        raise InvalidInput(f"a reconstruction needs at least 2 images; the project has {count}")
    run, workspace = context.run(), Workspace(work)
    reused = _reuse_tree(context, workspace)
    workspace.reconstruct(context.images_dir(names), run, names)
    stats, used = workspace.stats(), workspace.used()
    message = (f"reconstructed {stats['num_registered']} of {stats['num_images']} images "
               f"({_chosen(run.options.matcher, used['matcher'])} matching, "
               f"{used['mapper']} mapping, max image size {used['max_image_size']})")
    return Produced(work, "reconstruct", message, context.job.base_version_id, stats, reuse_from=reused)


def _chosen(asked: str, used: str) -> str:
    """"retrieval" when asked for it, "auto: retrieval" when auto chose it."""
    return used if asked == used else f"{asked}: {used}"


def _reuse_tree(context: JobContext, workspace: Workspace) -> tuple[str, ...]:
    """Fetch the newest vocabulary tree of the project's earlier versions into the new workspace,
    so retrieval does not train one again (the tree is kept with the project); the version it
    came from, whose stored tree the new version then shares."""
    with session_scope(context.sessions) as session:
        paths = [v.path for v in reversed(queries.versions(session, context.job.project_id))]
    workspace.root.mkdir(parents=True, exist_ok=True)
    for path in paths:
        if context.store.fetch_member(path, workspace.tree.name, workspace.tree):
            return (path,)
    return ()
