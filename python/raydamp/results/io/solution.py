"""A Solution as files: an xarray Dataset, NetCDF, NPZ and CSV, with its provenance.

The Dataset has dims (time, dof) and (time, momentum_map): variables q, p, energy, momentum and,
when recorded, work; coordinates t (time), dof (the coordinate names) and momentum_map (the
momentum maps' names). attrs hold the run's status and scalars, and ``provenance``: the job
JSON that produced it (model or system, initial state, method, step size, span) and the
raydamp version, as a JSON string (NetCDF attributes are flat).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..solution import Solution

__all__ = ["to_xarray", "from_xarray", "save", "from_npz", "FORMATS"]

FORMATS = (".nc", ".npz", ".csv")
_FORMAT_OF_SUFFIX = dict(zip(FORMATS, ("netcdf", "npz", "csv")))
_SCALARS = ("status", "steps", "failed_step", "message", "method", "tableau", "composition", "h", "max_momentum_drift",
            "wall_time")


def _attributes(sol: Solution) -> dict[str, Any]:
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


def _dofs(provenance: dict[str, Any]) -> np.ndarray | None:
    """The saved coordinates' indices, from the provenance's save_dofs (None: every coordinate was saved)."""
    dofs = provenance.get("save_dofs")
    return None if dofs is None else np.asarray(dofs, dtype=np.int64)


def _scalars_from(attrs: dict[str, Any]) -> dict[str, Any]:
    out = {key: attrs.get(key, "") for key in _SCALARS}
    out["steps"] = int(out["steps"])
    out["failed_step"] = None if int(out["failed_step"]) < 0 else int(out["failed_step"])
    out["tableau"] = out["tableau"] or None
    out["composition"] = out.get("composition") or None
    out["h"] = float(out["h"])
    out["max_momentum_drift"] = float(out["max_momentum_drift"])
    out["wall_time"] = float(out["wall_time"])
    out["status"], out["message"], out["method"] = str(out["status"]), str(out["message"]), str(out["method"])
    return out


def to_xarray(sol: Solution):
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


def from_xarray(ds) -> Solution:
    """A Solution from ``to_xarray``'s Dataset, provenance included."""
    provenance = json.loads(ds.attrs["provenance"])
    return Solution(t=np.asarray(ds["t"].values, float), q=np.asarray(ds["q"].values, float),
                    p=np.asarray(ds["p"].values, float), energy=np.asarray(ds["energy"].values, float),
                    momentum=np.asarray(ds["momentum"].values, float).reshape(ds.sizes["time"], -1),
                    work=np.asarray(ds["work"].values, float) if "work" in ds else None, origin=provenance,
                    load_work=np.asarray(ds["load_work"].values, float) if "load_work" in ds else None,
                    dofs=_dofs(provenance), **_scalars_from(dict(ds.attrs)))


def _csv_table(sol: Solution) -> tuple[list[str], np.ndarray]:
    names = ["t", *(f"q_{c}" for c in sol.coordinates), *(f"p_{c}" for c in sol.coordinates), "energy",
             *sol.momentum_names]
    columns = [sol.t[:, None], sol.q, sol.p, sol.energy[:, None], sol.momentum]
    for name in ("work", "load_work"):
        if getattr(sol, name) is not None:
            names.append(name)
            columns.append(getattr(sol, name)[:, None])
    return names, np.hstack(columns)


def save(sol: Solution, path) -> None:
    """Write ``sol`` to ``path``, the format chosen by the suffix (.nc, .npz, .csv), a slice of rows at a
    time (writer.write_solution, which the service's downloads use too)."""
    from .writer import write_solution

    path = Path(path)
    fmt = _FORMAT_OF_SUFFIX.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(f"path: unknown format {path.suffix!r} (known: {', '.join(FORMATS)})")
    write_solution(path, fmt, sol)


def from_npz(path) -> Solution:
    """A Solution from ``save``'s .npz file, provenance included."""
    with np.load(path, allow_pickle=False) as data:
        attrs = json.loads(str(data["attrs"]))
        provenance = json.loads(attrs["provenance"])
        rows = data["t"].shape[0]
        return Solution(t=data["t"], q=data["q"], p=data["p"], energy=data["energy"],
                        momentum=data["momentum"].reshape(rows, -1),
                        work=data["work"] if "work" in data else None, origin=provenance,
                        load_work=data["load_work"] if "load_work" in data else None,
                        dofs=_dofs(provenance), **_scalars_from(attrs))
