"""raydamp.ida: incremental dynamic analysis, every record of a set at every scale, peaks only."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from .._validation import _short, real, values
from ..loads import GroundMotion, Load
from .ensemble import integrate_ensemble
from .envelope import limits

__all__ = ["ida"]


def ida(structure, records, scales, *, h: float, t_end: float, collapse_drift: float = 0.1, heights=1.0,
        method: str | None = "3s", composition: str | None = None, threads: int | None = None, progress=None,
        cancel=None):
    """Incremental dynamic analysis of ``structure``: every record at every scale, as an xarray Dataset of the
    peak drift per record x scale x storey, and whether each run collapsed.

    The runs are the members of one :func:`raydamp.integrate_ensemble` call (one load per member: the record
    times its scale) spread over ``threads``. They save no trajectory, only their envelopes (taken at every
    step's end, :mod:`raydamp.run.envelope`): a run's peaks equal those of ``raydamp.integrate(structure, ...,
    load=record * scale, envelope=["drift", "residual_drift"], collapse=collapse_drift * heights)`` bit for bit.

    Parameters
    ----------
    structure : a :class:`raydamp.Structure` with springs; each spring is a storey (its drift d = q_j - q_i).
        So that a frame can collapse, its springs may soften (``Bilinear(k, fy, b)`` with -1 < b < 0) and K may
        carry a constant geometric (P-Delta) stiffness: for a shear frame with gravity load P_s above storey s of
        height h_s, K_PDelta = -sum_s (P_s / h_s) r_s r_s^T (r_s the storey's direction, e_j - e_i), given as
        ``K`` (K0 = K + the springs' stiffness is checked positive semidefinite; past yield the tangent of a
        storey, b k_s - P_s / h_s, may be negative). Both lower the post-yield stiffness; with a negative one
        the drift runs away once a storey yields far enough.
    records : ground motions (:class:`raydamp.GroundMotion`), a list, or a dict {name: motion}. A record is zero
        after its end, so a shorter record's run goes on in free vibration up to ``t_end``.
    scales : the factors each record is run at (> 0), in any order.
    h, t_end : the step size and the end time, shared by every run.
    collapse_drift : the drift ratio |d_s| / heights_s past which a run has collapsed: it stops at that step's
        end (status "collapsed"), its peaks so far kept, ``collapsed`` True.
    heights : each storey's height (one number, or one per spring in the Structure's order); the drift ratio
        is drift / height. Default 1: the drift itself.
    method : the splitting (default "3s"; any method integrate takes for a Structure with springs).
    composition : a composition raising a symmetric method's order (e.g. "suzuki4"), as integrate takes it; on a
        Structure with ``locate_kinks=True`` it keeps that order through yield and unloading.
    threads, progress, cancel : as :func:`raydamp.integrate_ensemble` (progress counts runs).

    Returns
    -------
    xarray.Dataset with coordinates ``record`` (names, or 0..R-1), ``scale`` and ``storey`` (the springs, in
    the Structure's order) and variables ``peak_drift`` and ``peak_drift_time`` (record, scale, storey),
    ``peak_drift_ratio`` (the drift over its height), ``max_drift_ratio`` (record, scale: the largest over the
    storeys), ``residual_drift`` (record, scale, storey: at the run's end), ``collapsed`` and ``status``
    (record, scale), ``attrs`` the method, h, t_end, collapse_drift, threads and the analysis's wall time.
    """
    springs = tuple(getattr(structure, "springs", ()) or ())
    if not springs:
        raise ValueError(f"structure: a raydamp.Structure with springs (its storeys), got {_short(structure)}")
    names, motions = _records(records)
    scale_values = _scales(scales)
    drift_ratio = real("collapse_drift", collapse_drift, positive=True)
    storey_heights = limits(structure, heights, "heights")
    listed = [motion for motion in motions for _ in scale_values]
    amplitude = np.tile(scale_values, len(motions))
    n = structure.dim
    ens = integrate_ensemble(structure, np.zeros((len(listed), n)), np.zeros((len(listed), n)), load=listed,
                             parameters={"load.amplitude": amplitude}, method=method, composition=composition,
                             h=h, t_end=t_end,
                             save_every=_save_every(h, t_end), threads=threads, progress=progress, cancel=cancel,
                             envelope=["drift", "residual_drift"], collapse=drift_ratio * storey_heights)
    shape = (len(motions), scale_values.size)
    env = ens.envelope
    peak = env["drift"].values.reshape(shape + (len(springs),))
    ratio = peak / storey_heights
    status = np.array(ens.status, dtype=object).reshape(shape)
    import xarray as xr

    cube = ("record", "scale", "storey")
    return xr.Dataset(
        {"peak_drift": (cube, peak, {"long_name": "peak |drift| over every step's end"}),
         "peak_drift_time": (cube, env["drift_time"].values.reshape(peak.shape)),
         "peak_drift_ratio": (cube, ratio, {"long_name": "peak drift / storey height"}),
         "max_drift_ratio": (cube[:2], ratio.max(axis=2), {"long_name": "largest peak drift ratio of any storey"}),
         "residual_drift": (cube, env["residual_drift"].values.reshape(peak.shape)),
         "collapsed": (cube[:2], status == "collapsed"),
         "status": (cube[:2], status.astype(str))},
        coords={"record": names, "scale": scale_values, "storey": np.arange(len(springs)),
                "height": ("storey", storey_heights)},
        attrs={"method": ens.method, "composition": ens.composition or "", "h": ens.h, "t_end": float(t_end),
               "collapse_drift": drift_ratio,
               "threads": int(ens.threads), "wall_time": float(ens.wall_time)})


def _records(records) -> tuple[list, list[Load]]:
    if isinstance(records, Mapping):
        names, motions = [str(k) for k in records], list(records.values())
    elif isinstance(records, Sequence) and not isinstance(records, (str, bytes)):
        names, motions = list(range(len(records))), list(records)
    else:
        raise ValueError(f"records must be a list or dict of raydamp.GroundMotion, got {_short(records)}")
    if not motions:
        raise ValueError("records: empty; give at least one ground motion")
    for k, motion in zip(names, motions):
        if not isinstance(motion, GroundMotion):
            raise ValueError(f"records[{k!r}] must be a raydamp.GroundMotion, got {_short(motion)}")
    return names, motions


def _scales(scales) -> np.ndarray:
    return values("scales", scales)


def _save_every(h, t_end) -> int:
    """Every step of the run: only its first and last rows are saved (the peaks are the envelope's)."""
    from .._validation import span

    n_steps, _ = span(real("h", h, positive=True), t_end, None)
    return n_steps
