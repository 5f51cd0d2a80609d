"""``raydamp advise spec.json --t-end T --tolerance TOL``: each method's stability limit, step and predicted
cost for the structure of a job file (the service's job JSON; only its system is read, and its t_end when
--t-end is not given). Exit codes: 0 advised, 2 a bad file, spec or argument."""

from __future__ import annotations

import sys

from ..jobs import model_from_spec
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
        model = model_from_spec({key: spec.get(key) for key in ("model", "system", "parameters")})
        advice = advise(model, t_end, tolerance, omega=omega, measure=measure)
    except ValueError as error:
        print(f"raydamp advise: {error}", file=sys.stderr)
        return 2
    print(advice)
    return 0
