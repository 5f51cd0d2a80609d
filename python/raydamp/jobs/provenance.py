"""A run as a job: the provenance every Solution carries (so a saved result runs again), and a model
to and from its JSON form (a sweep sends models to its workers this way)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import ValidationError

from .build import validation_error
from .spec import ModelSpec

__all__ = ["describe_model", "model_from_spec", "job_spec"]


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def describe_model(model) -> dict[str, Any]:
    """{"model": name, "parameters": {...}} for a built-in model, {"system": {...}} for the other kinds
    ({"system": None, "label": ...} for a System built from Python functions, which has no plain form)."""
    if hasattr(model, "to_dict"):
        try:
            return {"system": model.to_dict()}
        except ValueError:
            return {"system": None, "label": repr(model)}
    return {"model": model.name, "parameters": {k: _plain(v) for k, v in model.parameters.items()}}


def model_from_spec(spec: Any, files=None):
    """The model of {"model": name, "parameters": {...}} or {"system": {...}}; a ValueError names the path."""
    try:
        parsed = ModelSpec.model_validate(spec)
    except ValidationError as error:
        raise validation_error(error) from None
    return parsed.build_model(files)


def job_spec(model, q0: np.ndarray, p0: np.ndarray, *, method: str, tableau: str | None, composition: str | None,
             h: float, t_end: float | None, n_steps: int | None, save_every: int, work: bool,
             save_dofs: list[int] | None = None) -> dict[str, Any]:
    """The job of a run: what Solution.provenance holds."""
    from .. import __version__

    spec = describe_model(model)
    spec.update({"method": method, "tableau": tableau, "composition": composition, "h": h, "save_every": save_every,
                 "work": work,
                 "initial_state": {"q": np.asarray(q0, float).tolist(), "p": np.asarray(p0, float).tolist()}})
    if save_dofs is not None:
        spec["save_dofs"] = list(save_dofs)
    if t_end is not None:
        spec["t_end"] = t_end
    else:
        spec["n_steps"] = n_steps
    spec["raydamp_version"] = __version__
    return spec
