"""GET /healthz: the process is up and its database answers."""

from __future__ import annotations

from fastapi import APIRouter

import raydamp

from ..schemas import Health
from .tasks import SettingsDep, StoreDep

router = APIRouter(tags=["health"])


@router.get("/healthz", response_model=Health)
async def healthz(store: StoreDep, settings: SettingsDep) -> Health:
    # On the event loop: it answers while every pool thread streams, and SELECT 1 never waits for a writer (WAL).
    store.ping()
    return Health(status="ok", version=raydamp.__version__, workers=settings.workers)
