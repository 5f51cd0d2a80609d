"""A Solution read back from its files (dataset.py's layout: an xarray Dataset, NetCDF, NPZ), provenance included."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from ..event_table import EventTable
from ..solution import Solution
from .dataset import _SCALARS, FORMATS, SPRING_ARRAYS, to_xarray

__all__ = ["from_xarray", "from_npz", "to_xarray", "FORMATS"]


def from_xarray(ds) -> Solution:
    """A Solution from ``to_xarray``'s Dataset, provenance included."""
    provenance = json.loads(ds.attrs["provenance"])
    return Solution(t=np.asarray(ds["t"].values, float), q=np.asarray(ds["q"].values, float),
                    p=np.asarray(ds["p"].values, float), energy=np.asarray(ds["energy"].values, float),
                    momentum=np.asarray(ds["momentum"].values, float).reshape(ds.sizes["time"], -1),
                    work=np.asarray(ds["work"].values, float) if "work" in ds else None, origin=provenance,
                    load_work=np.asarray(ds["load_work"].values, float) if "load_work" in ds else None,
                    multipliers=np.asarray(ds["multipliers"].values, float) if "multipliers" in ds else None,
                    **{name: np.asarray(ds[name].values, float) for name in SPRING_ARRAYS if name in ds},
                    dofs=_dofs(provenance), events=_events(ds, ds.attrs), **_scalars_from(dict(ds.attrs)))


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
                        multipliers=data["multipliers"] if "multipliers" in data else None,
                        **{name: data[name] for name in SPRING_ARRAYS if name in data},
                        dofs=_dofs(provenance), events=_events(data, attrs), **_scalars_from(attrs))


def _events(data, attrs: dict[str, Any]) -> EventTable | None:
    """The events table written beside the trajectory (dataset.event_columns), or None: q and p are at the
    saved coordinates."""
    if "event_names" not in attrs:
        return None
    names = json.loads(attrs["event_names"])
    if "event_t" not in data:
        return EventTable(names, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 0)),
                          np.zeros((0, 0)))
    crossed = [str(n) for n in np.asarray(data["event_name"]).tolist()]
    return EventTable(names, np.array([names.index(n) for n in crossed], dtype=np.int64),
                      np.asarray(data["event_direction"], np.int64), np.asarray(data["event_t"], float),
                      np.asarray(data["event_q"], float), np.asarray(data["event_p"], float))


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
