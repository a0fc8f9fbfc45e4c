"""Personal access tokens (secret shown once, kept as a SHA-256 digest) and password change."""

from __future__ import annotations

import hashlib
import secrets
from collections.abc import Callable
from datetime import datetime, timedelta

from sqlalchemy import select, update
from sqlalchemy.orm import Session

from guided_sfm.db.models import AccessToken, User, utcnow
from guided_sfm.errors import Conflict, Forbidden, NotFound, Unauthorized

PREFIX = "gsfm_"  # tells a personal token from a session JWT at a glance, in logs and in code
READ_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})


def digest(secret: str) -> str:
    # A plain hash suffices: the secret has 256 random bits, unlike a password.
    return hashlib.sha256(secret.encode()).hexdigest()


def is_personal(token: str) -> bool:
    return token.startswith(PREFIX)


def create(session: Session, user: User, name: str, scope: str, projects: list[int] | None,
           expires_days: int | None) -> tuple[AccessToken, str]:
    """The stored token and its secret (never stored); projects must be the user's own."""
    secret = PREFIX + secrets.token_urlsafe(32)
    expires = utcnow() + timedelta(days=expires_days) if expires_days else None
    row = AccessToken(user_id=user.id, name=name, scope=scope, digest=digest(secret),
                      projects=sorted(set(projects)) if projects is not None else None,
                      expires_at=expires)
    session.add(row)
    session.commit()
    return row, secret


def owned(session: Session, user_id: int) -> list[AccessToken]:
    query = select(AccessToken).where(AccessToken.user_id == user_id).order_by(AccessToken.id)
    return list(session.scalars(query))


def revoke(session: Session, user_id: int, token_id: int) -> None:
    """Delete the token: the next request that sends it is refused. Another's token looks absent."""
    row = session.get(AccessToken, token_id)
    if row is None or row.user_id != user_id:
        raise NotFound(f"token {token_id} not found")
    session.delete(row)
    session.commit()


def resolve(session: Session, secret: str, now: datetime | None = None) -> AccessToken:
    """The live token this secret belongs to; Unauthorized when unknown, revoked or expired."""
    row = session.scalar(select(AccessToken).where(AccessToken.digest == digest(secret)))
    now = now or utcnow()
    if row is None:
        raise Unauthorized("the access token is unknown or revoked")
    if row.expires_at is not None and row.expires_at <= now:
        raise Unauthorized(f"the access token {row.name!r} expired; create a new one")
    return row


def allows(token: AccessToken | None, method: str) -> None:
    """Forbidden when a read-only token asks for a change."""
    if token is not None and token.scope == "read" and method not in READ_METHODS:
        raise Forbidden(f"the access token {token.name!r} is read-only; this request changes data")


def change_password(session: Session, user: User, old: str, new: str,
                    verify: Callable[[str, str], bool], hash_password: Callable[[str], str]) -> None:
    """A new password and a new token epoch, which ends every session token issued before.
    Argon2 runs with no transaction open (on SQLite: no write lock held for its half second); the
    write is a compare-and-set on the hash it checked, so of two changes at once one wins."""
    user_id, stored = user.id, user.password_hash
    session.commit()
    if not verify(old, stored):
        raise Forbidden("the old password is wrong")
    fresh = hash_password(new)
    result = session.execute(update(User).where(User.id == user_id, User.password_hash == stored)
                             .values(password_hash=fresh, token_epoch=User.token_epoch + 1))
    session.commit()
    if result.rowcount != 1:
        raise Conflict("the password was changed meanwhile; sign in again")
