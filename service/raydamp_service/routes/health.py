"""GET /healthz: the process is up and its database answers."""

from __future__ import annotations

from fastapi import APIRouter

import raydamp

from ..schemas import Health
from .tasks import SettingsDep, StoreDep

router = APIRouter(tags=["health"])


@router.get("/healthz", response_model=Health)
async def healthz(store: StoreDep, settings: SettingsDep) -> Health:
    # On the event loop, not the thread pool: a probe answers while every pool thread is busy
    # streaming, and SELECT 1 on a WAL database never waits for a writer.
    store.ping()
    return Health(status="ok", version=raydamp.__version__, workers=settings.workers)
