"""Bearer tokens for username + password (OAuth2 password form)."""

from typing import Annotated

from fastapi import APIRouter, Depends
from fastapi.security import OAuth2PasswordRequestForm

from guided_sfm.api import security
from guided_sfm.api.deps import ClientAddress, SessionDep, SettingsDep, ThrottleDep
from guided_sfm.api.schemas import TokenOut
from guided_sfm.db import queries
from guided_sfm.errors import Unauthorized

router = APIRouter(prefix="/auth", tags=["auth"])


@router.post("/token", response_model=TokenOut)
def token(form: Annotated[OAuth2PasswordRequestForm, Depends()], session: SessionDep,
          settings: SettingsDep, throttle: ThrottleDep, address: ClientAddress) -> TokenOut:
    throttle.check("address", address)
    throttle.check("user", form.username)
    throttle.record("address", address)
    user = queries.user_by_name(session, form.username) if "\x00" not in form.username else None
    user_id, stored_hash, epoch = (user.id, user.password_hash, user.token_epoch) if user else (None, None, 0)
    session.close()  # Argon2 takes a while and much memory: hold no connection (nor lock) meanwhile
    if not security.verify_password(form.password, stored_hash):
        throttle.record("user", form.username)
        raise Unauthorized("wrong username or password")
    throttle.forget("user", form.username)
    return TokenOut(access_token=security.issue_token(user_id, settings.secret_key or "",
                                                      settings.token_minutes, epoch))
