"""Envelope recorders: peaks taken at the end of every step, not only at the saved rows.

``raydamp.integrate(..., envelope=["drift", "abs_acceleration", "residual_drift"])`` keeps, for each quantity
named, its largest magnitude over the run and the time it happens (``Solution.envelope``, an xarray Dataset);
``integrate_ensemble`` keeps them per member, and :func:`raydamp.ida` runs on them alone, saving no
trajectory. The names are those an OpenSees user knows from an envelope recorder:

- ``"displacement"`` (per coordinate): max |q_i|. Under a :class:`raydamp.GroundMotion`, relative to the ground.
- ``"velocity"`` (per coordinate): max |v_i|, v = M^-1 p (relative under a ground motion).
- ``"acceleration"`` (per coordinate): max |a_i|, the relative acceleration a = M^-1 (-grad V - C v + f(t)).
- ``"abs_acceleration"`` (per coordinate): max |a_i + r_i a_g(t)|, the relative acceleration plus the
  ground's (the ground motion terms of the load: what an accelerometer on the floor reads, OpenSees'
  absolute acceleration with ``-timeSeries``). Without a ground motion it equals ``"acceleration"``.
- ``"drift"`` (per spring): max |d_s|, d_s = q_j - q_i the spring's deformation (q_j for a spring to the
  ground). For a shear frame, whose springs are its storeys, the interstorey drift.
- ``"force"`` (per spring): max |sigma_s(d_s)|, the spring's force (a shear frame's storey shear).
- ``"residual_drift"`` (per spring): d_s at the run's end, signed (the permanent set).
- ``"residual_displacement"`` (per coordinate): q_i at the run's end, signed.

Every peak is taken at t = 0 and at each step's end (a step's end is where the state is known; a peak
between step ends is not interpolated), so the peak of a trajectory saved every step equals it exactly.
The Dataset holds ``<name>`` and ``<name>_time`` per peak (dims ``dof`` and ``spring``; ``member`` first in
an ensemble), the residuals without a time; springs are in the order the Structure lists them.

A run with an envelope steps whole steps (as events do): 3s's merged damping flows between steps are not
merged, which changes its result by rounding only.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .. import _core
from .._validation import _short, real
from ..jobs.envelope_forms import ENVELOPE_QUANTITIES as QUANTITIES
from ..jobs.envelope_forms import PER_SPRING as _PER_SPRING

__all__ = ["QUANTITIES", "Prepared", "prepare", "limits", "dataset"]

PEAKS: tuple[str, ...] = tuple(_core.PEAKS)  # taken in the step loop (record/envelope.hpp)
RESIDUALS = tuple(q for q in QUANTITIES if q not in PEAKS)  # read from the final state


@dataclass(frozen=True)
class Prepared:
    names: tuple[str, ...]    # in the order asked
    core: object              # the _core.EnvelopeSpec
    order: np.ndarray         # the user's index of each spring in the core's order
    first: np.ndarray         # each spring's coordinates (i, -1 to the ground; j), the user's order
    second: np.ndarray
    n_springs: int
    collapse: float | list[float] | None = None  # as given (provenance)


def _spring_columns(model):
    springs = tuple(getattr(model, "springs", ()) or ())
    if not springs:
        return (), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    from ..systems.yielding import core_order

    first = np.array([s.dofs[0] if len(s.dofs) == 2 else -1 for s in springs], dtype=np.int64)
    second = np.array([s.dofs[-1] for s in springs], dtype=np.int64)
    return springs, core_order(springs), first, second


def prepare(model, envelope, *, collapse=None, given_collapse=None, where: str = "envelope") -> Prepared | None:
    """The checked envelope of a run of ``model``: ``envelope`` a list of names of QUANTITIES (None: none);
    ``collapse`` per-spring limits of |d_s| (the user's order, from limits()) past which the run stops as
    "collapsed" (raydamp.ida's), or None; ``given_collapse`` as the caller gave it (provenance). A ValueError
    names ``where`` (``envelope[1]``)."""
    if envelope is None and collapse is None:
        return None
    envelope = [] if envelope is None else envelope
    if isinstance(envelope, (str, bytes, Mapping)) or not isinstance(envelope, (list, tuple)):
        raise ValueError(f"{where} must be a list of names ({', '.join(QUANTITIES)}), got {_short(envelope)}")
    springs, order, first, second = _spring_columns(model)
    names = []
    for k, name in enumerate(envelope):
        if not isinstance(name, str) or name not in QUANTITIES:
            raise ValueError(f"{where}[{k}]: unknown quantity {_short(name)} (known: {', '.join(QUANTITIES)})")
        if name in names:
            raise ValueError(f"{where}[{k}]: {name!r} is listed twice")
        if name in _PER_SPRING and not springs:
            raise ValueError(f"{where}[{k}]: {name!r} is a spring's, and this model has no springs "
                             "(a raydamp.Structure with springs=[raydamp.Spring(...)])")
        names.append(name)
    core_limits = [] if collapse is None else np.asarray(collapse, dtype=float)[order].tolist()
    core = _core.EnvelopeSpec([n for n in names if n in PEAKS], core_limits, order.tolist())
    return Prepared(tuple(names), core, order, first, second, len(springs), _as_given(given_collapse))


def limits(model, collapse, where: str = "collapse") -> np.ndarray | None:
    """``collapse`` as one positive limit per spring of ``model`` (a number for all, or one per spring in the
    Structure's order), or None; a ValueError names ``where``."""
    if collapse is None:
        return None
    springs = tuple(getattr(model, "springs", ()) or ())
    if not springs:
        raise ValueError(f"{where}: a limit of a spring's drift, and this model has no springs")
    if isinstance(collapse, (list, tuple, np.ndarray)):
        if len(collapse) != len(springs):
            raise ValueError(f"{where}: {len(collapse)} values for {len(springs)} springs; give one per spring, "
                             "or one number for all")
        return np.array([real(f"{where}[{s}]", c, positive=True) for s, c in enumerate(collapse)])
    return np.full(len(springs), real(where, collapse, positive=True))


def dataset(prepared: Prepared, out: dict, q_final: np.ndarray, *, ensemble: bool = False):
    """The envelope of a run (or of every member, ``ensemble``) as an xarray Dataset, from the core's
    ``out["envelope"]`` and the final states q_final ((n,), or (members, n))."""
    import xarray as xr

    found = out["envelope"]
    lead = ("member",) if ensemble else ()
    variables = {}
    for name in prepared.names:
        spring = name in _PER_SPRING
        dims = lead + ("spring" if spring else "dof",)
        if name in RESIDUALS:
            if spring:
                start = np.where(prepared.first >= 0, q_final[..., np.maximum(prepared.first, 0)], 0.0)
                value = q_final[..., prepared.second] - start
            else:
                value = np.array(q_final, dtype=float)
            variables[name] = (dims, value)
            continue
        peak, time = found[name]
        if spring:  # the core keeps springs by material kind: back to the user's order
            peak, time = _users_order(peak, prepared.order), _users_order(time, prepared.order)
        variables[name] = (dims, np.asarray(peak))
        variables[f"{name}_time"] = (dims, np.asarray(time))
    collapsed = np.asarray(found.get("collapse_spring", -1) if found else -1)
    users = np.where(collapsed >= 0, prepared.order[np.maximum(collapsed, 0)] if prepared.n_springs else -1, -1)
    if ensemble:
        variables["collapsed_spring"] = (("member",), users.astype(np.int64))
        return xr.Dataset(variables)
    return xr.Dataset(variables, attrs={"collapsed_spring": int(users)})


def users_springs(model, values):
    """An array (..., springs) in the core's order of the springs (grouped by kind) in ``model``'s order, or
    None for None."""
    if values is None:
        return None
    _, order, _, _ = _spring_columns(model)
    return _users_order(np.asarray(values), order)


def _as_given(collapse):
    """A collapse limit as the job JSON holds it: a number, or a list of them."""
    if collapse is None:
        return None
    return float(collapse) if np.ndim(collapse) == 0 else [float(c) for c in collapse]


def _users_order(core: np.ndarray, order: np.ndarray) -> np.ndarray:
    out = np.empty_like(core)
    out[..., order] = core
    return out
