"""An EnsembleSolution as files: an xarray Dataset with dims (member, time, dof), NetCDF and Zarr,
with its provenance."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..._validation import replaceable_store
from ...jobs.statuses import STATUSES

__all__ = ["ensemble_to_xarray", "save_ensemble", "ENSEMBLE_FORMATS", "ENSEMBLE_SPRING_ARRAYS"]

ENSEMBLE_FORMATS = (".nc", ".zarr")


def _member_coordinates(parameters: dict[str, np.ndarray]) -> dict[str, Any]:
    coords: dict[str, Any] = {}
    for name, values in parameters.items():
        coords[name] = (("member",), values) if values.ndim == 1 else (("member", f"{name}_component"), values)
    return coords


def ensemble_to_xarray(ens: Any):
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
    if ens.spring_forces is not None:
        _add_springs(ens, data, coords)
    provenance = ens.provenance or {}
    messages = {str(i): m for i, (s, m) in enumerate(zip(ens.status, ens.message)) if s != "completed"}
    attrs = {"kind": "ensemble", "provenance": json.dumps(provenance), "method": ens.method,
             "tableau": ens.tableau or "", "composition": ens.composition or "", "h": ens.h,
             "wall_time": ens.wall_time, "threads": ens.threads, "parameters": json.dumps(list(ens.parameters)),
             "messages": json.dumps(messages), "raydamp_version": provenance.get("raydamp_version", "")}
    return xr.Dataset(data, coords=coords, attrs=attrs)


# An ensemble's per-spring arrays: (member, time, spring) at the saved rows, (member, spring) at the last state.
ENSEMBLE_SPRING_ARRAYS = {
    "spring_forces": ("spring force sigma_s (from that row's material state; NaN past a member's rows)", "time"),
    "spring_deformations": ("spring deformation d_s = q_j - q_i (q_j to the ground)", "time"),
    "spring_forces_final": ("spring force at the member's last state", None),
    "spring_deformations_final": ("spring deformation at the member's last state", None),
}


def _add_springs(ens: Any, data: dict[str, Any], coords: dict[str, Any]) -> None:
    """A Structure's spring arrays, with each spring's coordinates (spring_i = -1: the ground) as a single run's
    file gives them (io/dataset.py)."""
    for name, (long_name, time) in ENSEMBLE_SPRING_ARRAYS.items():
        dims = ("member", "time", "spring") if time else ("member", "spring")
        data[name] = (dims, getattr(ens, name), {"long_name": long_name})
    width = ens.spring_forces.shape[2]
    coords["spring"] = np.arange(width)
    if isinstance(ens.origin, tuple):
        springs = [s.dofs for s in getattr(ens.origin[0], "springs", ())]
    else:
        system = (ens.provenance or {}).get("system")
        springs = [s.get("dofs") for s in (system or {}).get("springs") or () if isinstance(s, dict)]
    if len(springs) == width and all(isinstance(d, (list, tuple)) for d in springs):
        coords["spring_i"] = (("spring",), np.array([int(d[0]) if len(d) == 2 else -1 for d in springs], np.int64),
                              {"long_name": "d = q[spring_j] - q[spring_i]; -1: the ground"})
        coords["spring_j"] = (("spring",), np.array([int(d[-1]) for d in springs], np.int64))


def save_ensemble(ens: Any, path) -> None:
    """Write ``ens`` to ``path``: .nc (NetCDF via h5netcdf) or .zarr (a Zarr store, replaced if present)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".nc":
        ensemble_to_xarray(ens).to_netcdf(path, engine="h5netcdf")
    elif suffix == ".zarr":
        replaceable_store("path", path)
        # Zarr format 2: its string arrays (the dof names) have a settled spec, unlike format 3 yet.
        ensemble_to_xarray(ens).to_zarr(path, mode="w", zarr_format=2)
    else:
        raise ValueError(f"path: unknown format {path.suffix!r} for an ensemble (known: {', '.join(ENSEMBLE_FORMATS)})")
