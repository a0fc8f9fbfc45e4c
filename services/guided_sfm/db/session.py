"""Engine and session factory from Settings; SQLite gets foreign keys, WAL and real transactions.

On SQLite every transaction takes the write lock up front (BEGIN IMMEDIATE) unless its session was
marked read-only: a deferred transaction that read and then writes fails at once with "database is
locked" when another connection committed in between (the busy timeout does not apply to that
upgrade), so concurrent saves, uploads and a worker's heartbeat would fail each other."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm.settings import Settings

SQLITE_BUSY_SECONDS = 30  # the API and the worker write the same file in the embedded mode
READ_ONLY = "guided_sfm_read_only"  # execution option: a transaction that never writes


def make_engine(database_url: str, **kwargs: Any) -> Engine:
    if not database_url.startswith("sqlite"):
        return create_engine(database_url, pool_pre_ping=True, **kwargs)
    engine = create_engine(
        database_url,
        connect_args={"check_same_thread": False, "timeout": SQLITE_BUSY_SECONDS},
        **kwargs,
    )
    event.listen(engine, "connect", _sqlite_connect)
    event.listen(engine, "begin", _sqlite_begin)
    return engine


def _sqlite_connect(dbapi_connection: Any, _record: Any) -> None:
    # pysqlite's own implicit transactions break SAVEPOINT and transactional DDL; SQLAlchemy
    # emits BEGIN itself (see _sqlite_begin), as its documentation recommends.
    dbapi_connection.isolation_level = None
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_SECONDS * 1000}")
    for _seq, name, path in cursor.execute("PRAGMA database_list").fetchall():
        if name == "main" and path:
            _owner_only(Path(path))
    cursor.close()


def _owner_only(database: Path) -> None:
    """The database file and its WAL and shared-memory companions: readable by their owner only."""
    for path in (database, *(database.with_name(database.name + suffix) for suffix in ("-wal", "-shm"))):
        with contextlib.suppress(FileNotFoundError, PermissionError):
            if path.stat().st_mode & 0o077:
                path.chmod(0o600)


def _sqlite_begin(connection: Any) -> None:
    read_only = connection.get_execution_options().get(READ_ONLY, False)
    connection.exec_driver_sql("BEGIN" if read_only else "BEGIN IMMEDIATE")


def read_only(session: Session) -> Session:
    """Mark a fresh session's transactions as reads (SQLite then takes no write lock; WAL readers
    never wait for writers); call it before the session's first query."""
    session.connection(execution_options={READ_ONLY: True})
    return session


def make_sessionmaker(settings_or_engine: Settings | Engine) -> sessionmaker[Session]:
    engine = (
        make_engine(settings_or_engine.database_url)
        if isinstance(settings_or_engine, Settings)
        else settings_or_engine
    )
    return sessionmaker(bind=engine, expire_on_commit=False)


@contextmanager
def session_scope(sessions: sessionmaker[Session]) -> Iterator[Session]:
    """A session for a task or a thread: committed by the caller, always closed."""
    session = sessions()
    try:
        yield session
    except BaseException:
        session.rollback()
        raise
    finally:
        session.close()
