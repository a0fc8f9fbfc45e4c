"""Accounts: sign-up while it is open, with unique user names."""

from __future__ import annotations

from collections.abc import Callable

from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from guided_sfm.db.models import User
from guided_sfm.errors import Conflict, Forbidden
from guided_sfm.settings import PREFIX


def sign_up(session: Session, open_signup: bool, username: str, password: str,
            hash_password: Callable[[str], str]) -> User:
    """The new user; the password is hashed (slow on purpose) only once sign-up is known open."""
    if not open_signup:
        raise Forbidden(f"sign-up is closed on this server ({PREFIX}OPEN_SIGNUP=false)")
    user = User(username=username, password_hash=hash_password(password))
    session.add(user)
    try:
        session.commit()
    except IntegrityError as exc:  # the unique index decides between racing sign-ups
        session.rollback()
        raise Conflict(f"the username {username!r} is taken") from exc
    return user
