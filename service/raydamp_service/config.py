"""Service settings, read from RAYDAMP_* environment variables."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict

__all__ = ["Settings"]


class Settings(BaseSettings):
    """Everything an operator may change; each field is the env variable RAYDAMP_<NAME>."""

    model_config = SettingsConfigDict(env_prefix="RAYDAMP_", extra="ignore")

    db: Path = Field(Path("var/raydamp.sqlite3"), description="SQLite file holding jobs and results")
    host: str = "127.0.0.1"
    port: int = Field(8000, ge=0, le=65535)
    workers: int = Field(2, ge=1, le=64, description="runs executed at once")

    # Bounds on what one job may ask for, so that no request can exhaust memory or disk.
    max_steps: int = Field(10**8, ge=1)
    max_saved_points: int = Field(10**6, ge=2, description="n_steps // save_every + 2 at most")
    max_dim: int = Field(1000, ge=1, description="longest initial_state.q / p or vector parameter accepted")
    # SQLite refuses blobs above 1e9 bytes; stay well under it per array.
    max_trajectory_bytes: int = Field(512 * 2**20, ge=1, le=900_000_000)
    max_list_limit: int = Field(1000, ge=1)

    # How often a run's progress is also written to the database (GET reads memory first).
    progress_save_seconds: float = Field(1.0, gt=0)
    # How long shutdown waits for interrupted runs to hand their jobs back to the queue.
    shutdown_seconds: float = Field(10.0, gt=0)
