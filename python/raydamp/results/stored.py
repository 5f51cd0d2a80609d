"""A Solution rebuilt from what a job keeps of its run: the saved arrays, its summary (Solution.summary()) and
its job spec. A service stores a run so and writes files and plots from it again; only the summary's first
crossings of the events are kept (raydamp.jobs.summary.MAX_SUMMARY_EVENTS)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .._core import __version__
from ..jobs import JobSpec
from .event_table import EventTable
from .solution import Solution

__all__ = ["stored_solution"]


def stored_solution(spec: JobSpec, summary: Mapping[str, Any] | None, arrays: Mapping[str, np.ndarray | None], *,
                    origin: Mapping[str, Any], status: str, message: str = "",
                    failed_step: int | None = None) -> Solution:
    """The run of `spec` as a Solution: arrays are the saved ones by name (t, q, p, energy, momentum, work,
    load_work); origin, the job as stored, becomes its provenance with the saved coordinates' names; status,
    message and failed_step stand where the summary has none (a run stored without one)."""
    summary = summary or {}
    dim, momenta = arrays["q"].shape[1], arrays["momentum"].shape[1]
    coordinates, momentum_names = spec.names(dim, momenta, spec.save_dofs)
    drift = summary.get("momentum_drift")
    return Solution(
        **arrays, status=summary.get("status", status), steps=int(summary.get("steps", 0)), failed_step=failed_step,
        message=summary.get("message") or message, method=summary.get("method") or spec.method or "3s",
        tableau=summary.get("tableau"), composition=summary.get("composition"), h=spec.h,
        max_momentum_drift=float(drift) if drift is not None else 0.0, wall_time=float(summary.get("wall_time", 0.0)),
        origin={**origin, "raydamp_version": __version__, "coordinates": coordinates,
                "momentum_names": momentum_names},
        dofs=None if spec.save_dofs is None else np.asarray(spec.save_dofs, dtype=np.int64),
        events=_events(spec, summary, dim))


def _events(spec: JobSpec, summary: Mapping[str, Any], saved_width: int) -> EventTable | None:
    """The events table as the summary lists it (q and p for a small model, else NaN), or None without events."""
    if spec.events is None or summary.get("events") is None:
        return None
    listed = summary["events"]
    names = [e.name or f"event{i}" for i, e in enumerate(spec.events)]
    if listed.get("q"):
        dim = len(listed["q"][0])
    else:  # NaN columns wide enough for the saved coordinates' indices
        dim = max(spec.save_dofs) + 1 if spec.save_dofs else saved_width
    return EventTable.from_summary(names, listed, dim)
