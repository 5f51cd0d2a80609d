"""A Solution's layout in files: an xarray Dataset, NetCDF, NPZ and CSV, with its provenance (solution.py reads
it back).

The Dataset has dims (time, dof) and (time, momentum_map): variables q, p, energy, momentum and,
when recorded, work; coordinates t (time), dof (the coordinate names) and momentum_map (the
momentum maps' names). A Structure with springs adds dims (time, spring): spring_forces and
spring_deformations, and with work hysteretic_work, springs in the Structure's order; the coordinates
spring_i and spring_j give each spring's coordinates (d = q[spring_j] - q[spring_i], spring_i = -1 to
the ground). attrs hold the run's status and scalars, and ``provenance``: the job
JSON that produced it (model or system, initial state, method, step size, span) and the
raydamp version, as a JSON string (NetCDF attributes are flat).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

__all__ = ["to_xarray", "event_columns", "events_csv", "FORMATS", "SPRING_ARRAYS"]

FORMATS = (".nc", ".npz", ".csv")
_FORMAT_OF_SUFFIX = dict(zip(FORMATS, ("netcdf", "npz", "csv")))
# A structure's per-spring arrays (time, spring), with each one's long name and its CSV columns' prefix.
SPRING_ARRAYS = {
    "spring_forces": ("spring force sigma_s (from that row's material state)", "spring_force"),
    "spring_deformations": ("spring deformation d_s = q_j - q_i (q_j to the ground)", "spring_deformation"),
    "hysteretic_work": ("hysteretic work W_h,s(t) = int sigma_s dd_s - stored_s(t)", "hysteretic_work"),
}
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
    if getattr(sol, "events", None) is not None:
        attrs["event_names"] = json.dumps(list(sol.events.names))
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
    if getattr(sol, "multipliers", None) is not None:
        data["multipliers"] = (("time", "constraint"), sol.multipliers, {
            "long_name": "constraint multipliers lambda: the constraint force on the coordinates is -G(q)^T lambda"})
        coords["constraint"] = np.arange(sol.multipliers.shape[1])
    springs = _spring_width(sol)
    if springs is not None:
        for name, (long_name, _) in SPRING_ARRAYS.items():
            if getattr(sol, name, None) is not None:
                data[name] = (("time", "spring"), getattr(sol, name), {"long_name": long_name})
        coords["spring"] = np.arange(springs)
        ends = spring_coordinates(sol)
        if ends is not None:
            coords["spring_i"] = (("spring",), ends[0], {"long_name": "d = q[spring_j] - q[spring_i]; -1: the ground"})
            coords["spring_j"] = (("spring",), ends[1])
    for name, (dims, values, attrs) in event_columns(sol).items():
        data[name] = (dims, values, attrs)
    return xr.Dataset(data, coords=coords, attrs=_attributes(sol))


def _spring_width(sol: Any) -> int | None:
    """The number of springs whose arrays the solution holds, or None (no springs, or not kept)."""
    for name in SPRING_ARRAYS:
        values = getattr(sol, name, None)
        if values is not None:
            return int(values.shape[1])
    return None


def spring_coordinates(sol: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """Each spring's coordinates (i, j), i = -1 for a spring to the ground, in the Structure's order: from the
    run's model, or from the provenance's springs (a solution read back); None where neither names them."""
    if isinstance(sol.origin, tuple):
        springs = [s.dofs for s in getattr(sol.origin[0], "springs", ())]
    else:
        system = (sol.provenance or {}).get("system")
        listed = system.get("springs") if isinstance(system, dict) else None
        springs = [s.get("dofs") for s in listed or () if isinstance(s, dict)]
    if not springs or len(springs) != _spring_width(sol) or not all(isinstance(d, (list, tuple)) for d in springs):
        return None
    first = np.array([int(d[0]) if len(d) == 2 else -1 for d in springs], dtype=np.int64)
    return first, np.array([int(d[-1]) for d in springs], dtype=np.int64)


def event_columns(sol: Any) -> dict[str, tuple[tuple[str, ...], np.ndarray, dict[str, str]]]:
    """The run's events table (``sol.events``, when the run watched events) as variables along a
    ``crossing`` dimension: event_name, event_t, event_direction, and event_q, event_p at the saved
    coordinates (dims crossing, dof). The event names, crossed or not, are the attribute event_names."""
    table = getattr(sol, "events", None)
    if table is None or len(table) == 0:  # no crossing: the attribute event_names alone
        return {}
    dofs = slice(None) if sol.dofs is None else np.asarray(sol.dofs)
    width = len(sol.coordinates)
    q = np.asarray(table.q, dtype=float).reshape(len(table), -1)[:, dofs].reshape(len(table), width)
    p = np.asarray(table.p, dtype=float).reshape(len(table), -1)[:, dofs].reshape(len(table), width)
    return {"event_name": (("crossing",), np.array([str(n) for n in table.name], dtype=str).astype(object),
                           {"long_name": "the event crossed"}),
            "event_t": (("crossing",), np.asarray(table.t, dtype=float), {"long_name": "crossing time"}),
            "event_direction": (("crossing",), np.asarray(table.direction, dtype=np.int8),
                                {"long_name": "+1 rising through 0, -1 falling"}),
            "event_q": (("crossing", "dof"), q, {"long_name": "positions at the crossing"}),
            "event_p": (("crossing", "dof"), p, {"long_name": "momenta at the crossing"})}


def events_csv(sol: Any) -> tuple[list[str], list[list[str]]]:
    """The events table as CSV lines: a header (name, t, direction, q_<name>..., p_<name>...) and one row per
    crossing, every number as %.17g."""
    columns = event_columns(sol)
    names = ["name", "t", "direction", *(f"q_{c}" for c in sol.coordinates), *(f"p_{c}" for c in sol.coordinates)]
    if not columns:
        return names, []
    rows = []
    for i, name in enumerate(columns["event_name"][1]):
        numbers = [columns["event_t"][1][i], *columns["event_q"][1][i], *columns["event_p"][1][i]]
        text = [f"{x:.17g}" for x in numbers]
        rows.append([_csv_text(str(name)), text[0], str(int(columns["event_direction"][1][i])), *text[1:]])
    return names, rows


def _csv_text(text: str) -> str:
    """A CSV field: quoted where it holds a comma, a quote or a line break."""
    if any(c in text for c in ',"\n\r'):
        return '"' + text.replace('"', '""') + '"'
    return text


def _csv_table(sol: Any) -> tuple[list[str], np.ndarray]:
    names = ["t", *(f"q_{c}" for c in sol.coordinates), *(f"p_{c}" for c in sol.coordinates), "energy",
             *sol.momentum_names]
    columns = [sol.t[:, None], sol.q, sol.p, sol.energy[:, None], sol.momentum]
    for name in ("work", "load_work"):
        if getattr(sol, name) is not None:
            names.append(name)
            columns.append(getattr(sol, name)[:, None])
    if getattr(sol, "multipliers", None) is not None:
        names.extend(f"multiplier_{i}" for i in range(sol.multipliers.shape[1]))
        columns.append(sol.multipliers)
    for name, (_, prefix) in SPRING_ARRAYS.items():
        values = getattr(sol, name, None)
        if values is not None:
            names.extend(f"{prefix}_{s}" for s in range(values.shape[1]))
            columns.append(values)
    return names, np.hstack(columns)
