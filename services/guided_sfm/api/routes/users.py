"""Sign-up and password change."""

from fastapi import APIRouter, Response

from guided_sfm.actions import accounts, tokens
from guided_sfm.api import security
from guided_sfm.api.deps import ClientAddress, SessionDep, SessionUser, SettingsDep, ThrottleDep
from guided_sfm.api.schemas import PasswordChange, UserCreate, UserOut
from guided_sfm.db.models import User

router = APIRouter(prefix="/users", tags=["users"])


@router.post("", status_code=201, response_model=UserOut)
def sign_up(body: UserCreate, session: SessionDep, settings: SettingsDep, throttle: ThrottleDep,
            address: ClientAddress) -> User:
    """Create an account (when open sign-up is on)."""
    throttle.check("address", address)
    throttle.record("address", address)
    return accounts.sign_up(session, settings.open_signup, body.username, body.password,
                            security.hash_password)


@router.post("/me/password", status_code=204)
def change_password(body: PasswordChange, session: SessionDep, user: SessionUser) -> Response:
    """A new password; session tokens issued before it stop working (access tokens stay)."""
    tokens.change_password(session, user, body.old_password, body.new_password,
                           security.verify_password, security.hash_password)
    return Response(status_code=204)
