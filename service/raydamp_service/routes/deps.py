"""Request dependencies: the objects the lifespan put on app.state, overridable in tests.

They are coroutines on purpose: FastAPI runs a plain-function dependency in its thread pool,
and a hop there and back for each of them (three per submission) cost more than the
submission's own work under load. That is right only for dependencies that do no blocking
work, as these (they read app.state): one that queried SQLite would have to stay a plain
function, and tests/service/test_dependencies.py would have to name it as the exception."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from ..checks.pool import CheckPool
from ..config import Settings
from ..kinds.jobs import JobStore
from ..tasks.runner import Runner

__all__ = ["SettingsDep", "StoreDep", "RunnerDep", "ChecksDep", "get_settings", "get_store", "get_runner", "get_checks"]


async def get_settings(request: Request) -> Settings:
    return request.app.state.settings


async def get_store(request: Request) -> JobStore:
    return request.app.state.store


async def get_runner(request: Request) -> Runner:
    return request.app.state.runner


async def get_checks(request: Request) -> CheckPool:
    return request.app.state.checks


SettingsDep = Annotated[Settings, Depends(get_settings)]
StoreDep = Annotated[JobStore, Depends(get_store)]
RunnerDep = Annotated[Runner, Depends(get_runner)]
ChecksDep = Annotated[CheckPool, Depends(get_checks)]
