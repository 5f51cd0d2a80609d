"""Solutions as files: an xarray Dataset, NetCDF, NPZ and CSV, with their provenance.

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

from .ensemble_solution import STATUSES, EnsembleSolution
from .solution import Solution

__all__ = ["to_xarray", "from_xarray", "save", "load", "FORMATS", "ensemble_to_xarray", "ensemble_from_xarray",
           "save_ensemble"]

FORMATS = (".nc", ".npz", ".csv")
ENSEMBLE_FORMATS = (".nc", ".zarr")
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
    coords = {"t": (("time",), sol.t), "dof": list(sol.coordinates), "momentum_map": list(sol.momentum_names)}
    return xr.Dataset(data, coords=coords, attrs=_attributes(sol))


def from_xarray(ds) -> Solution:
    """A Solution from ``to_xarray``'s Dataset, provenance included."""
    provenance = json.loads(ds.attrs["provenance"])
    return Solution(t=np.asarray(ds["t"].values, float), q=np.asarray(ds["q"].values, float),
                    p=np.asarray(ds["p"].values, float), energy=np.asarray(ds["energy"].values, float),
                    momentum=np.asarray(ds["momentum"].values, float).reshape(ds.sizes["time"], -1),
                    work=np.asarray(ds["work"].values, float) if "work" in ds else None, origin=provenance,
                    **_scalars_from(dict(ds.attrs)))


def _csv_table(sol: Solution) -> tuple[list[str], np.ndarray]:
    names = ["t", *(f"q_{c}" for c in sol.coordinates), *(f"p_{c}" for c in sol.coordinates), "energy",
             *sol.momentum_names]
    columns = [sol.t[:, None], sol.q, sol.p, sol.energy[:, None], sol.momentum]
    if sol.work is not None:
        names.append("work")
        columns.append(sol.work[:, None])
    return names, np.hstack(columns)


def save(sol: Solution, path) -> None:
    """Write ``sol`` to ``path``, the format chosen by the suffix (.nc, .npz, .csv)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".nc":
        to_xarray(sol).to_netcdf(path, engine="h5netcdf")
    elif suffix == ".npz":
        arrays = {"t": sol.t, "q": sol.q, "p": sol.p, "energy": sol.energy, "momentum": sol.momentum}
        if sol.work is not None:
            arrays["work"] = sol.work
        attrs = _attributes(sol)
        np.savez(path, **arrays, attrs=np.array(json.dumps(attrs, allow_nan=True)))
    elif suffix == ".csv":
        names, table = _csv_table(sol)
        np.savetxt(path, table, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    else:
        raise ValueError(f"path: unknown format {path.suffix!r} (known: {', '.join(FORMATS)})")


def load(path) -> Solution | EnsembleSolution:
    """Read a solution written by ``Solution.save`` (.nc, .npz) or an ensemble written by
    ``EnsembleSolution.save`` (.nc, .zarr), with its provenance; a sweep's file (.nc, .zarr)
    comes back as its xarray.Dataset."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".nc", ".zarr"):
        import xarray as xr

        if suffix == ".zarr":
            with xr.open_zarr(path) as ds:
                return _from_dataset(ds.load())
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            return _from_dataset(ds.load())
    if suffix == ".npz":
        with np.load(path, allow_pickle=False) as data:
            attrs = json.loads(str(data["attrs"]))
            provenance = json.loads(attrs["provenance"])
            rows = data["t"].shape[0]
            return Solution(t=data["t"], q=data["q"], p=data["p"], energy=data["energy"],
                            momentum=data["momentum"].reshape(rows, -1),
                            work=data["work"] if "work" in data else None, origin=provenance,
                            **_scalars_from(attrs))
    if suffix == ".csv":
        raise ValueError("path: a .csv file keeps the numbers only; save as .nc or .npz to load it back")
    raise ValueError(f"path: unknown format {path.suffix!r} (known: .nc, .npz, .zarr)")



def _from_dataset(ds):
    kind = ds.attrs.get("kind")
    if kind == "sweep":  # a sweep's result is its Dataset (raydamp.sweep's layout)
        return ds
    return ensemble_from_xarray(ds) if kind == "ensemble" else from_xarray(ds)


def save_sweep(ds, path) -> None:
    """Write a :func:`raydamp.sweep` Dataset to ``path``: .nc (NetCDF via h5netcdf) or .zarr."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".nc":
        ds.to_netcdf(path, engine="h5netcdf")
    elif suffix == ".zarr":
        ds.to_zarr(path, mode="w", zarr_format=2)
    else:
        raise ValueError(f"path: unknown format {path.suffix!r} for a sweep (known: {', '.join(ENSEMBLE_FORMATS)})")


# -- ensembles ---------------------------------------------------------------------------------

def _member_coordinates(parameters: dict[str, np.ndarray]) -> dict[str, Any]:
    coords: dict[str, Any] = {}
    for name, values in parameters.items():
        coords[name] = (("member",), values) if values.ndim == 1 else (("member", f"{name}_component"), values)
    return coords


def ensemble_to_xarray(ens: EnsembleSolution):
    """The ensemble as an xarray.Dataset: dims (member, time, dof, momentum_map), a member
    coordinate per swept parameter, the provenance and shared scalars in attrs. Statuses are
    stored as codes (``status.attrs['flag_meanings']``) and the messages of members that did not
    complete as a JSON attribute, so the file needs no string arrays."""
    try:
        import xarray as xr
    except ImportError as error:
        raise ImportError("to_xarray needs xarray: pip install 'raydamp[io]'") from error
    codes = np.array([STATUSES.index(s) for s in ens.status], dtype=np.int8)
    data = {
        "q": (("member", "time", "dof"), ens.q, {"long_name": "positions (NaN past a member's rows)"}),
        "p": (("member", "time", "dof"), ens.p, {"long_name": "momenta (NaN past a member's rows)"}),
        "energy": (("member", "time"), ens.energy, {"long_name": "H(q, p)"}),
        "momentum": (("member", "time", "momentum_map"), ens.momentum, {"long_name": "momentum maps"}),
        "q0": (("member", "dof"), ens.q0, {"long_name": "initial positions"}),
        "p0": (("member", "dof"), ens.p0, {"long_name": "initial momenta"}),
        "rows": (("member",), np.asarray(ens.rows, np.int64), {"long_name": "rows of the save grid reached"}),
        "t_final": (("member",), ens.t_final, {"long_name": "time of the last (finite) state"}),
        "q_final": (("member", "dof"), ens.q_final),
        "p_final": (("member", "dof"), ens.p_final),
        "energy_final": (("member",), ens.energy_final),
        "momentum_final": (("member", "momentum_map"), ens.momentum_final),
        "steps": (("member",), np.asarray(ens.steps, np.int64)),
        "failed_step": (("member",), np.asarray(ens.failed_step, np.int64), {"long_name": "-1: none"}),
        "status": (("member",), codes, {"flag_values": list(range(len(STATUSES))),
                                         "flag_meanings": " ".join(STATUSES)}),
        "max_momentum_drift": (("member",), ens.max_momentum_drift),
    }
    coords = {"member": np.arange(ens.members), "t": (("time",), ens.t), "dof": list(ens.coordinates),
              "momentum_map": list(ens.momentum_names), **_member_coordinates(ens.parameters)}
    provenance = ens.provenance or {}
    messages = {str(i): m for i, (s, m) in enumerate(zip(ens.status, ens.message)) if s != "completed"}
    attrs = {"kind": "ensemble", "provenance": json.dumps(provenance), "method": ens.method,
             "tableau": ens.tableau or "", "composition": ens.composition or "", "h": ens.h,
             "wall_time": ens.wall_time, "threads": ens.threads, "parameters": json.dumps(list(ens.parameters)),
             "messages": json.dumps(messages), "raydamp_version": provenance.get("raydamp_version", "")}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def ensemble_from_xarray(ds) -> EnsembleSolution:
    """An EnsembleSolution from ``ensemble_to_xarray``'s Dataset, provenance included."""
    attrs = dict(ds.attrs)
    status = tuple(STATUSES[int(c)] for c in ds["status"].values)
    steps = np.asarray(ds["steps"].values, np.int64)
    messages = json.loads(attrs["messages"])
    message = tuple(messages.get(str(i), f"completed {steps[i]} steps") for i in range(len(status)))
    members = ds.sizes["member"]

    def values(name):
        return np.asarray(ds[name].values, float)

    return EnsembleSolution(
        t=values("t"), q=values("q"), p=values("p"), energy=values("energy"),
        momentum=values("momentum").reshape(members, ds.sizes["time"], -1), rows=np.asarray(ds["rows"].values, np.int64),
        t_final=values("t_final"), q_final=values("q_final"), p_final=values("p_final"),
        energy_final=values("energy_final"), momentum_final=values("momentum_final").reshape(members, -1),
        status=status, steps=steps, failed_step=np.asarray(ds["failed_step"].values, np.int64), message=message,
        max_momentum_drift=values("max_momentum_drift"), q0=values("q0"), p0=values("p0"),
        parameters={name: values(name) for name in json.loads(attrs["parameters"])}, method=str(attrs["method"]),
        tableau=str(attrs["tableau"]) or None, composition=str(attrs["composition"]) or None, h=float(attrs["h"]),
        wall_time=float(attrs["wall_time"]), threads=int(attrs["threads"]), origin=json.loads(attrs["provenance"]))


def save_ensemble(ens: EnsembleSolution, path) -> None:
    """Write ``ens`` to ``path``: .nc (NetCDF via h5netcdf) or .zarr (a Zarr store, replaced if present)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".nc":
        ensemble_to_xarray(ens).to_netcdf(path, engine="h5netcdf")
    elif suffix == ".zarr":
        # Zarr format 2: its string arrays (the dof names) have a settled spec, unlike format 3 yet.
        ensemble_to_xarray(ens).to_zarr(path, mode="w", zarr_format=2)
    else:
        raise ValueError(f"path: unknown format {path.suffix!r} for an ensemble (known: {', '.join(ENSEMBLE_FORMATS)})")
