"""A project's webhooks (owners): subscribe a URL to events, list, delete, see the last deliveries."""

from fastapi import APIRouter, Response

from guided_sfm.actions import webhooks
from guided_sfm.api.deps import OwnerProject, PathId, SessionDep, SettingsDep
from guided_sfm.api.schemas import DeliveryOut, WebhookCreated, WebhookIn, WebhookOut

router = APIRouter(prefix="/projects/{pid}/webhooks", tags=["webhooks"])


@router.post("", status_code=201, response_model=WebhookCreated)
def create(body: WebhookIn, project: OwnerProject, session: SessionDep,
           settings: SettingsDep) -> WebhookCreated:
    """Subscribe; a URL that is not http(s) or resolves to a non-public address is 422."""
    hook = webhooks.create(session, project.id, body.url, list(body.events), body.secret,
                           settings.webhook_allow_private)
    return WebhookCreated(**WebhookOut.model_validate(hook).model_dump(), secret=hook.secret)


@router.get("", response_model=list[WebhookOut])
def list_webhooks(project: OwnerProject, session: SessionDep) -> list[WebhookOut]:
    return [WebhookOut.model_validate(hook) for hook in webhooks.of_project(session, project.id)]


@router.delete("/{wid}", status_code=204)
def delete(wid: PathId, project: OwnerProject, session: SessionDep) -> Response:
    session.delete(webhooks.find(session, project.id, wid))
    session.commit()
    return Response(status_code=204)


@router.get("/{wid}/deliveries", response_model=list[DeliveryOut])
def deliveries(wid: PathId, project: OwnerProject, session: SessionDep) -> list[DeliveryOut]:
    """The last deliveries, newest first, with the receiver's status and reply."""
    hook = webhooks.find(session, project.id, wid)
    return [DeliveryOut.model_validate(row).model_copy(update={"ok": row.state == "ok"})
            for row in webhooks.deliveries(session, hook)]
