"""/v1/jobs: submit, list, inspect and cancel integration jobs, and fetch their trajectories. Handlers run in the
thread pool (SQLite reads never hold up the event loop) but the submission, whose insert is one short write."""

from __future__ import annotations

import secrets
import tempfile
import threading
from pathlib import Path
from typing import Annotated, Literal

from fastapi import APIRouter, HTTPException, Query, Request, Response
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError
from starlette.background import BackgroundTask
from starlette.concurrency import run_in_threadpool

from raydamp.jobs import validation_error

from ..checks.limits import JobError, RaydampCall
from ..checks.pool import CheckPool, PlotOverBudget, checked_inline
from ..config import Settings
from ..edge.deadlines import TimedFileResponse, TimedStreamingResponse
from ..edge.http import HEAD, UniqueKeysRoute
from ..kinds.jobs import JobRecord, JobStore
from ..schemas import JobCreated, JobList, JobListItem, JobSpec, JobStatus, JobView, Trajectory
from ..tasks.runner import Runner
from ..tasks.store import FINAL_STATUSES
from ..trajectories.downloads import draw_plot, events_file, write_file
from ..trajectories.stream import FetchLease, read_arrays, trajectory_chunks
from .tasks import RunnerDep, SettingsDep, StoreDep, Tasks, check_limit, fields, invalid

router = APIRouter(prefix="/v1/jobs", tags=["jobs"], route_class=UniqueKeysRoute)

_NOT_FOUND = {404: {"description": "no job with this id"}}


def _view(record: JobRecord, runner: Runner) -> JobView:
    return JobView(**{**fields(record), "progress": runner.progress(record.id, record.status, record.progress)},
                   trajectory=JOBS.url(record.id) + "/trajectory" if record.has_trajectory else None)


JOBS = Tasks("job", "/v1/jobs", _view, "max_queued")


def with_seed(spec: JobSpec) -> JobSpec:
    """A job at a temperature gets a seed now, stored with it: a rerun after a restart draws the same noise."""
    if spec.temperature and spec.seed is None:
        return spec.model_copy(update={"seed": secrets.randbits(64)})
    return spec


@router.post("", status_code=202, response_model=JobCreated,
             responses={400: {"description": "the body is not UTF-8 text, or the Host is not one of trusted_hosts"},
                        422: {"description": "the spec is invalid; detail[].loc names the field"},
                        409: {"description": "an uploaded file the spec names was deleted while it was checked"},
                        429: {"description": "max_queued jobs are waiting, or max_pending_checks checks of "
                                             "systems are under way; retry after Retry-After seconds"}})
async def submit_job(spec: JobSpec, request: Request, response: Response) -> JobCreated:
    """Queue an integration; poll the Location for its status. A system is checked (compiled, one trial
    step) in a check process within check_seconds and check_memory_bytes: past either, 422 on system."""
    # app.state, not four Depends: solving them costs a sixth of the POST's CPU.
    state = request.app.state
    store, runner, settings, checks = state.store, state.runner, state.settings, state.checks
    spec = with_seed(spec)
    if checked_inline(spec):  # microseconds: a hop to the thread pool would cost more than the check
        call = _check(spec, store, checks)
    else:  # waits for a check process, or reads uploaded files (whose arrays a queued job should not hold)
        call = await run_in_threadpool(_check, spec, store, checks) and None
    record = JOBS.queue(request, response, store, runner, spec, settings, prepare=lambda row: row.checked(spec, call))
    return JobCreated(id=record.id, status=record.status)


def _check(spec: JobSpec, store: JobStore, checks: CheckPool) -> RaydampCall | None:
    try:
        return checks.job(spec, files=store.parsed_files)
    except JobError as error:
        raise invalid(error, spec.model_dump()) from None


@router.get("", response_model=JobList)
def list_jobs(store: StoreDep, runner: RunnerDep, settings: SettingsDep,
              limit: Annotated[int, Query(ge=1, description="at most this many jobs, newest first")] = 50,
              status: Annotated[JobStatus | None, Query(description="only jobs in this state")] = None) -> JobList:
    check_limit(limit, settings)
    return JobList(jobs=[
        JobListItem(id=r["id"], status=r["status"], progress=runner.progress(r["id"], r["status"], r["progress"]),
                    model=r["label"], method=r["method"] or "chosen by raydamp", created_at=r["created_at"],
                    finished_at=r["finished_at"], url=JOBS.url(r["id"]))
        for r in store.listing(limit, status)])


@router.get("/{job_id}", response_model=JobView, responses=_NOT_FOUND)
def get_job(job_id: str, store: StoreDep, runner: RunnerDep) -> JobView:
    """Status, progress, and once finished the summary; a blow-up is "failed" with the solver's reason."""
    return _view(JOBS.existing(store, job_id), runner)


@router.get("/{job_id}/trajectory", response_model=Trajectory,
            responses={**_NOT_FOUND, 409: {"description": "the job has no trajectory (yet)"},
                       # the files ?format= writes, beside the JSON of the response model
                       200: {"content": {"text/csv": {}, "application/octet-stream": {}, "application/x-netcdf": {}}},
                       429: {"description": "max_large_fetches large fetches are being served; retry after "
                                            "Retry-After seconds, or ask for fewer points"}})
def get_trajectory(job_id: str, request: Request, store: StoreDep, settings: SettingsDep,
                   start: Annotated[int, Query(ge=0, description="first saved point (0-based)")] = 0,
                   stop: Annotated[int | None, Query(ge=0, description="end before this point (default: all)")] = None,
                   every: Annotated[int, Query(ge=1, description="every this many points")] = 1,
                   format: Annotated[Literal["json", "csv", "npz", "netcdf", "nc"], Query(  # noqa: A002 - the API's name
                       description="json (streamed), or a file: csv (the numbers), npz or netcdf (nc: the same; with "
                                   "the job spec as provenance; raydamp.load reads them)")] = "json") -> Response:
    """The saved points start, start + every, ... before stop, streamed as JSON or written as a file."""
    record = JOBS.existing(store, job_id)
    spec = None if format == "json" else _spec(record)
    connection, stored = _opened(record, store)
    selection = range(stored.points)[start:stop:every]
    if spec is not None:  # a file, written a slice at a time (downloads.write_file) and sent from disk
        if len(selection) == 0:
            connection.close()
            raise RequestValidationError([{"type": "value_error", "loc": ("query", "start"), "input": start, "msg":
                                           f"start, stop, every select none of the {stored.points} saved points"}])
        fmt = "netcdf" if format == "nc" else format
        return _file(record, request, settings, connection, len(selection) * stored.row_bytes,
                     lambda directory: write_file(record, spec, connection, stored, selection, fmt, directory))
    try:
        # A HEAD of the streamed JSON reads no body: no slot (a file's HEAD takes one: it writes the file).
        lease = FetchLease(None if request.scope.get(HEAD) else
                           _large_slot(request, settings, len(selection) * stored.row_bytes))
    except HTTPException:
        connection.close()
        raise
    # Not validated against the response model: the pieces are written to have exactly its schema.
    return TimedStreamingResponse(trajectory_chunks(connection, stored, selection, lease),
                                  media_type="application/json", background=BackgroundTask(lease.release),
                                  send_seconds=settings.send_timeout_seconds,
                                  min_rate=settings.min_send_bytes_per_second)


def _opened(record: JobRecord, store: JobStore):
    """The job's stored trajectory (store.open_trajectory), or 409 saying why there is none."""
    opened = store.open_trajectory(record.id)
    if opened is None:
        if record.status not in FINAL_STATUSES:
            raise HTTPException(409, detail=f"job {record.id} is {record.status}; its trajectory is stored when the "
                                "run ends")
        raise HTTPException(409, detail=f"job {record.id} is {record.status} and has no trajectory"
                            + (f": {record.error}" if record.error else ""))
    return opened


def _spec(record: JobRecord) -> JobSpec:
    """The stored spec validated, for a file or a plot; 409 if this version refuses what an earlier one stored."""
    try:
        return JobSpec.model_validate(record.spec)
    except ValidationError as error:
        raise HTTPException(409, detail=f"job {record.id} was stored by an earlier version whose spec this one "
                            f"refuses ({validation_error(error)}); its trajectory is served as JSON only") from None


def _large_slot(request: Request, settings: Settings, selected_bytes: int) -> threading.Semaphore | None:
    """The large-fetch slot a fetch, file or plot reading this many stored bytes needs (None for a small one)."""
    if selected_bytes <= settings.large_fetch_bytes:
        return None
    semaphore = request.app.state.large_fetches
    if not semaphore.acquire(blocking=False):
        raise HTTPException(429, detail=f"{settings.max_large_fetches} large trajectory fetches are being served "
                            "(max_large_fetches); retry, or ask for fewer points with every/stop",
                            headers={"Retry-After": "1"})
    return semaphore


def _file(record: JobRecord, request: Request, settings: Settings, connection, selected_bytes: int, write) -> Response:
    """write(directory) -> (path, media type), sent from disk; the connection, directory and slot given back."""
    try:
        download = FetchLease(_large_slot(request, settings, selected_bytes),
                              directory := Path(tempfile.mkdtemp(prefix="raydamp-download-")))
        try:
            path, media_type = write(directory)
        except BaseException:
            download.release()
            raise
    finally:
        connection.close()
    return TimedFileResponse(path, media_type=media_type, background=BackgroundTask(download.release),
                             headers={"Content-Disposition": f'attachment; filename="{record.id}-{path.name}"'},
                             send_seconds=settings.send_timeout_seconds, min_rate=settings.min_send_bytes_per_second)


@router.get("/{job_id}/events.csv", response_class=Response,
            responses={**_NOT_FOUND, 200: {"content": {"text/csv": {}}, "description": "the events table as CSV"},
                       409: {"description": "the job has no trajectory (yet), or watched no events"}})
def get_events(job_id: str, request: Request, store: StoreDep, settings: SettingsDep) -> Response:
    """The job's events table: one line per crossing (name, t, direction, and q, p at the saved coordinates of a
    model of at most 8), the first 1000 as the summary lists them."""
    record = JOBS.existing(store, job_id)
    spec = _spec(record)
    if spec.events is None:
        raise HTTPException(409, detail=f"job {record.id} watched no events (its spec has no \"events\")")
    connection, stored = _opened(record, store)
    return _file(record, request, settings, connection, 0, lambda directory: (
        events_file(record, spec, connection, stored, directory), "text/csv"))


_PLOT_POINTS = 20_000  # points drawn at most: a plot of more is decimated evenly


@router.get("/{job_id}/plots/{kind}.png", response_class=Response,
            responses={**_NOT_FOUND, 200: {"content": {"image/png": {}}, "description": "a PNG image"},
                       409: {"description": "the job has no trajectory (yet)"},
                       422: {"description": "a plot this system cannot have (a projection of one coordinate), "
                                            "an unknown coordinate, or one whose drawing passes a check's budget"},
                       429: {"description": "max_large_fetches large fetches are being served, or "
                                            "max_pending_checks checks and plots are under way; retry after "
                                            "Retry-After seconds"}})
def get_plot(job_id: str, kind: Literal["energy", "phase", "projection"], request: Request, store: StoreDep,
             settings: SettingsDep,
             width: Annotated[int, Query(ge=200, le=3000, description="pixels")] = 800,
             height: Annotated[int, Query(ge=150, le=3000, description="pixels")] = 500,
             coordinate: Annotated[str | None, Query(max_length=100, description="phase: the coordinate "
                                                     "(name or index; default the first)")] = None,
             x: Annotated[str | None, Query(max_length=100, description="projection: horizontal coordinate")] = None,
             y: Annotated[str | None, Query(max_length=100, description="projection: vertical coordinate")] = None,
             ) -> Response:
    """energy: H(t) (and H - H0 + W when recorded); phase: (q_i, p_i); projection: (q_x, q_y). At most 20,000
    points and max_plot_bytes of stored floats are drawn, decimated evenly."""
    record = JOBS.existing(store, job_id)
    spec = _spec(record)

    def pick(value: str | None):  # a coordinate's name, or its index (ASCII digits: int() refuses "²")
        return int(value) if value is not None and value.isascii() and value.isdecimal() else value

    options = {"width": width, "height": height, "coordinate": pick(coordinate), "x": pick(x), "y": pick(y)}
    connection, stored = _opened(record, store)
    try:  # a place among the checks, then a large-fetch slot, are taken before any stored array is read
        points = max(2, min(_PLOT_POINTS, settings.max_plot_bytes // stored.row_bytes))
        selection = range(0, stored.points, max(1, -(-stored.points // points)))

        def read():
            lease = FetchLease(_large_slot(request, settings, len(selection) * stored.row_bytes))
            try:
                return read_arrays(connection, stored, selection)
            finally:
                lease.release()

        png = request.app.state.checks.plot(read, draw_plot, record, spec, kind, options)  # drawn in a check process
    except PlotOverBudget as error:
        raise RequestValidationError([{"type": "value_error", "loc": ("query", "width"), "msg": str(error),
                                       "input": width}]) from None
    except ValueError as error:
        field = str(error).partition(": ")[0]  # raydamp names the argument: coordinate, x, y, or the plot's kind
        loc = ("query", field) if field in ("coordinate", "x", "y") else ("path", "kind")
        raise RequestValidationError([{"type": "value_error", "loc": loc, "msg": str(error), "input": None}]) from None
    finally:
        connection.close()
    return Response(png, media_type="image/png")


@router.post("/{job_id}/cancel", status_code=202, response_model=JobView,
             responses={**_NOT_FOUND, 409: {"description": "the job has already finished"}})
def cancel_job(job_id: str, store: StoreDep, runner: RunnerDep) -> JobView:
    """Cancel a queued job at once, or stop a running one (it ends "cancelled" with its partial trajectory)."""
    return JOBS.cancel(store, runner, job_id)


@router.delete("/{job_id}", status_code=202, response_model=JobView,
               responses={**_NOT_FOUND, 204: {"description": "the finished job and its trajectory were removed"}})
def delete_job(job_id: str, store: StoreDep, runner: RunnerDep) -> JobView | Response:
    """A finished job is removed with its trajectory (204); a queued or running one is cancelled as by
    POST /v1/jobs/{id}/cancel (202), and a second DELETE once it has stopped removes it."""
    return JOBS.delete(store, runner, job_id)
