"""An event-driven exact solution of a bilinear (b = 0: elastic-perfectly-plastic) SDOF under a half-sine
pulse, independent of raydamp: the reference of tests/test_structure_springs.py.

    m u'' + c u' + sigma(u) = p0 sin(w t) for t <= t_d, 0 after.

Between events the equation is linear with constant coefficients: elastic, sigma = sigma* + k (u - u*)
(from the last unloading point); yielding, sigma = b k u +- (1 - b) fy (Steel01's asymptotes without
isotropic hardening). With y = (u, v, s, co, 1) and s = sin(w t), co = cos(w t) carried along, y' = B y and
y(t) = expm(B (t - t0)) y(t0) exactly. Events: the elastic line meets an asymptote (yield), the velocity
reaches 0 while yielding (unloading), the pulse ends. Each is found by a scan and brentq on the exact
solution, to 1e-15 in time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.optimize import brentq


@dataclass
class Phase:
    t0: float
    y0: np.ndarray
    B: np.ndarray
    mode: int  # 0 elastic, +1 / -1 yielding on the upper / lower asymptote
    sigma_star: float = 0.0
    u_star: float = 0.0

    def at(self, t: float) -> np.ndarray:
        return scipy.linalg.expm(self.B * (t - self.t0)) @ self.y0


class HystereticSDOF:
    def __init__(self, m, c, k, fy, b, p0, w, t_d, t_end):
        self.m, self.c, self.k, self.fy, self.b = m, c, k, fy, b
        self.p0, self.w, self.t_d = p0, w, t_d
        self.phases: list[Phase] = []
        y = np.array([0.0, 0.0, 0.0, 1.0, 1.0])  # sin(0), cos(0)
        t, mode, sigma_star, u_star = 0.0, 0, 0.0, 0.0
        while t < t_end:
            phase = Phase(t, y, self._matrix(mode, sigma_star, u_star, t < t_d), mode, sigma_star, u_star)
            self.phases.append(phase)
            limit = min(t_d, t_end) if t < t_d else t_end
            event, kind = self._next_event(phase, limit)
            y = phase.at(event)
            t = event
            if kind == "yield+":
                mode = 1
            elif kind == "yield-":
                mode = -1
            elif kind == "unload":
                sigma_star, u_star = self._sigma(mode, sigma_star, u_star, y[0]), y[0]
                mode = 0
        self.t_end = t_end

    def _sigma(self, mode, sigma_star, u_star, u):
        if mode == 0:
            return sigma_star + self.k * (u - u_star)
        return self.b * self.k * u + mode * (1 - self.b) * self.fy

    def _matrix(self, mode, sigma_star, u_star, loaded):
        m = self.m
        if mode == 0:
            stiffness, offset = self.k, sigma_star - self.k * u_star
        else:
            stiffness, offset = self.b * self.k, mode * (1 - self.b) * self.fy
        B = np.zeros((5, 5))
        B[0, 1] = 1.0
        B[1, 0] = -stiffness / m
        B[1, 1] = -self.c / m
        B[1, 4] = -offset / m
        if loaded:
            B[1, 2] = self.p0 / m
            B[2, 3] = self.w
            B[3, 2] = -self.w
        return B

    def _events(self, phase, y):
        """The event functions of a phase at state y: each crosses from < 0 to >= 0 at its event."""
        u, v = y[0], y[1]
        if phase.mode == 0:
            sigma = self._sigma(0, phase.sigma_star, phase.u_star, u)
            upper = self.b * self.k * u + (1 - self.b) * self.fy
            lower = self.b * self.k * u - (1 - self.b) * self.fy
            return {"yield+": sigma - upper, "yield-": lower - sigma}
        return {"unload": -phase.mode * v}

    def _next_event(self, phase, limit):
        step = 5e-3  # the event functions' crossings are isolated on this scale (elastic period 1 s)
        P = scipy.linalg.expm(phase.B * step)
        y, t = phase.y0, phase.t0
        before = self._events(phase, y)
        while t < limit:
            t_next = t + step
            if t_next < limit:
                y_next = P @ y
            else:
                t_next = limit
                y_next = phase.at(limit)
            after = self._events(phase, y_next)
            for kind, g in after.items():
                if before[kind] < 0 <= g:
                    root = brentq(lambda s, kind=kind: self._events(phase, phase.at(s))[kind], t, t_next,
                                  xtol=1e-15, rtol=1e-15)
                    return root, kind
            y, t, before = y_next, t_next, after
        return limit, "time"

    def displacement(self, times) -> np.ndarray:
        """u at each of the increasing times (from each phase's start by a fixed propagator per step size)."""
        times = np.asarray(times, dtype=float)
        out = np.empty_like(times)
        starts = np.array([p.t0 for p in self.phases])
        which = np.searchsorted(starts, times, side="right") - 1
        for index in np.unique(which):
            phase = self.phases[index]
            picked = np.flatnonzero(which == index)
            lam, V = np.linalg.eig(phase.B)
            if np.linalg.cond(V) < 1e6:  # diagonalisable (every phase but a perfectly plastic one): vectorised
                coefficients = np.linalg.solve(V, phase.y0.astype(complex))
                out[picked] = np.real(np.exp(np.outer(times[picked] - phase.t0, lam)) @ (V[0] * coefficients))
                continue
            y, t = phase.y0, phase.t0
            cache: dict[float, np.ndarray] = {}
            for i in picked:
                dt = times[i] - t
                key = round(dt, 12)  # step sizes equal but for rounding share one propagator
                if key not in cache:
                    cache[key] = scipy.linalg.expm(phase.B * key)
                y = cache[key] @ y
                t = times[i]
                out[i] = y[0]
        return out

    def peak(self) -> float:
        """The largest |u| at an unloading (velocity 0 while yielding): the peak of a pulse that yields once,
        as Chopra's does (a run's own peak is checked against displacement() at its steps)."""
        return max(abs(p.u_star) for p in self.phases if p.mode == 0 and p.t0 > 0)

    def permanent_set(self) -> float:
        """The centre the last elastic phase decays to: u* - sigma* / k (p = 0 after the pulse)."""
        last = self.phases[-1]
        assert last.mode == 0 and last.t0 >= self.t_d
        return last.u_star - last.sigma_star / self.k
