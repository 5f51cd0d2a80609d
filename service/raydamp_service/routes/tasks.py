"""What the routes share: their dependencies (app.state's objects, as coroutines: FastAPI runs a plain function
in its thread pool, a hop costing more than the work), and a task's lifecycle routes (jobs, sweeps)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Annotated, Any

from fastapi import Depends, HTTPException, Request, Response
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError

from ..checks.limits import JobError
from ..checks.pool import CheckPool
from ..config import Settings
from ..kinds.jobs import JobStore
from ..kinds.sweeps import SweepStore
from ..tasks.runner import Runner
from ..tasks.store import FINAL_STATUSES, FileGone, TaskStore

__all__ = ["Tasks", "fields", "invalid", "check_limit", "checks_busy", "checks_busy_handler", "SettingsDep",
           "StoreDep", "RunnerDep", "ChecksDep", "SweepsDep", "SweepRunnerDep"]


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


def fields(record: Any) -> dict[str, Any]:
    """A record's fields by name, not copied: a view takes those it shows."""
    return {field.name: getattr(record, field.name) for field in dataclasses.fields(record)}


def invalid(error: JobError, body: Any = None) -> RequestValidationError:
    """A JobError as the same shape as pydantic's own 422s, so a client reads one format."""
    return RequestValidationError([{"type": "value_error", "loc": ("body", *error.loc), "msg": error.message,
                                    "input": _value_at(body, error.loc)}])


def _value_at(data: Any, loc: tuple[str | int, ...]) -> Any:
    for key in loc:
        if isinstance(data, dict):
            data = data.get(key)
        elif isinstance(data, list) and isinstance(key, int) and 0 <= key < len(data):
            data = data[key]
        else:
            return None
    return data


def checks_busy(settings: Settings, error: Exception | None = None) -> HTTPException:
    """The 429 of a check that finds max_pending_checks checks under way, or the machine too loaded to end it."""
    return HTTPException(429, detail=str(error or "") or f"{settings.max_pending_checks} checks of submitted systems "
                         "are running or waiting (max_pending_checks); retry later",
                         headers={"Retry-After": str(settings.retry_after_seconds)})


async def checks_busy_handler(request: Request, error: Exception) -> Response:
    """A ChecksBusy out of any route (a check, a plot, an upload's parse): its 429."""
    return await http_exception_handler(request, checks_busy(request.app.state.settings, error))


def check_limit(limit: int, settings: Settings) -> None:
    if limit > settings.max_list_limit:
        raise RequestValidationError([{"type": "less_than_equal", "loc": ("query", "limit"), "input": limit,
                                       "msg": f"limit must be <= {settings.max_list_limit}"}])


class Tasks:
    """One kind's lifecycle: submit (422, 429 when the queue holds the setting max_queued names, the Location), 404,
    cancel (409 once finished) and delete (204 once finished, else a cancel); view(record, runner) is the body."""

    def __init__(self, noun: str, prefix: str, view: Callable[[Any, Runner], Any], max_queued: str):
        self.noun, self.prefix, self.view, self.max_queued = noun, prefix, view, max_queued

    def url(self, task_id: str) -> str:
        return f"{self.prefix}/{task_id}"

    def existing(self, store: TaskStore, task_id: str) -> Any:
        record = store.get(task_id)
        if record is None:
            raise HTTPException(404, detail=f"no {self.noun} with id {task_id!r}")
        return record

    def queue(self, request: Request, response: Response, store: TaskStore, runner: Runner, spec: Any,
              settings: Settings, prepare: Callable[[Any], Any] | None = None, **columns: Any) -> Any:
        """Store the checked spec as queued, hand it to the runner (as prepare(record)); 429 when the queue is full."""
        limit = getattr(settings, self.max_queued)
        try:
            record = store.create(spec.model_dump(mode="json"), limit, files=spec.uploads(), **columns)
        except FileGone as error:
            raise HTTPException(409, detail=str(error)) from None
        if record is None:
            raise HTTPException(429, detail=f"{limit} {self.noun}s are already queued ({self.max_queued}); retry later",
                                headers={"Retry-After": str(settings.retry_after_seconds)})
        runner.submit(record.id, prepare(record) if prepare is not None else record)
        # A path, never built from the Host header: a forged Host must not come back as a redirect target.
        response.headers["Location"] = request.scope.get("root_path", "") + self.url(record.id)
        return record

    def cancel(self, store: TaskStore, runner: Runner, task_id: str) -> Any:
        record = self.existing(store, task_id)
        if record.status in FINAL_STATUSES:
            raise HTTPException(409, detail=f"{self.noun} {task_id} is already {record.status}; there is nothing "
                                            "to cancel")
        return self._request_cancel(store, runner, task_id)

    def delete(self, store: TaskStore, runner: Runner, task_id: str) -> Any:
        record = self.existing(store, task_id)
        if record.status in FINAL_STATUSES and store.delete_finished(task_id):
            return Response(status_code=204)
        if record.status in FINAL_STATUSES:  # removed by another request meanwhile
            raise HTTPException(404, detail=f"no {self.noun} with id {task_id!r}")
        return self._request_cancel(store, runner, task_id)

    def _request_cancel(self, store: TaskStore, runner: Runner, task_id: str) -> Any:
        record = store.request_cancel(task_id)
        runner.cancel(task_id)
        return self.view(record, runner)
