"""Request dependencies: the objects the lifespan put on app.state, overridable in tests. Coroutines, as they do
no blocking work: FastAPI would run a plain function in its thread pool, a hop costing more than the work
(tests/service/test_dependencies.py names the exceptions)."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from ..checks.pool import CheckPool
from ..config import Settings
from ..kinds.jobs import JobStore
from ..kinds.sweeps import SweepStore
from ..tasks.runner import Runner

__all__ = ["SettingsDep", "StoreDep", "RunnerDep", "ChecksDep", "SweepsDep", "SweepRunnerDep"]


def _state(name: str):
    """The dependency answering app.state.<name>."""

    async def dependency(request: Request):
        return getattr(request.app.state, name)

    dependency.__name__ = dependency.__qualname__ = f"get_{name}"
    return dependency


SettingsDep = Annotated[Settings, Depends(_state("settings"))]
StoreDep = Annotated[JobStore, Depends(_state("store"))]
RunnerDep = Annotated[Runner, Depends(_state("runner"))]
ChecksDep = Annotated[CheckPool, Depends(_state("checks"))]
SweepsDep = Annotated[SweepStore, Depends(_state("sweeps"))]
SweepRunnerDep = Annotated[Runner, Depends(_state("sweep_runner"))]
