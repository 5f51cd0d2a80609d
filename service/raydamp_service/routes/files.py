"""/v1/files: upload (multipart, one part named "file": `curl -F file=@K.mtx`), list and remove matrices and
records. A file a queued or running job names cannot be removed (409)."""

from __future__ import annotations

import shutil
import tempfile
from functools import partial
from typing import Annotated

from fastapi import APIRouter, File, HTTPException, Query, Request, Response, UploadFile
from fastapi.exceptions import RequestValidationError

from ..checks.limits import JobError
from ..checks.uploads import RecordFileInfo, check_upload_file
from ..edge.guard import file_too_large
from ..kinds.files import FileRecord
from ..schemas import FileInfo, FileList
from .tasks import SettingsDep, StoreDep, check_limit

router = APIRouter(prefix="/v1/files", tags=["files"])

_NOT_FOUND = {404: {"description": "no file with this id"}}
_MAX_NAME = 200
_PIECE = 1 << 20  # bytes of an upload copied at once


def _info(record: FileRecord) -> FileInfo:
    common = {"id": record.id, "name": record.name, "bytes": record.bytes, "created_at": record.created_at}
    if record.kind == "record":
        return FileInfo(**common, kind="record", format=record.format, shape=None, nnz=None, samples=record.shape[0],
                        t_start=record.t_start, t_end=record.t_end, dt=record.dt)
    return FileInfo(**common, shape=list(record.shape), nnz=record.nnz)


def _name(filename: str | None) -> str:
    name = (filename or "upload.mtx").encode("utf-8", "replace").decode("utf-8")  # lone surrogates -> ?
    return name[:_MAX_NAME]


@router.post("", status_code=201, response_model=FileInfo,
             responses={413: {"description": "the file is over max_file_bytes"},
                        422: {"description": "no file part, or not a file this service can use: a Matrix Market "
                                             "file (a real square matrix of at most max_structure_dim rows) or a "
                                             "record raydamp reads (.AT2 with NPTS values, times increasing, "
                                             "finite numbers); detail[].msg says why"},
                        507: {"description": "the stored files would exceed max_stored_file_bytes; delete some"}})
def upload_file(file: Annotated[UploadFile, File(description="a Matrix Market (.mtx) file, a real square matrix; "
                                                 "or a record: PEER .AT2, CSV/text columns t, value, or .npy")],
                request: Request, response: Response, store: StoreDep, settings: SettingsDep) -> FileInfo:
    """Store a file, read by its name's suffix and its content. A Matrix Market matrix: {"file": id} for a
    linear structure's M or K. A record (.AT2, two columns t, value as CSV/text, a .npy of shape (T, 2); or
    one column of values, whose sample interval a job gives as "dt"): {"file": {"id": id, "direction": [...],
    "factor": 9.81}} as a load, or as a ground motion's acceleration; a one-column record also serves as an
    initial state's {"file": id}."""
    limit = settings.max_file_bytes
    if file.size is not None and file.size > limit:
        raise HTTPException(413, detail=file_too_large(limit))
    # Spooled piecewise, parsed by a check process, stored from the spool: the server never holds the whole upload.
    with tempfile.NamedTemporaryFile(prefix="raydamp-upload-") as spool:
        shutil.copyfileobj(file.file, spool, _PIECE)
        if spool.tell() > limit:
            raise HTTPException(413, detail=file_too_large(limit))
        spool.flush()
        try:
            info = request.app.state.checks.call(partial(check_upload_file, max_dim=settings.max_structure_dim),
                                                 spool.name, _name(file.filename), where=("body", "file"))
        except JobError as error:
            raise RequestValidationError([{"type": "value_error", "loc": error.loc, "msg": error.message,
                                           "input": _name(file.filename)}]) from None
        matrix = not isinstance(info, RecordFileInfo)
        record = store.add_file(_name(file.filename), spool, *((info.shape, info.nnz) if matrix else ()),
                                max_total_bytes=settings.max_stored_file_bytes, record=None if matrix else info)
    if record is None:
        raise HTTPException(507, detail=f"the stored files would exceed max_stored_file_bytes = "
                            f"{settings.max_stored_file_bytes} bytes; delete files no longer needed")
    response.headers["Location"] = request.scope.get("root_path", "") + f"/v1/files/{record.id}"
    return _info(record)


@router.get("", response_model=FileList)
def list_files(store: StoreDep, settings: SettingsDep,
               limit: Annotated[int, Query(ge=1, description="at most this many files, newest first")] = 100
               ) -> FileList:
    check_limit(limit, settings)
    return FileList(files=[_info(record) for record in store.files(limit)])


@router.get("/{file_id}", response_model=FileInfo, responses=_NOT_FOUND)
def get_file(file_id: str, store: StoreDep) -> FileInfo:
    record = store.file(file_id)
    if record is None:
        raise HTTPException(404, detail=f"no file with id {file_id!r}")
    return _info(record)


@router.delete("/{file_id}", status_code=204, response_class=Response,
               responses={**_NOT_FOUND, 409: {"description": "a queued or running job uses the file"}})
def delete_file(file_id: str, store: StoreDep) -> Response:
    """Remove the file. Finished jobs that used it keep their results; a queued or running job that names
    it keeps it (409, naming the jobs): cancel them, or wait for them to finish."""
    outcome = store.delete_file(file_id)
    if outcome == "missing":
        raise HTTPException(404, detail=f"no file with id {file_id!r}")
    if outcome == "in_use":
        jobs = store.jobs_using_file(file_id)
        raise HTTPException(409, detail=f"file {file_id} is used by queued or running jobs ({', '.join(jobs)}); "
                            "cancel them or wait for them to finish")
    return Response(status_code=204)
