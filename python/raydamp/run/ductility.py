"""raydamp.ductility_spectrum: constant-ductility inelastic response spectra of a ground-motion record.

Each period T runs the oscillator m u'' + c u' + sigma(u) = -m a_g(t) with k = m omega^2, c = 2 zeta m omega and a
hysteretic material sigma of yield force fy. In units of the yield deformation u_y = fy / k and of the time
omega t, every period and every fy is one model, x'' + 2 zeta x' + sigma_1(x) = -a_g(t / omega) / (omega^2 u_y)
(sigma_1 the material with k = 1, fy = 1): so all the oscillators of one round of the search run as one ensemble,
members differing by their record's time scale and amplitude only, and the peak |x| is the ductility itself.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import _core
from .._validation import _short, integer, real, values
from ..loads import Load
from ..systems.materials import ElasticPlastic, Material
from ..systems.yielding import Spring, Structure
from .ensemble import integrate_ensemble
from .events import Event
from .spectrum import _periods, _record

__all__ = ["ductility_spectrum"]

_DOWN = 0.8       # the search's step down in fy between rounds, until the target ductility is passed
_LOWEST = 1e-3    # ... down to fy = _LOWEST f0, below which the target counts as not reached
_ROUNDS = 60      # rounds of the bracketed search at most
_BAND = 4.0       # the periods of one ensemble call are within this factor of each other


def ductility_spectrum(record, periods, ductility, damping: float = 0.05, material: Material | None = None, *,
                       steps_per_period: int = 64, tolerance: float = 1e-6, threads: int | None = None):
    """The constant-ductility inelastic spectrum of ``record``: for each period and target ductility mu, the
    largest yield strength fy whose peak deformation is mu times its yield deformation.

    Each oscillator (mass m, k = m omega^2, damping c = 2 zeta m omega, a spring of ``material``) starts from
    rest. Its yield strength is searched as Chopra does (Dynamics of Structures, section 7.5): from the elastic
    strength f0 = k SD (the elastic spectrum's, :func:`raydamp.response_spectrum`), fy steps down by a factor
    0.8 per round until the achieved ductility passes mu; the last step brackets the largest fy that gives mu
    (one that lies in an earlier step, where mu(fy) rose past mu and fell back within one step, is not seen),
    and a regula falsi (Illinois) narrows the bracket until the ductility is within ``tolerance`` of mu, or fy
    within ``tolerance`` relative. A round runs every period still searching as members of ensembles, one per
    band of periods within a factor 4 of each other (0.05-5 s: four calls a round), since each member runs as
    long as the longest record of its call in its own time.

    The peak deformation u_m is the largest |u| over the record and the free vibration that follows, up to its
    first turning point (u' = 0) after the record's end: the turning points are located on each step's
    interpolant (events), so u_m is the response's own, not the largest of a sampled trajectory.

    The oscillators step with 3s composed by yoshida4 on ``steps_per_period`` steps per natural period, the
    springs' kinks (yield, unloading) and the record's samples located inside the steps
    (:class:`raydamp.Structure`'s ``locate_kinks``), so the composition keeps its order 4 in h / T whatever the
    record's step. Measured against an event-driven exact solution (tests/test_ductility_spectrum.py): the
    ductility the exact solution gives at the fy found is within 2.5e-5 of the target at 64 steps per period and
    1.2e-6 at 128 (periods 0.3-1.5 s, mu = 2 and 4).

    Parameters
    ----------
    record : the ground acceleration, any form :func:`raydamp.response_spectrum` takes.
    periods : natural periods T > 0 (seconds, in the record's time unit).
    ductility : a target ductility mu >= 1, or a vector of them.
    damping : the damping ratio zeta in [0, 1) (default 0.05).
    material : the spring's material as a shape: a :mod:`raydamp.materials` instance whose k and fy are replaced
        by each oscillator's (its b, or alpha, beta, gamma, are kept); None for ElasticPlastic.
    steps_per_period : steps per natural period, >= 8 (default 64).
    tolerance : the search's relative tolerance on the ductility and on fy, in [1e-12, 0.1] (default 1e-6).
    threads : threads of each round's ensemble (None: one per hardware thread).

    Returns
    -------
    xarray.Dataset with coordinates ``ductility`` (the targets) and ``period``, and variables (ductility, period):
    ``fy_ratio`` (fy / f0, the normalised yield strength), ``Ay`` (fy / m = omega^2 u_y, the pseudo-acceleration
    at yield, in the record's unit), ``Dy`` (u_y), ``SD`` (u_m, the peak deformation), ``ductility_achieved``
    (u_m / u_y at the fy found) and ``elastic_SD``. A period whose target is not reached with fy >= 1e-3 f0 has
    NaN there.
    """
    t, a_g, name = _record(record)
    periods = _periods(periods)
    targets = _ductility(ductility)
    zeta = real("damping", damping)
    if not 0.0 <= zeta < 1.0:
        raise ValueError(f"damping must be in [0, 1) (a damping ratio, 0.05 for 5%), got {zeta!r}")
    shape = _material(material)
    steps_per_period = integer("steps_per_period", steps_per_period)
    if steps_per_period < 8:
        raise ValueError(f"steps_per_period must be >= 8, got {steps_per_period}")
    tolerance = real("tolerance", tolerance)
    if not 1e-12 <= tolerance <= 0.1:
        raise ValueError(f"tolerance must be in [1e-12, 0.1], got {tolerance!r}")

    omega = 2.0 * np.pi / periods
    elastic_sd = _core.elastic_peaks(omega, zeta, t, a_g)
    if not np.all(elastic_sd > 0):
        raise ValueError("record: the elastic response is zero at some period (an all-zero record?); a ductility "
                         "needs a response to yield")
    search = _Search(t, a_g, omega, zeta, shape, steps_per_period, threads)
    n_p, n_mu = periods.size, targets.size
    period_of = np.tile(np.arange(n_p), n_mu)  # member m: ductility m // n_p, period m % n_p
    target = np.repeat(targets, n_p)
    eta, achieved = _largest_strength(search, period_of, target, elastic_sd, tolerance)

    u_y = eta * elastic_sd[period_of]
    import xarray as xr

    def grid(values):
        return (("ductility", "period"), values.reshape(n_mu, n_p))

    return xr.Dataset(
        {"fy_ratio": grid(eta) + ({"long_name": "yield strength over the elastic strength, fy / f0"},),
         "Ay": grid(omega[period_of] ** 2 * u_y) + ({"long_name": "fy / m = omega^2 u_y"},),
         "Dy": grid(u_y) + ({"long_name": "yield deformation u_y = fy / k"},),
         "SD": grid(achieved * u_y) + ({"long_name": "peak deformation u_m"},),
         "ductility_achieved": grid(achieved) + ({"long_name": "u_m / u_y at the fy found"},),
         "elastic_SD": ("period", elastic_sd, {"long_name": "elastic SD (raydamp.response_spectrum)"})},
        coords={"ductility": ("ductility", targets, {"long_name": "target ductility"}),
                "period": ("period", periods, {"units": "s", "long_name": "natural period"})},
        attrs={"damping": zeta, "material": repr(shape), "record": name, "record_samples": int(t.size),
               "record_duration": float(t[-1] - t[0]), "steps_per_period": steps_per_period,
               "tolerance": tolerance,
               "peak": "largest |u| over the record and the free vibration up to its first turning point after it",
               "method": "3s+yoshida4 with located kinks; fy searched down by 0.8 per round, then regula falsi "
                         "(Illinois)"})


class _Search:
    """The rounds of the search: achieved ductilities of (period, fy / f0) pairs, one ensemble per call."""

    def __init__(self, t, a_g, omega, zeta, shape, steps_per_period, threads):
        self.omega = omega
        start = t[0]
        # each period's record in its own time omega (t - t0), one Load object per period (shared by its members)
        self.loads = [Load.series(w * (t - start), a_g, [1.0]) for w in omega]
        self.window = omega * (t[-1] - start)  # the record's end, in each period's time
        unit = dataclasses.replace(shape, k=1.0, fy=1.0)
        self.model = Structure([[1.0]], springs=[Spring((0,), unit)], alpha=2.0 * zeta, locate_kinks=True)
        self.h = 2.0 * np.pi / steps_per_period
        self.threads = threads
        self.turning = [Event("p[0]", name="turning")]

    def ductility(self, period_of: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
        """Peak |x| of the members (period_of[m], load amplitude[m]) over each one's window: one ensemble per band
        of periods within a factor _BAND of each other (a member runs as long as its band's longest window, so a
        band bounds the free vibration it runs past its own)."""
        peak = np.empty(period_of.size)
        band = np.floor(np.log(self.window[period_of] / self.window.min()) / np.log(_BAND)).astype(int)
        for b in np.unique(band):
            members = np.flatnonzero(band == b)
            peak[members] = self._band(period_of[members], amplitude[members])
        return peak

    def _band(self, period_of: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
        members = period_of.size
        # past the longest window by 1.5 periods (3 pi): time for the turning point that follows it
        t_end = float(np.max(self.window[period_of])) + 3.0 * np.pi
        n_steps = int(np.ceil(t_end / self.h))
        sol = integrate_ensemble(self.model, np.zeros((members, 1)), np.zeros((members, 1)), method="3s",
                                 composition="yoshida4", h=self.h, n_steps=n_steps, save_every=n_steps,
                                 threads=self.threads, load=[self.loads[i] for i in period_of],
                                 parameters={"load.amplitude": amplitude}, events=self.turning)
        bad = np.flatnonzero(np.asarray(sol.status) != "completed")
        if bad.size:
            raise RuntimeError(f"ductility_spectrum: an oscillator's run did not complete: {sol.status[bad[0]]}")
        table = sol.events
        who, when, where = table.member, table.t, np.abs(table.q[:, 0])
        window = self.window[period_of]
        peak = np.zeros(members)
        inside = when <= window[who]
        np.maximum.at(peak, who[inside], where[inside])
        # the first turning point after each member's window (time order within a member)
        after = np.flatnonzero(~inside)
        order = after[np.lexsort((when[after], who[after]))]
        first_members, first = np.unique(who[order], return_index=True)
        np.maximum.at(peak, first_members, where[order[first]])
        missing = np.setdiff1d(np.arange(members), first_members)  # no turning point left in the run: its end
        peak[missing] = np.maximum(peak[missing], np.abs(np.asarray(sol.q)[missing, -1, 0]))
        return peak


def _largest_strength(search: _Search, period_of, target, elastic_sd, tolerance):
    """(fy / f0, achieved ductility) per member: the largest fy / f0 whose ductility is the target."""
    members = period_of.size

    def achieved(which, eta):
        p = period_of[which]
        return search.ductility(p, -1.0 / (search.omega[p] ** 2 * eta * elastic_sd[p]))

    # above: fy / f0 where the ductility is still below the target; below: where it has passed it
    hi = np.full(members, 1.5)
    mu_hi = achieved(np.arange(members), hi)
    lo = np.full(members, np.nan)
    mu_lo = np.full(members, np.nan)
    open_ = np.flatnonzero(mu_hi < target)
    lo[mu_hi >= target], mu_lo[mu_hi >= target] = hi[mu_hi >= target], mu_hi[mu_hi >= target]  # mu = 1: reached
    eta = hi.copy()
    while open_.size:
        trial = hi[open_] * _DOWN
        mu = achieved(open_, trial)
        passed = mu >= target[open_]
        lo[open_[passed]], mu_lo[open_[passed]] = trial[passed], mu[passed]
        hi[open_[~passed]], mu_hi[open_[~passed]] = trial[~passed], mu[~passed]
        open_ = open_[~passed & (trial > _LOWEST)]
    found = np.isfinite(lo)
    # Illinois on log(fy / f0): f = mu - target, f(hi) < 0 <= f(lo)
    x_lo, x_hi = np.log(np.where(found, lo, 1.0)), np.log(hi)
    f_lo, f_hi = mu_lo - target, mu_hi - target
    best, best_mu = np.where(found, lo, np.nan), np.where(found, mu_lo, np.nan)
    side = np.zeros(members, dtype=int)
    active = np.flatnonzero(found & (f_lo > tolerance * target) & (x_hi - x_lo > tolerance))
    for _ in range(_ROUNDS):
        if not active.size:
            break
        a = active
        x = x_hi[a] - f_hi[a] * (x_hi[a] - x_lo[a]) / (f_hi[a] - f_lo[a])
        width = x_hi[a] - x_lo[a]
        x = np.clip(x, x_lo[a] + 0.01 * width, x_hi[a] - 0.01 * width)  # keep inside: mu(fy) is not smooth
        mu = achieved(a, np.exp(x))
        f = mu - target[a]
        up = f >= 0.0  # the new point replaces lo
        for mask, f_keep, x_new, f_new, flag in ((up, f_hi, x_lo, f_lo, 1), (~up, f_lo, x_hi, f_hi, -1)):
            m = a[mask]
            x_new[m], f_new[m] = x[mask], f[mask]
            again = side[m] == flag  # the same side twice: halve the other end's f (Illinois)
            f_keep[m[again]] *= 0.5
            side[m] = flag
        closer = np.abs(f) <= np.abs(best_mu[a] - target[a])
        best[a[closer]], best_mu[a[closer]] = np.exp(x[closer]), mu[closer]
        active = a[(np.abs(f) > tolerance * target[a]) & (x_hi[a] - x_lo[a] > tolerance)]
    eta[:] = best
    return eta, best_mu


def _ductility(ductility) -> np.ndarray:
    return values("ductility", ductility, minimum=1.0, what="target ductility")


def _material(material) -> Material:
    if material is None:
        return ElasticPlastic(1.0, 1.0)
    if not isinstance(material, Material):
        raise ValueError(f"material must be a raydamp.materials material (its k and fy are replaced) or None, got "
                         f"{_short(material)}")
    return material
