"""``raydamp advise spec.json --t-end T --tolerance TOL``: each method's stability limit, step and predicted
cost for the structure of a job file (the service's job JSON: its system, its t_end when --t-end is not given,
and, when it is a whole job, its initial state and load, which weight advise's error model as they weight
raydamp.advise's q0, p0 and load). Exit codes: 0 advised, 2 a bad file, spec or argument."""

from __future__ import annotations

import sys

import numpy as np

from ..jobs import job_arguments, model_from_spec
from ..run.advise import advise
from .run_command import read_spec

__all__ = ["advise_file"]


def advise_file(spec_path: str, *, t_end: float | None, tolerance: float, omega: float | None = None,
                measure: bool = True) -> int:
    try:
        spec = read_spec(spec_path)
        if not isinstance(spec, dict):
            raise ValueError(f"{spec_path}: a job file is a JSON object")
        if t_end is None:
            t_end = spec.get("t_end")
            if t_end is None:
                raise ValueError("--t-end: give it (the job file has no t_end)")
        start = {}
        if "initial_state" in spec:  # a whole job: its start and load are what the run will meet
            job = {**spec, "t_end": t_end, "n_steps": None, "h": spec.get("h") or spec.get("step_size") or t_end}
            job.pop("step_size", None)
            model, q0, p0, options = job_arguments(job)
            if np.any(np.asarray(q0, dtype=float)) or np.any(np.asarray(p0, dtype=float)):
                start.update(q0=q0, p0=p0)
            if options.get("load") is not None:
                start["load"] = options["load"]
        else:
            model = model_from_spec({key: spec.get(key) for key in ("model", "system", "parameters")})
        advice = advise(model, t_end, tolerance, omega=omega, measure=measure, **start)
    except ValueError as error:
        print(f"raydamp advise: {error}", file=sys.stderr)
        return 2
    print(advice)
    return 0
