"""A job's patience with the artifact store (operations.md, "The store unavailable"). Each store
call already tries a few times within seconds; an outage longer than that (a restart, a network
cut) would fail a job that has mapped for an hour. So a step that meets StoreUnavailable runs again
after a pause that doubles (1 s, 2 s, ... at most 30 s), the job's row saying it waits for the
store, until the store has been away for GUIDED_SFM_STORE_WAIT_SECONDS (since it last answered: a
try that fetched for minutes before a call failed meets a new outage); then the job fails naming
the store. A step runs again whole, so it must be safe to repeat: fetching inputs into emptied
scratch, publishing under a new key (what a failed try left is the reconciler's)."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import TypeVar

from guided_sfm.core.sfm import CancelToken
from guided_sfm.storage import StoreUnavailable

log = logging.getLogger(__name__)
T = TypeVar("T")
FIRST_PAUSE, LONGEST_PAUSE = 1.0, 30.0
CANCEL_POLL = 0.5  # a cancel (or the time limit) ends a pause within this many seconds


class StoreOutage(Exception):
    """The store stayed away longer than a job waits for it."""


class StoreWait:
    """run(step): the step's result, waiting out the store's absences of up to `patience` seconds;
    `say(message)` puts what the job is doing on its row; `answered()` when the store last
    answered a call (time.monotonic(), None if never)."""

    def __init__(self, patience: float, say: Callable[[str], None], cancel: CancelToken,
                 answered: Callable[[], float | None] = lambda: None) -> None:
        self.patience, self.say, self.cancel, self.answered = patience, say, cancel, answered

    def run(self, step: Callable[[], T]) -> T:
        away_since, pause = None, FIRST_PAUSE
        while True:
            try:
                result = step()
            except StoreUnavailable as exc:
                last = self.answered()
                if away_since is None:
                    away_since = time.monotonic()
                elif last is not None and last > away_since:  # back meanwhile: a new outage
                    away_since, pause = last, FIRST_PAUSE
                away = time.monotonic() - away_since
                if away >= self.patience:
                    raise StoreOutage(
                        f"{exc} for {away:.0f} s, longer than a job waits for it "
                        f"(GUIDED_SFM_STORE_WAIT_SECONDS={self.patience:g}); the project's head is "
                        "unchanged") from exc
                pause = min(pause, LONGEST_PAUSE, self.patience - away)
                self.say(f"waiting for the artifact store: {exc}; trying again in {math.ceil(pause)} s "
                         f"(away {away:.0f} s of the {self.patience:g} s a job waits)")
                log.warning("%s; trying again in %.1f s", exc, pause)
                self._sleep(pause)
                pause *= 2
                continue
            if away_since is not None:
                self.say(f"the artifact store answered again after {time.monotonic() - away_since:.0f} s")
            return result

    def _sleep(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            self.cancel.check()
            time.sleep(min(left, CANCEL_POLL))
        self.cancel.check()
