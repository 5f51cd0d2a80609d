"""A run as plain data: the job JSON the service takes, the file ``raydamp run`` reads, and
the provenance every Solution carries (so a saved result can be run again).

    {"model": "elastic_pendulum", "parameters": {"eps": 0.1}}   or   {"system": System.to_dict()}
    + {"method": "3s", "tableau": null, "composition": null, "step_size": 0.1, "t_end": 100 | "n_steps": 1000,
       "save_every": 1, "initial_state": {"q": [...], "p": [...]}, "work": false}

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

__all__ = ["JOB_KEYS", "PROVENANCE_KEYS", "describe_model", "model_from_spec", "job_arguments", "job_spec"]

JOB_KEYS = ("model", "system", "parameters", "method", "tableau", "composition", "step_size", "t_end", "n_steps", "save_every",
            "initial_state", "work", "save_dofs")
# What a Solution's provenance adds to the job (a saved result's provenance runs as a job).
PROVENANCE_KEYS = ("raydamp_version", "job_id", "coordinates", "momentum_names")


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


def job_arguments(spec: Mapping[str, Any]) -> tuple[Model, Any, Any, dict[str, Any]]:
    """(model, q0, p0, keyword arguments of raydamp.integrate) for a job spec."""
    if not isinstance(spec, Mapping):
        raise ValueError("a job must be an object with the keys " + ", ".join(JOB_KEYS))
    unknown = [k for k in spec if k not in JOB_KEYS and k not in PROVENANCE_KEYS]
    if unknown:
        raise ValueError(f"{unknown[0]}: unknown key (known: {', '.join(JOB_KEYS)})")
    model = model_from_spec(spec)
    state = spec.get("initial_state")
    if isinstance(model, Chain) and isinstance(state, Mapping) and "mode" in state:
        state = _chain_mode_state(model, state)
    if isinstance(state, Mapping) and "rest" in state:
        state = rest_state(model, state)
    if not isinstance(state, Mapping) or "q" not in state or "p" not in state:
        raise ValueError('initial_state: must be {"q": [...], "p": [...]}, {"rest": true}'
                         + (' or {"mode": k, "amplitude": a} for a chain' if isinstance(model, Chain) else ""))
    for key in ("method", "step_size"):
        if key not in spec:
            raise ValueError(f"{key}: missing")
    options: dict[str, Any] = {"method": spec["method"], "h": spec["step_size"],
                               "save_every": spec.get("save_every", 1), "work": spec.get("work", False)}
    for key in ("tableau", "composition", "t_end", "n_steps", "save_dofs"):
        if spec.get(key) is not None:
            options[key] = spec[key]
    return model, state["q"], state["p"], options


def rest_state(model: Model, state: Mapping[str, Any]) -> dict[str, Any]:
    """{"rest": true}: q = 0, p = 0, so that a job for a large structure (its response to the load f)
    need not carry 2 n zeros."""
    if dict(state) != {"rest": True}:
        raise ValueError('initial_state: a start at rest is exactly {"rest": true}')
    return {"q": np.zeros(model.dim), "p": np.zeros(model.dim)}


def _chain_mode_state(chain: Chain, state: Mapping[str, Any]) -> dict[str, Any]:
    """{"mode": k, "amplitude": a}: a chain started in one normal mode at rest (Chain.normal_mode),
    so a job for a million sites need not carry two million numbers."""
    for key in state:
        if key not in ("mode", "amplitude"):
            raise ValueError(f"initial_state.{key}: unknown key (a chain's mode start has mode, amplitude)")
    try:
        q, p = chain.normal_mode(state["mode"], state.get("amplitude", 1.0))
    except ValueError as error:
        raise ValueError(f"initial_state.{error}") from None
    return {"q": q, "p": p}


def job_spec(model: Model, q0: np.ndarray, p0: np.ndarray, *, method: str, tableau: str | None,
             composition: str | None, h: float, t_end: float | None, n_steps: int | None, save_every: int,
             work: bool, save_dofs: list[int] | None = None) -> dict[str, Any]:
    """The job spec of a run: what Solution.provenance holds."""
    from . import __version__

    spec = describe_model(model)
    spec.update({"method": method, "tableau": tableau, "composition": composition, "step_size": h, "save_every": save_every, "work": work,
                 "initial_state": {"q": np.asarray(q0, float).tolist(), "p": np.asarray(p0, float).tolist()}})
    if save_dofs is not None:
        spec["save_dofs"] = list(save_dofs)
    if t_end is not None:
        spec["t_end"] = t_end
    else:
        spec["n_steps"] = n_steps
    spec["raydamp_version"] = __version__
    return spec
