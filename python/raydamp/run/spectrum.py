"""raydamp.response_spectrum: the elastic response spectrum of a ground-motion record, exact for the record as
the straight lines through its samples."""

from __future__ import annotations

import os

import numpy as np

from .. import _core
from .._validation import _short, real, values
from ..loads import GroundMotion, Load
from ..loads import terms as T

__all__ = ["response_spectrum"]


def response_spectrum(record, periods, damping: float = 0.05):
    """The elastic response spectrum of ``record`` at ``periods``, as an xarray Dataset.

    Each period T runs one oscillator u'' + 2 zeta omega u' + omega^2 u = -a_g(t), omega = 2 pi / T, from rest at
    the record's first sample. a_g is the straight lines through the record's samples, so each sample interval
    is one exact step (Nigam and Jennings' recurrence, in the core), and the response carries no error of a step
    size. SD is the peak |u| over the record's sample times, as Nigam and Jennings and eqsig define it (the peak
    between two samples can be slightly larger; take a record resampled finer for that).

    Parameters
    ----------
    record : the ground acceleration a_g(t): a pair (t, a_g) of arrays, a :class:`raydamp.Load` of one series
        without direction (``Load.series(t, a_g)``, ``Load.from_file(path, factor=9.81)``), a
        :class:`raydamp.GroundMotion` (its acceleration), or a file path (read as :meth:`raydamp.Load.from_file`,
        in the file's units). At least two samples; the times may be unevenly spaced.
    periods : natural periods T > 0 (seconds, in the record's time unit), any order.
    damping : the damping ratio zeta, in [0, 1) (default 0.05, 5% of critical).

    Returns
    -------
    xarray.Dataset with coordinate ``period`` and variables ``SD`` (peak relative displacement, in the record's
    acceleration unit times s^2), ``PSV = omega SD`` and ``PSA = omega^2 SD``; ``attrs`` name the damping, the
    record (its file, or its sample count), its samples and duration.
    """
    t, a_g, name = _record(record)
    periods = _periods(periods)
    zeta = real("damping", damping)
    if not 0.0 <= zeta < 1.0:
        raise ValueError(f"damping must be in [0, 1) (a damping ratio, 0.05 for 5%), got {zeta!r}")
    omega = 2.0 * np.pi / periods
    sd = _core.elastic_peaks(omega, zeta, t, a_g)
    import xarray as xr

    return xr.Dataset(
        {"SD": ("period", sd, {"long_name": "spectral displacement: peak |u| over the record's sample times"}),
         "PSV": ("period", omega * sd, {"long_name": "pseudo-spectral velocity omega SD"}),
         "PSA": ("period", omega ** 2 * sd, {"long_name": "pseudo-spectral acceleration omega^2 SD"})},
        coords={"period": ("period", periods, {"units": "s", "long_name": "natural period"})},
        attrs={"damping": zeta, "record": name, "record_samples": int(t.size),
               "record_duration": float(t[-1] - t[0]),
               "method": "exact for the piecewise-linear record (Nigam-Jennings recurrence), from rest"})


def _record(record) -> tuple[np.ndarray, np.ndarray, str]:
    """(t, a_g, a name for the attrs) of any form response_spectrum takes, checked; errors name ``record``."""
    if isinstance(record, (str, os.PathLike)):
        record = Load.from_file(record)  # a ValueError names the file
    if isinstance(record, GroundMotion):
        record = record.acceleration
    if isinstance(record, Load):
        terms = record._scaled_terms()
        if len(terms) != 1 or not isinstance(terms[0], T.Series) or terms[0].direction is not None \
                or terms[0].values.ndim != 1:
            raise ValueError("record: expected a history a_g(t), a Load of one series made without direction "
                             f"(Load.series(t, a_g) or Load.from_file), got {record!r}")
        term = terms[0]
        t, a_g = term.t, term.values * term.scale
        name = term.source or f"a series of {t.size} samples"
    elif isinstance(record, (tuple, list)) and len(record) == 2:
        t = T.times("record.t", record[0])
        a_g = T.history("record.values", record[1], t.size)
        if a_g.ndim != 1:
            raise ValueError(f"record.values must be one value per time, got shape {a_g.shape}")
        name = f"a (t, a_g) pair of {t.size} samples"
    else:
        raise ValueError("record must be a pair (t, a_g), a raydamp.Load of one series, a raydamp.GroundMotion or a "
                         f"file path, got {_short(record)}")
    if t.size < 2:
        raise ValueError(f"record: {t.size} sample(s); a record needs at least two samples (one interval)")
    return np.ascontiguousarray(t, dtype=float), np.ascontiguousarray(a_g, dtype=float), name


def _periods(periods) -> np.ndarray:
    return values("periods", periods)
