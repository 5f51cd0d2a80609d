"""GET /healthz: the process is up and its database answers."""

from __future__ import annotations

import raydamp
from fastapi import APIRouter

from ..deps import SettingsDep, StoreDep
from ..schemas import Health

router = APIRouter(tags=["health"])


@router.get("/healthz", response_model=Health)
def healthz(store: StoreDep, settings: SettingsDep) -> Health:
    store.ping()
    return Health(status="ok", version=raydamp.__version__, workers=settings.workers)
