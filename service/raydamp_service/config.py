"""Service settings, read from RAYDAMP_* environment variables."""

from __future__ import annotations

import ipaddress
from pathlib import Path
from typing import Annotated

from pydantic import Field, SecretStr, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

__all__ = ["Settings", "is_loopback"]

LOOPBACK_NAMES = ("127.0.0.1", "::1", "localhost")


def is_loopback(host: str) -> bool:
    """True for an address or name that only this machine can reach."""
    host = host.strip("[]")
    try:
        return host.lower() == "localhost" or ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class Settings(BaseSettings):
    """Everything an operator may change; each field is the env variable RAYDAMP_<NAME>."""

    model_config = SettingsConfigDict(env_prefix="RAYDAMP_", extra="ignore")

    db: Path = Field(Path("var/raydamp.sqlite3"), description="SQLite file holding jobs and results")
    host: str = "127.0.0.1"
    port: int = Field(8000, ge=0, le=65535)
    workers: int = Field(2, ge=1, le=64, description="runs executed at once")

    token: SecretStr | None = Field(None, description=(
        "when set, every /v1 request needs Authorization: Bearer <token>; required to bind a non-loopback address"))
    trusted_hosts: Annotated[list[str], NoDecode] = Field(
        list(LOOPBACK_NAMES), min_length=1, description="Host header names accepted (comma-separated; '*': any)")

    # Bounds on what one request or job may ask for, so that none can exhaust memory or disk.
    max_body_bytes: int = Field(2 * 2**20, ge=1024, description="a larger request body gets 413 before parsing")
    large_body_bytes: int = Field(256 * 2**10, ge=1, description="a request body above this is large")
    max_large_bodies: int = Field(2, ge=1, description="large request bodies handled at once; more get 429")
    header_seconds: float = Field(10.0, gt=0, description=(
        "a connection whose request headers have not all arrived this long after it opened (or after its previous "
        "response) is closed"))
    body_seconds: float = Field(120.0, gt=0, description=(
        "a request body must arrive within this many seconds of the request's headers (plus its bytes at "
        "min_body_bytes_per_second), or the request gets 408"))
    min_body_bytes_per_second: int = Field(64 * 2**10, ge=0, description=(
        "each byte of a body received extends its deadline by 1 / this many seconds (0: body_seconds alone)"))
    max_queued: int = Field(1000, ge=1, description="queued jobs beyond this get 429 with Retry-After")
    retry_after_seconds: int = Field(5, ge=1, description="the Retry-After of a 429")
    max_steps: int = Field(10**8, ge=1)
    max_saved_points: int = Field(10**6, ge=2, description=(
        "saved points of a job at most: step 0, every save_every-th step and the last"))
    max_dim: int = Field(1000, ge=1, le=10_000,  # schemas.MAX_VECTOR
                         description="longest initial_state.q / p or vector parameter accepted")
    # All of a job's stored arrays; SQLite refuses blobs above 1e9 bytes.
    max_trajectory_bytes: int = Field(512 * 2**20, ge=1, le=900_000_000, description=(
        "a job whose stored trajectory would be larger gets 422 on save_every (raise it, or save fewer "
        "coordinates: save_dofs)"))
    max_list_limit: int = Field(1000, ge=1)

    # Linear structures: inline COO matrices up to max_structure_nnz entries each; larger ones are uploaded files.
    max_structure_nnz: int = Field(100_000, ge=1, le=1_000_000,  # schemas.MAX_COO_ENTRIES
                                   description="stored entries of one COO matrix in a job at most")
    max_structure_dim: int = Field(100_000, ge=1, le=10**7, description=(  # schemas.MAX_STRUCTURE_DIM
        "coordinates of a linear structure at most (one started at rest may exceed max_dim)"))
    max_file_bytes: int = Field(64 * 2**20, ge=1024, description="a larger upload gets 413, counted as it arrives")
    max_stored_file_bytes: int = Field(2**30, ge=0, description=(
        "uploaded files kept at most, in all; past it an upload gets 507 (delete files first); 0: no bound"))

    # Trajectory fetches, files and plots read the stored arrays in slices; few large ones at once.
    large_fetch_bytes: int = Field(16 * 2**20, ge=1, description=(
        "stored bytes selected above which a fetch, file or plot is large"))
    max_large_fetches: int = Field(2, ge=1, description="large trajectory fetches served at once; more get 429")
    send_timeout_seconds: float = Field(60.0, gt=0, description=(
        "a trajectory or file response whose client reads nothing for this long is dropped, with its slot"))
    min_send_bytes_per_second: int = Field(128 * 2**10, ge=0, description=(
        "a trajectory, file or sweep result whose client reads slower than this on average (after the first "
        "send_timeout_seconds) is dropped, with its slot; 0: no floor"))
    max_plot_bytes: int = Field(16 * 2**20, ge=2**16, description=(
        "stored bytes a plot reads at most (its points decimated evenly to fit)"))

    # The heavy checks run in worker processes (checks/pool.py), each within a CPU and a memory budget.
    check_workers: int = Field(2, ge=1, le=16, description="processes that check submitted systems")
    check_seconds: float = Field(10.0, gt=0, description="CPU time budget of one check")
    check_memory_bytes: int = Field(2**30, ge=2**24, description=(
        "memory budget of one check: address space a check process may add to what it holds at start"))
    max_pending_checks: int = Field(8, ge=1, description="checks running or waiting for a process; more get 429")

    # Retention: finished jobs (oldest first) are removed past any of these; 0 means no bound.
    retain_jobs: int = Field(10_000, ge=0, description="finished jobs kept at most")
    retain_seconds: float = Field(0, ge=0, description="finished jobs older than this are removed")
    retain_bytes: int = Field(4 * 2**30, ge=0, description="trajectory bytes kept at most")
    retention_interval_seconds: float = Field(60.0, gt=0, description="how often the retention pass runs")

    # Sweeps run through raydamp.sweep on a Dask client (the compiled runs release the GIL).
    dask_scheduler: str | None = Field(None, description=(
        "a Dask scheduler's address (tcp://host:8786) for sweeps; unset: an in-process LocalCluster"))
    sweep_threads: int = Field(2, ge=1, le=64, description="threads of the in-process LocalCluster")
    max_sweep_members: int = Field(100_000, ge=1, description="grid points of one sweep at most")
    max_sweep_steps: int = Field(10**10, ge=1, description="members x steps of one sweep at most")
    max_sweep_bytes: int = Field(256 * 2**20, ge=1, le=900_000_000, description="a sweep's result size at most")
    max_queued_sweeps: int = Field(20, ge=1, description="queued sweeps beyond this get 429 with Retry-After")

    access_log: bool = Field(True, description="log every request (method, path, status) on stdout")
    progress_save_seconds: float = Field(1.0, gt=0, description="how often a run's progress is saved to the database")
    shutdown_seconds: float = Field(10.0, gt=0, description="how long shutdown waits for runs to hand their jobs back")

    @field_validator("trusted_hosts", mode="before")
    @classmethod
    def _split_hosts(cls, value: object) -> object:
        if isinstance(value, str):
            return [name.strip() for name in value.split(",") if name.strip()]
        return value
