"""A run's summary: the scalar results of a Solution (Solution.summary()), as a job answers them.

One definition for raydamp (Solution.summary() builds this model through summary_values, where a value
without a field here is an error), `raydamp run` (which prints it) and the service (whose job views carry
it, and whose OpenAPI document describes it from here). Read back, a summary stored by another version
keeps its fields and drops keys this one does not know (one a later version added, or one removed).
Non-finite numbers are None (JSON null).
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from .statuses import STATUSES

__all__ = ["JobSummary", "EventsSummary", "EnvelopeSummary", "MAX_SUMMARY_EVENTS", "MAX_SUMMARY_EVENT_DIM",
           "MAX_SUMMARY_PEAKS", "summary_values", "envelope_summary"]


MAX_SUMMARY_EVENTS = 1000  # crossings a summary lists; count says how many there were
MAX_SUMMARY_EVENT_DIM = 8  # coordinates up to which it lists q and p at each crossing too (at most 16,000 numbers)


class EventsSummary(BaseModel):
    """The events table of a run (raydamp.run.events.EventTable): name, t and direction of each crossing,
    the first MAX_SUMMARY_EVENTS of them."""

    count: int = Field(description="crossings found (the lists hold the first 1000)")
    name: list[str]
    t: list[float]
    direction: list[int] = Field(description="+1 rising through 0, -1 falling")
    q: list[list[float]] | None = Field(None, description=(
        f"positions at each listed crossing (every coordinate), for a model of at most {MAX_SUMMARY_EVENT_DIM} "
        "coordinates; else null"))
    p: list[list[float]] | None = Field(None, description="momenta likewise")


MAX_SUMMARY_PEAKS = 1000  # coordinates or springs a summary lists per quantity; size says how many there are


class EnvelopeSummary(BaseModel):
    """A run's envelope (raydamp.run.envelope): per quantity the peak |x| of each coordinate or spring and the
    time it happened (the first MAX_SUMMARY_PEAKS of them), the residuals at the run's end, and the spring
    whose drift passed its collapse limit."""

    peaks: dict[str, list[float | None]] = Field(description="{quantity: max |x| of each coordinate or spring}")
    times: dict[str, list[float | None]] = Field(description="{quantity: the time of each peak}")
    residuals: dict[str, list[float | None]] = Field(description="{residual_drift | residual_displacement: the "
                                                                 "value at the run's end, signed}")
    size: dict[str, int] = Field(description="{quantity: coordinates or springs (the lists hold the first 1000)}")
    collapsed_spring: int | None = Field(None, description="the spring whose drift passed its collapse limit")


class JobSummary(BaseModel):
    """raydamp's Solution.summary(): the scalar results of a run (non-finite numbers as null)."""

    status: Literal[STATUSES] = Field(description="why the run stopped (raydamp.jobs.statuses documents each)")
    message: str
    method: str
    tableau: str | None
    composition: str | None = None
    h: float
    step_size: float = Field(description="h, under its former name (kept for one release)",
                             json_schema_extra={"deprecated": True})
    steps: int
    failed_step: int | None
    t_final: float
    saved_points: int
    energy_initial: float | None
    energy_final: float | None
    energy_dissipated: float | None = Field(description=(
        "the energy the damping took out: H(0) - H(t_final) for a free run; for a run driven by a load, a "
        "ground motion or a temperature (where H(0) - H(t_final) mixes in the energy put in) the damping "
        "work W at the end, null when the run did not record it"))
    mean_dissipation_rate: float | None = Field(description="energy_dissipated / (t_final - t_0)")
    momentum_drift: float | None
    work_final: float | None = Field(None, description="the damping work W at the end (jobs with work)")
    load_work_final: float | None = Field(None, description="the load's work W_f at the end (jobs with work)")
    energy_balance_max: float | None = Field(None, description="max |H - H0 + W - W_f| over the saved points: the "
                                                               "energy budget's error (jobs with work)")
    kinetic_temperature: float | None = Field(
        None, description="<p^T M^-1 p> / n over the second half of the saved points (at most 2000, evenly "
                          "spaced), to compare with the job's temperature kT (jobs at a temperature)")
    events: EventsSummary | None = Field(None, description="the crossings of the job's events, in time order "
                                                           "(jobs with events)")
    envelope: EnvelopeSummary | None = Field(None, description="the peaks of the job's envelope (jobs with "
                                                               "envelope)")
    constraint_residual: float | None = Field(
        None, description="max_i |g_i(q)| / s_i over every drift of the run, s_i the constraint's scale (the sum of "
                          "its terms' absolute values): what the constraint solve reached (constrained systems)")
    constraint_velocity_residual: float | None = Field(
        None, description="max_i |(G M^-1 p)_i| / (|G_i| |M^-1 p|) after each drift's projection: how far p "
                          "stayed from the tangent space (constrained systems)")
    wall_time: float

    @model_validator(mode="before")
    @classmethod
    def _h_from_step_size(cls, data: Any) -> Any:
        """A summary stored by the service before 0.2 carries only step_size."""
        return {**data, "h": data.get("step_size")} if isinstance(data, dict) and "h" not in data else data


class _Built(JobSummary):
    model_config = ConfigDict(extra="forbid")


def envelope_summary(envelope) -> dict[str, Any]:
    """The plain values of EnvelopeSummary from a Solution's envelope Dataset (non-finite numbers as None)."""
    def plain(values) -> list[float | None]:
        return [float(x) if math.isfinite(x) else None for x in values[:MAX_SUMMARY_PEAKS].tolist()]

    peaks, times, residuals, size = {}, {}, {}, {}
    for name, variable in envelope.data_vars.items():
        if name.endswith("_time") or name == "collapsed_spring":
            continue
        size[name] = int(variable.size)
        if name.startswith("residual_"):
            residuals[name] = plain(variable.values)
        else:
            peaks[name] = plain(variable.values)
            times[name] = plain(envelope[f"{name}_time"].values)
    collapsed = int(envelope.attrs.get("collapsed_spring", -1))
    return {"peaks": peaks, "times": times, "residuals": residuals, "size": size,
            "collapsed_spring": None if collapsed < 0 else collapsed}


def summary_values(**values: Any) -> dict[str, Any]:
    """A run's summary as plain values, every one a field of JobSummary (an undeclared one raises)."""
    return _Built(**values).model_dump()
