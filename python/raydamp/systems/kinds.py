"""The kinds of system a job names, as plain data both ways: a built-in model
``{"model": name, "parameters": {...}}``, or ``{"system": {...}}`` for a System, a Chain
(``"kind": "chain"``) or a LinearStructure (``"kind": "linear_structure"``).

Errors are ValueErrors whose message starts with the JSON path of the bad field.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .chain import Chain
from .models import MODELS, Model
from .system import SpecError, System

__all__ = ["describe_model", "model_from_spec"]


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def describe_model(model: Model) -> dict[str, Any]:
    """{"model": name, "parameters": {...}} for a built-in model, {"system": {...}} for a System
    ({"system": None, "label": ...} for one built from Python functions, which has no plain form)."""
    from .structure import LinearStructure

    if isinstance(model, (Chain, LinearStructure)):
        return {"system": model.to_dict()}
    if isinstance(model, System):
        try:
            return {"system": model.to_dict()}
        except ValueError:
            return {"system": None, "label": repr(model)}
    return {"model": model.name, "parameters": {k: _plain(v) for k, v in model.parameters.items()}}


def model_from_spec(spec: Mapping[str, Any]) -> Model:
    """The model of a job spec: ``model`` + ``parameters`` or ``system`` (exactly one)."""
    has_model, has_system = spec.get("model") is not None, spec.get("system") is not None
    if has_model == has_system:
        raise ValueError("model: give exactly one of model (a built-in model's name, with parameters) and "
                         "system (a user-defined system)")
    if has_system:
        if spec.get("parameters"):
            raise ValueError("parameters: a system carries its parameters inside system.parameters")
        kind = spec["system"].get("kind") if isinstance(spec["system"], Mapping) else None
        if kind in ("chain", "linear_structure"):
            from .structure import LinearStructure

            try:
                if kind == "chain":
                    return Chain.from_dict(spec["system"])
                return LinearStructure.from_dict(dict(spec["system"]))
            except ValueError as error:
                raise ValueError(f"system.{error}") from None
        try:
            return System.from_dict(spec["system"])
        except SpecError as error:
            raise ValueError(f"system.{error}") from None
    name = spec["model"]
    if name not in MODELS:
        raise ValueError(f"model: unknown model {name!r} (known: {', '.join(MODELS)})")
    parameters = spec.get("parameters") or {}
    if not isinstance(parameters, Mapping):
        raise ValueError("parameters: must be an object of name: value")
    try:
        return MODELS[name](**parameters)
    except TypeError as error:  # an unknown keyword
        raise ValueError(f"parameters: {error}") from None
    except ValueError as error:
        raise ValueError(f"parameters.{error}") from None
