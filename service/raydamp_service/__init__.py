"""raydamp_service: an HTTP job service for raydamp integrations. POST a problem to /v1/jobs, poll /v1/jobs/{id},
fetch /v1/jobs/{id}/trajectory. Jobs and results live in SQLite (RAYDAMP_DB); a restarted service re-runs the
interrupted ones. The numerics are raydamp's: this package validates, stores, runs and reports."""

from .app import create_app
from .config import Settings

__all__ = ["create_app", "Settings"]
