"""A model as plain data: ``{"model": name, "parameters": {...}}`` for a built-in model, or
``{"system": {...}}`` for a kind that has its own JSON form (``to_dict``: a System, a Chain, a
LinearStructure). The way back, JSON to model, is the job schema's (raydamp.jobs.model_from_spec).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["describe_model"]


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def describe_model(model) -> dict[str, Any]:
    """{"model": name, "parameters": {...}} for a built-in model, {"system": model.to_dict()} for the
    other kinds ({"system": None, "label": ...} for a System built from Python functions, which has no
    plain form)."""
    if hasattr(model, "to_dict"):
        try:
            return {"system": model.to_dict()}
        except ValueError:
            return {"system": None, "label": repr(model)}
    return {"model": model.name, "parameters": {k: _plain(v) for k, v in model.parameters.items()}}
