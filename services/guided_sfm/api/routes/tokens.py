"""Personal access tokens: created (secret shown once), listed and revoked by their owner."""

from fastapi import APIRouter, Response

from guided_sfm.actions import tokens
from guided_sfm.api.deps import CurrentUser, PathId, SessionDep, SessionUser
from guided_sfm.api.schemas import AccessTokenCreate, AccessTokenCreated, AccessTokenOut
from guided_sfm.core.errors import InvalidInput
from guided_sfm.db import queries

router = APIRouter(prefix="/tokens", tags=["tokens"])


@router.post("", status_code=201, response_model=AccessTokenCreated)
def create(body: AccessTokenCreate, session: SessionDep, user: SessionUser) -> AccessTokenCreated:
    """A token for scripts and CI; only a password session can create one."""
    for pid in body.projects or []:
        if queries.role_of(session, pid, user.id) is None:
            raise InvalidInput(f"projects: you have no role in project {pid}")
    row, secret = tokens.create(session, user, body.name, body.scope, body.projects, body.expires_days)
    return AccessTokenCreated(**AccessTokenOut.model_validate(row).model_dump(), token=secret)


@router.get("", response_model=list[AccessTokenOut])
def list_tokens(session: SessionDep, user: CurrentUser) -> list[AccessTokenOut]:
    return [AccessTokenOut.model_validate(row) for row in tokens.owned(session, user.id)]


@router.delete("/{token_id}", status_code=204)
def revoke(token_id: PathId, session: SessionDep, user: CurrentUser) -> Response:
    """Revoke one of your tokens; a token may revoke itself (a leaked CI key can be killed by it)."""
    tokens.revoke(session, user.id, token_id)
    return Response(status_code=204)
