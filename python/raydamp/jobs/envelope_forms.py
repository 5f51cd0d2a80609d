"""The job's ``"envelope"`` and ``"collapse"``: the typed form of raydamp.integrate's envelope recorders
(raydamp.run.envelope documents each quantity), so that the service, ``raydamp run`` and a Solution's
provenance take and write the same JSON."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Discriminator, Field, Tag

from .. import _core
from .forms import bounded

__all__ = ["ENVELOPE_QUANTITIES", "EnvelopeName", "CollapseValue", "COLLAPSE_TAGS", "PER_SPRING", "MAX_SPRING_LIMITS"]

# Peaks the step loop takes (the core's list), then the residuals read from the final state.
ENVELOPE_QUANTITIES: tuple[str, ...] = tuple(_core.PEAKS) + ("residual_drift", "residual_displacement")
PER_SPRING = frozenset({"drift", "force", "residual_drift"})

EnvelopeName = Literal[ENVELOPE_QUANTITIES]  # type: ignore[valid-type]
MAX_SPRING_LIMITS = 10_000  # as a job's springs are bounded
CollapseLimit = Annotated[float, Field(gt=0, allow_inf_nan=False)]
# One limit for every spring, or one per spring, told apart by type (an error is the form's the client meant).
CollapseValue = Annotated[Annotated[CollapseLimit, Tag("number form")]
                          | Annotated[bounded(CollapseLimit, MAX_SPRING_LIMITS, min_length=1), Tag("list form")],
                          Discriminator(lambda value: "list form" if isinstance(value, list) else "number form")]
COLLAPSE_TAGS = frozenset({"number form", "list form"})
