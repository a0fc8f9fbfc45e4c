"""Password hashing (pwdlib, Argon2) and bearer tokens (HS256 JWT carrying the user id)."""

from __future__ import annotations

import os
import threading
from datetime import UTC, datetime, timedelta

import jwt
from pwdlib import PasswordHash

from guided_sfm.errors import Unauthorized

ALGORITHM = "HS256"
_hasher = PasswordHash.recommended()
# Verifying against this when the user does not exist keeps the timing the same.
_DUMMY_HASH = _hasher.hash("not a password")


# Argon2 takes 64 MiB and a core per hash: a flood of logins waits here instead of exhausting both.
_slots = threading.BoundedSemaphore(max(2, os.cpu_count() or 2))


def hash_password(password: str) -> str:
    with _slots:
        return _hasher.hash(password)


def verify_password(password: str, password_hash: str | None) -> bool:
    with _slots:
        if password_hash is None:
            _hasher.verify(password, _DUMMY_HASH)
            return False
        return _hasher.verify(password, password_hash)


def issue_token(user_id: int, secret: str, minutes: int, epoch: int = 0) -> str:
    """A session token; `epoch` is the user's token epoch, which a password change moves on."""
    expires = datetime.now(UTC) + timedelta(minutes=minutes)
    return jwt.encode({"sub": str(user_id), "ep": epoch, "exp": expires}, secret, algorithm=ALGORITHM)


def session_claims(token: str, secret: str) -> tuple[int, int]:
    """(user id, epoch) of a valid session token; tokens from before epochs existed count as 0."""
    try:
        claims = jwt.decode(token, secret, algorithms=[ALGORITHM], options={"require": ["sub", "exp"]})
        return int(claims["sub"]), int(claims.get("ep", 0))
    except (jwt.PyJWTError, ValueError, TypeError) as exc:
        raise Unauthorized("the token is invalid or expired; sign in again") from exc
