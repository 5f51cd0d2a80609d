"""The job's ``"events"``: the typed form of :class:`raydamp.Event` (raydamp.run.events), so that the
service, ``raydamp run`` and a Solution's provenance take and write the same JSON."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ..systems.expressions import MAX_LENGTH
from .forms import Input

__all__ = ["EventInput", "MAX_EVENTS"]

MAX_EVENTS = 64  # event functions per job: each is compiled, and evaluated at every step end


class EventInput(Input):
    """An event: the times at which g(t, q, p) crosses zero, located on each step's dense output."""

    g: str = Field(min_length=1, max_length=MAX_LENGTH, description=(
        "an expression in t, the parameters, a system's coordinate names and p_<name>, and q[i], p[i]"))
    direction: Literal[-1, 0, 1] = Field(0, description="+1: rising through 0 only, -1: falling only, 0: both")
    terminal: bool = Field(False, description="the run ends at the first such crossing (status \"event\")")
    name: str | None = Field(None, min_length=1, max_length=100, description="its name in the events table "
                                                                             "(default event<i>)")
    refine: Literal["henon"] | None = Field(None, description=(
        "\"henon\": land each crossing on g = 0 by Hénon's step from a stepped state (a Poincaré section's "
        "points; not with terminal)"))
