"""A run as plain data: the job JSON the service takes and the file ``raydamp run`` reads, turned
into integrate's arguments (the system's part is :mod:`raydamp.systems.kinds`; what a Solution
records of its run is :mod:`raydamp.results.provenance`).

    {"model": "elastic_pendulum", "parameters": {"eps": 0.1}}   or   {"system": System.to_dict()}
    + {"method": "3s", "tableau": null, "composition": null, "step_size": 0.1, "t_end": 100 | "n_steps": 1000,
       "save_every": 1, "initial_state": {"q": [...], "p": [...]}, "work": false}

Errors are ValueErrors whose message starts with the JSON path of the bad field.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..results.provenance import PROVENANCE_KEYS
from ..systems.chain import Chain
from ..systems.kinds import model_from_spec
from ..systems.models import Model

__all__ = ["JOB_KEYS", "job_arguments", "rest_state"]

JOB_KEYS = ("model", "system", "parameters", "method", "tableau", "composition", "step_size", "t_end", "n_steps", "save_every",
            "initial_state", "work", "save_dofs")


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
