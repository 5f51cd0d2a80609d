"""A Solution's layout in files: an xarray Dataset, NetCDF, NPZ and CSV, with its provenance (solution.py reads
it back).

The Dataset has dims (time, dof) and (time, momentum_map): variables q, p, energy, momentum and,
when recorded, work; coordinates t (time), dof (the coordinate names) and momentum_map (the
momentum maps' names). attrs hold the run's status and scalars, and ``provenance``: the job
JSON that produced it (model or system, initial state, method, step size, span) and the
raydamp version, as a JSON string (NetCDF attributes are flat).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

__all__ = ["to_xarray", "FORMATS"]

FORMATS = (".nc", ".npz", ".csv")
_FORMAT_OF_SUFFIX = dict(zip(FORMATS, ("netcdf", "npz", "csv")))
_SCALARS = ("status", "steps", "failed_step", "message", "method", "tableau", "composition", "h", "max_momentum_drift",
            "wall_time")


def _attributes(sol: Any) -> dict[str, Any]:
    provenance = sol.provenance or {}
    provenance = {**provenance, "coordinates": list(sol.coordinates), "momentum_names": list(sol.momentum_names)}
    attrs: dict[str, Any] = {"provenance": json.dumps(provenance)}
    for key in _SCALARS:
        value = getattr(sol, key)
        # NetCDF has no null: -1 for "no failed step", "" for "no tableau" or "no composition".
        if value is None:
            value = -1 if key == "failed_step" else ""
        attrs[key] = value
    attrs["raydamp_version"] = provenance.get("raydamp_version", "")
    return attrs


def to_xarray(sol: Any):
    """The solution as an xarray.Dataset (needs the ``io`` extra: xarray)."""
    try:
        import xarray as xr
    except ImportError as error:
        raise ImportError("to_xarray needs xarray: pip install 'raydamp[io]'") from error
    data = {
        "q": (("time", "dof"), sol.q, {"long_name": "positions"}),
        "p": (("time", "dof"), sol.p, {"long_name": "momenta"}),
        "energy": (("time",), sol.energy, {"long_name": "H(q, p)"}),
        "momentum": (("time", "momentum_map"), sol.momentum, {"long_name": "momentum maps"}),
    }
    if sol.work is not None:
        data["work"] = (("time",), sol.work, {"long_name": "damping work W(t)"})
    if sol.load_work is not None:
        data["load_work"] = (("time",), sol.load_work, {"long_name": "load work W_f(t)"})
    coords = {"t": (("time",), sol.t), "dof": list(sol.coordinates), "momentum_map": list(sol.momentum_names)}
    return xr.Dataset(data, coords=coords, attrs=_attributes(sol))


def _csv_table(sol: Any) -> tuple[list[str], np.ndarray]:
    names = ["t", *(f"q_{c}" for c in sol.coordinates), *(f"p_{c}" for c in sol.coordinates), "energy",
             *sol.momentum_names]
    columns = [sol.t[:, None], sol.q, sol.p, sol.energy[:, None], sol.momentum]
    for name in ("work", "load_work"):
        if getattr(sol, name) is not None:
            names.append(name)
            columns.append(getattr(sol, name)[:, None])
    return names, np.hstack(columns)
