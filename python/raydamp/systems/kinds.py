"""What every kind of system answers: the protocol of a built-in model, a System, a Chain and a
LinearStructure, so that the layers above (ensembles, sweeps, provenance, the job schema, the
service) ask a system instead of switching on its type.

A kind names its coordinates and momentum maps, gives its JSON form (:meth:`SystemKind.describe`:
``{"model": name, "parameters": {...}}`` for a built-in model, ``{"system": {...}}`` for a kind
with its own form, ``to_dict``), says which parameters may vary per ensemble member and builds
what the compiled ensemble runs. The way back, JSON to model, is the job schema's
(raydamp.jobs.model_from_spec).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple, Protocol

import numpy as np

__all__ = ["SystemKind", "MemberModels", "describe_model", "plain"]


class MemberModels(NamedTuple):
    """What the core's ``integrate_ensemble`` takes to build every member's model: member i runs
    ``models[index[i]]`` with the flat parameter values ``names`` (the core's catalogue names:
    ``"eps"``, ``"g[0]"``) set to ``values[i]``."""

    models: list        # systems whose ``_core_model`` the core runs
    index: np.ndarray   # (members,) int64
    names: list[str]
    values: np.ndarray  # (members, len(names))

    @classmethod
    def shared(cls, system: Any, members: int) -> MemberModels:
        """One model for every member, nothing set per member."""
        return cls([system], np.zeros(members, dtype=np.int64), [], np.zeros((members, 0)))


class SystemKind(Protocol):
    """The questions every kind of system answers (implemented by each kind's class)."""

    name: str  # the kind's name: a built-in model's ("elastic_pendulum"), or "system", "chain", "linear_structure"

    @property
    def dim(self) -> int:
        """Configuration dimension n."""

    @property
    def coordinates(self) -> tuple[str, ...]:
        """The coordinates' names, n of them."""

    @property
    def momentum_names(self) -> tuple[str, ...]:
        """The names of the momentum maps the runs record."""

    def describe(self) -> dict[str, Any]:
        """The JSON form: ``{"model": name, "parameters": {...}}`` or ``{"system": {...}}``
        (``{"system": None, "label": ...}`` for a system that has no plain form)."""

    def member_parameters(self) -> Mapping[str, int]:
        """The parameters ``integrate_ensemble`` may vary per member, each with its number of
        components (1, or 3 for a vector): ``{}`` when members differ by initial state only."""

    def member_models(self, parameters: Mapping[str, np.ndarray], members: int) -> MemberModels:
        """The models the compiled ensemble runs for per-member ``parameters`` ({name: (members,)
        or (members, size) floats}, names from member_parameters(), already checked)."""

    def check_configurations(self, name: str, qs: np.ndarray) -> None:
        """Refuse a row of qs (members, n) outside the configuration space, naming ``name[i]``."""


def plain(value: Any) -> Any:
    """A parameter value as JSON-ready data: tuples and arrays as lists, a non-finite float as None."""
    if isinstance(value, tuple):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def describe_model(model: SystemKind) -> dict[str, Any]:
    """The model's JSON form (:meth:`SystemKind.describe`)."""
    return model.describe()
