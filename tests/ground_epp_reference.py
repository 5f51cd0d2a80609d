"""An event-driven exact trajectory of an elastic-perfectly-plastic SDOF of mass m under a piecewise-linear ground
acceleration, independent of raydamp: the reference of tests/test_absolute_acceleration_springs.py.

    m u'' + c u' + sigma(u) = -m a_g(t),   |sigma| <= fy,  sigma = k (u - u_p) while elastic.

On each record interval [t_k, t_k+1] a_g = a_k + g_k s (s = t - t_k). Within a phase (elastic; yielding upward,
sigma = fy; yielding downward, sigma = -fy) the equation is linear: with y = (u, v, 1, s), y' = B y and
y(s) = expm(B s) y(0) exactly. Events, found by a scan (a 40th of the elastic period) and brentq on the exact
solution to 1e-15: |k (u - u_p)| reaching fy (yield), v reaching 0 against a yielding phase's direction
(unloading: u_p = u - +-fy / k). The trajectory is kept as its phases, so u, v and sigma at any time come from
the phase holding it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from ductility_reference import expm
from scipy.optimize import brentq


@dataclass
class Piece:
    t0: float  # the piece's start
    t1: float  # its end
    y0: np.ndarray  # (u, v, 1, s) at t0, s counted from the record interval's start
    B: np.ndarray
    mode: int  # 0 elastic, +1 / -1 yielding upward / downward
    plastic: float  # u_p of an elastic piece


class GroundEPP:
    def __init__(self, m, c, k, fy, t, a_g):
        self.m, self.c, self.k, self.fy = m, c, k, fy
        self.pieces: list[Piece] = []
        scan = 2 * math.pi * math.sqrt(m / k) / 40
        y = np.array([0.0, 0.0, 1.0, 0.0])
        mode, plastic, fired = 0, 0.0, None
        for t0, t1, a0, a1 in zip(t[:-1], t[1:], a_g[:-1], a_g[1:]):
            slope = (a1 - a0) / (t1 - t0)
            y = np.array([y[0], y[1], 1.0, 0.0])
            s0, length = 0.0, t1 - t0
            while s0 < length:
                B = self._matrix(mode, plastic, a0, slope)
                y_start, s_start = y.copy(), s0

                def at(s, B=B, s_start=s_start, y_start=y_start):
                    return expm(B * (s - s_start)) @ y_start

                found, s = None, s0
                before = self._events(mode, plastic, y)
                if fired in before:  # at its root the event just handled may round to either side of 0
                    before[fired] = max(before[fired], 0.0)
                while s < length and found is None:
                    s_next = min(s + scan, length)
                    y_next = at(s_next)
                    now = self._events(mode, plastic, y_next)
                    for name, g in now.items():
                        if before[name] < 0 <= g:
                            root = brentq(lambda x, name=name, mode=mode, plastic=plastic:
                                          self._events(mode, plastic, at(x))[name], s, s_next, xtol=1e-15, rtol=1e-15)
                            if found is None or root < found[0]:
                                found = (root, name)
                    before, s, y = now, s_next, y_next
                end = length if found is None else found[0]
                self.pieces.append(Piece(t0 + s_start, t0 + end, y_start, B, mode, plastic))
                y = at(end)
                s0 = end
                if found is None:
                    fired = None
                    continue
                fired = found[1]
                if fired == "unload":
                    plastic, mode = y[0] - mode * fy / k, 0
                else:
                    mode = 1 if fired == "yield+" else -1
        self.t_end = float(t[-1])

    def _matrix(self, mode, plastic, a0, slope):
        m, k = self.m, self.k
        B = np.zeros((4, 4))
        B[0, 1] = 1.0
        B[1, 1] = -self.c / m
        if mode == 0:
            B[1, 0], B[1, 2] = -k / m, k * plastic / m - a0
        else:
            B[1, 2] = -mode * self.fy / m - a0
        B[1, 3] = -slope
        B[3, 2] = 1.0
        return B

    def _events(self, mode, plastic, y):
        u, v = y[0], y[1]
        if mode == 0:
            force = self.k * (u - plastic)
            return {"yield+": force - self.fy, "yield-": -self.fy - force}
        return {"unload": -mode * v}

    def state(self, times):
        """(u, v, sigma) at each time in [0, t_end]."""
        times = np.asarray(times, dtype=float)
        starts = np.array([p.t0 for p in self.pieces])
        u, v, sigma = (np.empty_like(times) for _ in range(3))
        for i, t in enumerate(times):
            piece = self.pieces[max(0, int(np.searchsorted(starts, t, side="right")) - 1)]
            y = expm(piece.B * (t - piece.t0)) @ piece.y0
            u[i], v[i] = y[0], y[1]
            sigma[i] = self.k * (y[0] - piece.plastic) if piece.mode == 0 else piece.mode * self.fy
        return u, v, sigma

    def yielded(self) -> int:
        """How many times the spring yielded (an elastic phase, or the start, followed by a yielding one)."""
        modes = [p.mode for p in self.pieces]
        return sum(1 for before, now in zip([0, *modes], modes) if now != 0 and before == 0)
