"""/v1/sweeps: a job spec and a grid, run through raydamp.sweep on Dask; the result as NetCDF."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, HTTPException, Query, Request, Response

from ..checks.limits import JobError
from ..edge.deadlines import TimedStreamingResponse
from ..edge.http import UniqueKeysRoute
from ..kinds.sweeps import SweepRecord
from ..schemas import JobStatus, SweepCreated, SweepList, SweepListItem, SweepSpec, SweepView
from ..tasks.runner import Runner
from .jobs import with_seed
from .tasks import ChecksDep, SettingsDep, SweepRunnerDep, SweepsDep, Tasks, check_limit, fields, invalid

router = APIRouter(prefix="/v1/sweeps", tags=["sweeps"], route_class=UniqueKeysRoute)

_NOT_FOUND = {404: {"description": "no sweep with this id"}}
_PIECE = 1 << 20  # bytes per piece of a streamed result


def _done(record: SweepRecord, runner: Runner) -> tuple[int, float]:
    """Members done (live while it runs here), and the fraction of the sweep they are."""
    done = runner.progress(record.id, record.status, record.members_done)
    return done, 1.0 if record.status == "completed" else done / record.members


def _view(record: SweepRecord, runner: Runner) -> SweepView:
    done, progress = _done(record, runner)
    return SweepView(**{**fields(record), "members_done": done}, progress=progress,
                     result=SWEEPS.url(record.id) + "/result" if record.result_bytes else None)


SWEEPS = Tasks("sweep", "/v1/sweeps", _view, "max_queued_sweeps")


@router.post("", status_code=202, response_model=SweepCreated,
             responses={422: {"description": "the spec or grid is invalid; detail[].loc names the field"},
                        503: {"description": "this installation has no Dask (the sweep extra)"},
                        409: {"description": "an uploaded file the spec names was deleted while it was checked"},
                        429: {"description": "max_queued_sweeps sweeps are waiting, or max_pending_checks checks of "
                                             "systems are under way; retry after Retry-After seconds"}})
def submit_sweep(spec: SweepSpec, request: Request, response: Response, settings: SettingsDep, checks: ChecksDep,
                 sweeps: SweepsDep, runner: SweepRunnerDep) -> SweepCreated:
    """Queue a sweep: every combination of the grid's axes, each member the job with that point's values. Poll
    the Location for progress; the result is a NetCDF file (raydamp.load reads it)."""
    try:
        import dask.distributed  # noqa: F401 - present only with raydamp's sweep extra
    except ImportError:
        raise HTTPException(503, detail="sweeps need dask[distributed] and xarray: install raydamp with the "
                                        "sweep extra (pip install 'raydamp[sweep]')") from None
    spec = spec.model_copy(update={"job": with_seed(spec.job)})
    try:
        members = checks.sweep(spec)
    except JobError as error:
        raise invalid(error) from None
    record = SWEEPS.queue(request, response, sweeps, runner, spec, settings, members=members)
    return SweepCreated(id=record.id, status=record.status, members=record.members)


@router.get("", response_model=SweepList)
def list_sweeps(sweeps: SweepsDep, runner: SweepRunnerDep, settings: SettingsDep,
                limit: Annotated[int, Query(ge=1, description="at most this many sweeps, newest first")] = 50,
                status: Annotated[JobStatus | None, Query(description="only sweeps in this state")] = None
                ) -> SweepList:
    check_limit(limit, settings)
    return SweepList(sweeps=[
        SweepListItem(id=r.id, status=r.status, members=r.members, progress=_done(r, runner)[1],
                      created_at=r.created_at, finished_at=r.finished_at, url=SWEEPS.url(r.id))
        for r in sweeps.recent(limit, status)])


@router.get("/{sweep_id}", response_model=SweepView, responses=_NOT_FOUND)
def get_sweep(sweep_id: str, sweeps: SweepsDep, runner: SweepRunnerDep) -> SweepView:
    """Status, members done (per finished chunk), and once finished the members per outcome."""
    return _view(SWEEPS.existing(sweeps, sweep_id), runner)


def _pieces(connection, rowid: int, size: int):
    try:
        with connection.blobopen("sweeps", "result", rowid, readonly=True) as blob:
            for _offset in range(0, size, _PIECE):
                yield blob.read(_PIECE)
    finally:
        connection.close()


@router.get("/{sweep_id}/result", response_class=Response,
            responses={**_NOT_FOUND, 200: {"content": {"application/x-netcdf": {}}, "description": "NetCDF"},
                       409: {"description": "the sweep has no result (yet)"}})
def get_result(sweep_id: str, sweeps: SweepsDep, settings: SettingsDep,
               format: Annotated[Literal["netcdf", "nc"], Query(  # noqa: A002 - the API's name
                   description="netcdf (or nc): the sweep's xarray Dataset "
                               "(raydamp.load or xarray.open_dataset)")] = "netcdf"
               ) -> Response:
    """The members' trajectories and outcomes as one NetCDF file (raydamp.sweep's Dataset; a cancelled
    sweep's file holds the chunks finished before the cancel)."""
    record = SWEEPS.existing(sweeps, sweep_id)
    handle = sweeps.result_handle(sweep_id)
    if handle is None:
        reason = f": {record.error}" if record.error else ""
        raise HTTPException(409, detail=f"sweep {sweep_id} is {record.status} and has no result{reason}")
    connection, rowid, size = handle
    return TimedStreamingResponse(_pieces(connection, rowid, size), media_type="application/x-netcdf",
                                  headers={"Content-Disposition": f'attachment; filename="sweep-{sweep_id}.nc"',
                                           "Content-Length": str(size)},
                                  send_seconds=settings.send_timeout_seconds,
                                  min_rate=settings.min_send_bytes_per_second)


@router.post("/{sweep_id}/cancel", status_code=202, response_model=SweepView,
             responses={**_NOT_FOUND, 409: {"description": "the sweep has already finished"}})
def cancel_sweep(sweep_id: str, sweeps: SweepsDep, runner: SweepRunnerDep) -> SweepView:
    """Cancel a queued sweep at once, or stop a running one after its current chunks: it ends
    "cancelled" with the finished chunks as its result."""
    return SWEEPS.cancel(sweeps, runner, sweep_id)


@router.delete("/{sweep_id}", status_code=202, response_model=SweepView,
               responses={**_NOT_FOUND, 204: {"description": "the finished sweep and its result were removed"}})
def delete_sweep(sweep_id: str, sweeps: SweepsDep, runner: SweepRunnerDep) -> SweepView | Response:
    """A finished sweep is removed with its result (204); a queued or running one is cancelled (202)."""
    return SWEEPS.delete(sweeps, runner, sweep_id)
