"""Sign-up."""

from fastapi import APIRouter

from guided_sfm.actions import accounts
from guided_sfm.api import security
from guided_sfm.api.deps import ClientAddress, SessionDep, SettingsDep, ThrottleDep
from guided_sfm.api.schemas import UserCreate, UserOut
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
