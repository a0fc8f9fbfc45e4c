"""Webhooks: subscriptions per project, an outbox of deliveries written in the transaction of the
change they report, and the sender that posts them (signed) and retries with back-off."""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
import json
import secrets
import socket
from collections.abc import Callable
from datetime import datetime, timedelta
from typing import Any
from urllib.parse import urlsplit

import httpx
from sqlalchemy import select, update
from sqlalchemy.orm import Session

from guided_sfm.core.errors import InvalidInput
from guided_sfm.db.models import WEBHOOK_EVENTS, Job, Version, Webhook, WebhookDelivery, utcnow
from guided_sfm.errors import NotFound
from guided_sfm.settings import PREFIX, Settings

SIGNATURE_HEADER = "X-Guided-SFM-Signature"
ANSWER_CHARS = 500  # of a receiver's reply kept for the deliveries list
LISTED = 50  # deliveries listed per webhook, newest first
Resolver = Callable[[str], list[str]]


def resolve(host: str) -> list[str]:
    return sorted({info[4][0] for info in socket.getaddrinfo(host, None)})


def refusal(url: str, allow_private: bool, resolver: Resolver = resolve) -> str | None:
    """Why `url` may not receive webhooks (None when it may): not http(s), no host, a host that
    does not resolve, or one resolving to loopback, link-local or private addresses."""
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        return f"url must be an http(s) URL with a host, got {url!r}"
    if allow_private:
        return None
    try:
        addresses = resolver(parts.hostname)
    except OSError as exc:
        return f"url host {parts.hostname!r} does not resolve ({exc})"
    for address in addresses:
        ip = ipaddress.ip_address(address.split("%")[0])
        if not ip.is_global or ip.is_multicast:
            return (f"url host {parts.hostname!r} resolves to the non-public address {address}; "
                    f"set {PREFIX}WEBHOOK_ALLOW_PRIVATE=true to allow it")
    return None


def create(session: Session, project_id: int, url: str, events: list[str], secret: str | None,
           allow_private: bool, resolver: Resolver = resolve) -> Webhook:
    unknown = sorted(set(events) - set(WEBHOOK_EVENTS))
    if not events or unknown:
        raise InvalidInput(f"events must be a non-empty subset of {list(WEBHOOK_EVENTS)}; unknown: {unknown}")
    reason = refusal(url, allow_private, resolver)
    if reason:
        raise InvalidInput(reason)
    hook = Webhook(project_id=project_id, url=url, events=sorted(set(events)),
                   secret=secret or secrets.token_urlsafe(32))
    session.add(hook)
    session.commit()
    return hook


def of_project(session: Session, project_id: int) -> list[Webhook]:
    return list(session.scalars(select(Webhook).where(Webhook.project_id == project_id).order_by(Webhook.id)))


def find(session: Session, project_id: int, webhook_id: int) -> Webhook:
    hook = session.get(Webhook, webhook_id)
    if hook is None or hook.project_id != project_id:
        raise NotFound(f"webhook {webhook_id} not found in project {project_id}")
    return hook


def deliveries(session: Session, hook: Webhook) -> list[WebhookDelivery]:
    query = (select(WebhookDelivery).where(WebhookDelivery.webhook_id == hook.id)
             .order_by(WebhookDelivery.id.desc()).limit(LISTED))
    return list(session.scalars(query))


def emit(session: Session, project_id: int, event: str, data: dict[str, Any]) -> int:
    """Queue `event` for every webhook of the project that wants it, in the caller's transaction
    (committed with the change it reports, or not at all). Returns how many were queued."""
    hooks = [h for h in of_project(session, project_id) if event in h.events]
    now = utcnow()
    body = json.dumps({"event": event, "project_id": project_id, "at": now.isoformat(), "data": data},
                      sort_keys=True)
    for hook in hooks:
        session.add(WebhookDelivery(webhook_id=hook.id, event=event, body=body, at=now, state="pending",
                                    attempts=0, next_attempt_at=now))
    return len(hooks)


def job_finished(session: Session, job: Job, state: str, version_id: int | None = None,
                 error: str | None = None) -> None:
    emit(session, job.project_id, "job_finished", {"job_id": job.id, "kind": job.kind, "state": state,
                                                   "version_id": version_id, "error": error})


def jobs_failed_by_sweep(session: Session, job_ids: list[int]) -> None:
    """job_finished for jobs the sweeper failed (their worker died); committed here."""
    for job in session.scalars(select(Job).where(Job.id.in_(job_ids))):
        job_finished(session, job, job.state, job.version_id, job.error)
    session.commit()


def version_created(session: Session, version: Version, is_head: bool) -> None:
    emit(session, version.project_id, "version_created",
         {"version_id": version.id, "kind": version.kind, "parent_id": version.parent_id,
          "message": version.message, "is_head": is_head})


def signature(body: bytes, secret: str) -> str:
    return "sha256=" + hmac.new(secret.encode(), body, hashlib.sha256).hexdigest()


def due(session: Session, now: datetime, limit: int = 20) -> list[int]:
    query = (select(WebhookDelivery.id).where(WebhookDelivery.state == "pending",
                                              WebhookDelivery.next_attempt_at <= now)
             .order_by(WebhookDelivery.next_attempt_at).limit(limit))
    return list(session.scalars(query))


def claim(session: Session, delivery_id: int, now: datetime, lease: float) -> WebhookDelivery | None:
    """Take one attempt of a due delivery (compare-and-set on its attempts, so two senders never
    post the same attempt); the lease pushes it out of `due` while it is being sent."""
    row = session.get(WebhookDelivery, delivery_id)
    if row is None or row.state != "pending" or row.next_attempt_at > now:
        return None
    result = session.execute(
        update(WebhookDelivery).where(WebhookDelivery.id == delivery_id,
                                      WebhookDelivery.attempts == row.attempts)
        .values(attempts=row.attempts + 1, next_attempt_at=now + timedelta(seconds=lease)))
    session.commit()  # the update set the row's attempts in memory too; no reload (no new transaction)
    return row if result.rowcount == 1 else None


def send(row: WebhookDelivery, hook: Webhook, settings: Settings,
         client: httpx.Client) -> tuple[int | None, str]:
    """POST the delivery; (status code or None, the reply or the error)."""
    reason = refusal(hook.url, settings.webhook_allow_private)  # again: DNS may have changed
    if reason:
        return None, reason
    body = row.body.encode()
    headers = {"Content-Type": "application/json", SIGNATURE_HEADER: signature(body, hook.secret),
               "User-Agent": "guided-sfm-webhooks"}
    try:
        response = client.post(hook.url, content=body, headers=headers,
                               timeout=settings.webhook_timeout_seconds)
    except httpx.HTTPError as exc:
        return None, f"{type(exc).__name__}: {exc}"
    return response.status_code, response.text[:ANSWER_CHARS]


def record(session: Session, row: WebhookDelivery, status: int | None, answer: str,
           settings: Settings, now: datetime) -> None:
    """A 2xx ends the delivery; anything else retries after retry_seconds x 2^(attempts - 1)
    until the attempts run out."""
    row.status_code, row.answer = status, answer[:ANSWER_CHARS]
    if status is not None and 200 <= status < 300:
        row.state = "ok"
    elif row.attempts >= settings.webhook_attempts:
        row.state = "failed"
    else:
        delay = settings.webhook_retry_seconds * 2 ** (row.attempts - 1)
        row.next_attempt_at = now + timedelta(seconds=delay)
    session.commit()


def deliver_due(session: Session, settings: Settings, client: httpx.Client) -> int:
    """Send every delivery that is due; returns how many attempts were made."""
    made = 0
    ids = due(session, utcnow())
    session.commit()
    for delivery_id in ids:
        row = claim(session, delivery_id, utcnow(), lease=settings.webhook_timeout_seconds * 3)
        hook = session.get(Webhook, row.webhook_id) if row is not None else None
        session.commit()  # no transaction (on SQLite: no write lock) while the request is out
        if hook is None:  # taken by another sender, or the webhook was deleted meanwhile
            continue
        status, answer = send(row, hook, settings, client)
        record(session, row, status, answer, settings, utcnow())
        made += 1
    return made
