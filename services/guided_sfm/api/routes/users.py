"""Sign-up."""

from fastapi import APIRouter
from sqlalchemy.exc import IntegrityError

from guided_sfm.api import security
from guided_sfm.api.deps import SessionDep, SettingsDep
from guided_sfm.api.schemas import UserCreate, UserOut
from guided_sfm.db.models import User
from guided_sfm.errors import Conflict, Forbidden

router = APIRouter(prefix="/users", tags=["users"])


@router.post("", status_code=201, response_model=UserOut)
def sign_up(body: UserCreate, session: SessionDep, settings: SettingsDep) -> User:
    """Create an account (when open sign-up is on)."""
    if not settings.open_signup:
        raise Forbidden("sign-up is closed on this server (GUIDED_SFM_OPEN_SIGNUP=false)")
    user = User(username=body.username, password_hash=security.hash_password(body.password))
    session.add(user)
    try:
        session.commit()
    except IntegrityError as exc:
        session.rollback()
        raise Conflict(f"the username {body.username!r} is taken") from exc
    return user
