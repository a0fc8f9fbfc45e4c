"""Apply an edit set: prune the base version's pairs into a new workspace, then map it again."""

from __future__ import annotations

from pathlib import Path

from guided_sfm.actions.context import JobContext, Produced
from guided_sfm.actions.ids import IdMap
from guided_sfm.core import checked_round
from guided_sfm.core.edits import parse_edits
from guided_sfm.core.errors import MissingWorkspace
from guided_sfm.core.workspace import Workspace
from guided_sfm.db.models import Version
from guided_sfm.db.session import session_scope


def run(context: JobContext, work: Path) -> Produced:
    job = context.job
    body, remap = job.params["body"], bool(job.params.get("remap", True))
    with session_scope(context.sessions) as session:
        base = session.get(Version, job.base_version_id)
        if base is None:
            raise MissingWorkspace(f"the base version {job.base_version_id} no longer exists")
        base_path = base.path
    base_ws = Workspace(context.checkout(base_path))  # outside the session: a fetch may take a while
    with session_scope(context.sessions) as session:
        ids = IdMap.load(session, job.project_id, base_ws)
    edits = parse_edits(ids.edits_body(body), base_ws.image_ids())
    context.progress("prune", 0.0)
    new = Workspace(work)
    outcome = base_ws.prune(edits, new)
    mapped, checked = None, []
    if remap:  # warm from the base model unless its guard falls back to a cold re-map; checked
        images = context.images_dir(base_ws.image_ids())
        mapped, checked = checked_round.map_checked(new, edits, context.run(), images)
    reasons = ids.pairs_with([*((pair, outcome.reasons.get(pair, ())) for pair in outcome.deleted),
                              *((pair, (checked_round.CHECK,)) for pair in checked)])
    deleted = [(a, b, tests) for (a, b), tests in reasons]
    message = (f"edit set {job.params.get('edit_set_id')}: deleted {len(deleted)} pairs"
               + (f" ({len(checked)} by the check of the re-map)" if checked else "")
               + (f"; {mapped.message()}" if mapped else ", not mapped again"))
    if job.params.get("message"):  # the author's words first, then what was done
        message = f"{job.params['message']} ({message})"
    return Produced(work, "apply", message, job.base_version_id, new.stats(), edits=body,
                    deleted_pairs=deleted, reuse_from=(base_path,))
