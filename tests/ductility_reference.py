"""An event-driven exact solution of an elastic-perfectly-plastic SDOF under a piecewise-linear ground
acceleration, independent of raydamp: the reference of tests/test_ductility_spectrum.py.

    u'' + 2 zeta omega u' + sigma(u) = -a_g(t),   k = omega^2 (unit mass), |sigma| <= fy.

On each record interval [t_k, t_k+1] a_g = a_k + g_k s (s = t - t_k), and within a phase (elastic: sigma =
k (u - u_p); yielding: sigma = +-fy) the equation is linear: with y = (u, v, 1, s), y' = B y and
y(s) = expm(B s) y(0) exactly. Events, found by a scan (a 40th of a period) and brentq on the exact solution:
|u - u_p| reaching u_y (yield), v reaching 0 (a turning point: unloading where yielding, an extremum of u
always).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq


def expm(A):
    """exp(A) of a small matrix by scaling and squaring of its Taylor series (to 20 terms after scaling to norm
    below 1/2: truncation below 1e-25): scipy.linalg.expm's Pade code cost milliseconds per 4 x 4 call here."""
    norm = np.max(np.sum(np.abs(A), axis=1))
    squarings = max(0, math.ceil(math.log2(norm)) + 1) if norm > 0 else 0
    X = A / 2.0 ** squarings
    term = np.eye(A.shape[0])
    out = term.copy()
    for k in range(1, 21):
        term = term @ X / k
        out = out + term
    for _ in range(squarings):
        out = out @ out
    return out


def peak_ductility(t, a_g, period, zeta, fy):
    """u_m / u_y, u_m the largest |u| at a turning point within the record, or at the first one after it."""
    omega = 2 * np.pi / period
    k, c = omega ** 2, 2 * zeta * omega
    uy = fy / k
    scan = period / 40

    def matrix(mode, up, a0, slope):
        B = np.zeros((4, 4))
        B[0, 1] = 1.0
        B[1, 1] = -c
        if mode == 0:
            B[1, 0], B[1, 2] = -k, k * up - a0
        else:
            B[1, 2] = -mode * fy - a0
        B[1, 3] = -slope
        B[3, 2] = 1.0
        return B

    def events(mode, up, y):
        u, v = y[0], y[1]
        out = {"turn+": -v, "turn-": v}  # v falling through 0 (a maximum), rising (a minimum)
        if mode == 0:
            out["yield+"] = (u - up) - uy
            out["yield-"] = -uy - (u - up)
        return out

    y = np.array([0.0, 0.0, 1.0, 0.0])
    mode, up, peak, after = 0, 0.0, 0.0, None
    fired = None  # the event just handled: at its root, its g may round to either side of 0
    t_rec = t[-1]
    edges = list(zip(t[:-1], t[1:], a_g[:-1], a_g[1:]))
    # after the record: free vibration (a_g = 0) for up to 3 periods, for the first turning point after it
    edges.append((t_rec, t_rec + 3 * period, 0.0, 0.0))
    for t0, t1, a0, a1 in edges:
        slope = (a1 - a0) / (t1 - t0)
        y = np.array([y[0], y[1], 1.0, 0.0])
        s0, length = 0.0, t1 - t0
        while s0 < length:
            B = matrix(mode, up, a0, slope)
            y_start, s_start = y.copy(), s0

            def at(s, B=B, s_start=s_start, y_start=y_start):
                return expm(B * (s - s_start)) @ y_start

            found = None
            before, s = events(mode, up, y), s0
            if fired in before:
                before[fired] = max(before[fired], 0.0)
            while s < length and found is None:
                s_next = min(s + scan, length)
                y_next = at(s_next)
                now = events(mode, up, y_next)
                for name, g in now.items():
                    if before[name] < 0 <= g:
                        root = brentq(lambda x, name=name, mode=mode, up=up: events(mode, up, at(x))[name], s, s_next,
                                      xtol=1e-15, rtol=1e-15)
                        if found is None or root < found[0]:
                            found = (root, name)
                before, s, y = now, s_next, y_next
            if found is None:
                s0 = length
                continue
            s0, name = found
            fired = name
            y = at(s0)
            time = t0 + s0
            if name.startswith("turn"):
                if time <= t_rec:
                    peak = max(peak, abs(y[0]))
                elif after is None:
                    after = abs(y[0])
                    return max(peak, after) / uy
                if mode != 0 and ((mode > 0 and name == "turn+") or (mode < 0 and name == "turn-")):
                    up, mode = y[0] - mode * uy, 0  # unloading
            else:
                mode = 1 if name == "yield+" else -1
    return max(peak, abs(y[0])) / uy
