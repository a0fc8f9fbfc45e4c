"""The webhook sender: a thread in every worker's main process that posts due deliveries from the
outbox (actions.webhooks) about once a second; several workers share the outbox safely."""

from __future__ import annotations

import logging
import threading

import httpx

from guided_sfm.actions import webhooks
from guided_sfm.db.session import make_sessionmaker, session_scope
from guided_sfm.settings import Settings

log = logging.getLogger(__name__)
POLL_SECONDS = 1.0
BACKOFF_SECONDS = 30.0  # after an error of the database itself


class Deliverer(threading.Thread):
    def __init__(self, settings: Settings) -> None:
        super().__init__(name="guided-sfm-webhooks", daemon=True)
        self.settings = settings
        self.stopped = threading.Event()

    def run(self) -> None:
        sessions = make_sessionmaker(self.settings)
        try:
            with httpx.Client(follow_redirects=False) as client:
                while not self.stopped.wait(self._round(sessions, client)):
                    pass
        finally:
            sessions.kw["bind"].dispose()

    def _round(self, sessions, client: httpx.Client) -> float:
        """One pass; the seconds to wait before the next. Never lets an error end the thread."""
        try:
            with session_scope(sessions) as session:
                webhooks.deliver_due(session, self.settings, client)
            return POLL_SECONDS
        except Exception:
            log.warning("webhook deliveries failed; retrying in %s s", BACKOFF_SECONDS, exc_info=True)
            return BACKOFF_SECONDS

    def stop(self) -> None:
        self.stopped.set()
