"""The provenance every Solution carries: the job JSON of its run (the JSON the service takes and
``raydamp run`` reads, so a saved result can be run again) plus the raydamp version."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._core import __version__
from ..jobs import PROVENANCE_KEYS
from ..systems.kinds import describe_model
from ..systems.models import Model

__all__ = ["PROVENANCE_KEYS", "job_spec"]


def job_spec(model: Model, q0: np.ndarray, p0: np.ndarray, *, method: str, tableau: str | None,
             composition: str | None, h: float, t_end: float | None, n_steps: int | None, save_every: int,
             work: bool, save_dofs: list[int] | None = None, load=None, thermal=None,
             method_reason: str | None = None, divergence: float | None = None, events: list | None = None,
             dense: bool = False, envelope: list | None = None, collapse: list | None = None,
             corrector: int | None = None) -> dict[str, Any]:
    """The job spec of a run: what Solution.provenance holds; ``method_reason`` says why the method was
    chosen when the run named none (raydamp.run.choose_method)."""
    spec = describe_model(model)
    spec.update({"method": method, "tableau": tableau, "composition": composition, "h": h, "save_every": save_every,
                 "work": work,
                 "initial_state": {"q": np.asarray(q0, float).tolist(), "p": np.asarray(p0, float).tolist()}})
    if method_reason is not None:
        spec["method_reason"] = method_reason
    if save_dofs is not None:
        spec["save_dofs"] = list(save_dofs)
    if divergence is not None:
        spec["divergence"] = divergence
    if load is not None:
        spec["load"] = load.to_dict()
    if events:
        spec["events"] = events
    if dense:
        spec["dense"] = True
    if envelope:
        spec["envelope"] = list(envelope)
    if collapse is not None:
        spec["collapse"] = collapse if isinstance(collapse, (int, float)) else list(collapse)  # one for all, or each
    if corrector is not None:
        spec["corrector"] = corrector
    if thermal is not None:
        kT, seed, stream = thermal
        spec.update({"temperature": kT, "seed": seed})
        if stream:
            spec["stream"] = stream
    if t_end is not None:
        spec["t_end"] = t_end
    else:
        spec["n_steps"] = n_steps
    spec["raydamp_version"] = __version__
    return spec
