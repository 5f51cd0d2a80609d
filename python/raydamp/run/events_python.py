"""Events whose g is a Python callable: found after the run, on its dense output.

The step loop calls no Python, so a run with ``Event(g=callable)`` keeps dense output (t, q, p, M^-1 p and
pdot at every step end: ``raydamp.run.events.dense_bytes``) and this module finds the crossings on it:
``g(t, q, p)`` is called with every step end at once (t of shape (K,), q and p of shape (K, n)) and must
return K values; where g changes sign between two step ends, the crossing is located on the step's cubic
Hermite interpolant (``Solution.at``) by the root finder the core uses (false position with the Illinois
halving and a bisection every fourth step, to a few roundings of t), all such steps at once, one call of g
per iteration. So a crossing's time has the same order in h as a compiled event's.

What it does not do, and a compiled g (an expression) does: stop the run (``terminal``), refine by Hénon's
step, run in an ensemble, and find a touch or two crossings inside one step (they need dg/dt at the step
ends, which a callable does not give). It is slower too: g runs in Python, over arrays of every step end.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..results.event_table import EventTable

__all__ = ["with_callables", "crossings"]

_EPS = np.finfo(float).eps


def with_callables(table: EventTable, prepared: Any, dense: Any) -> EventTable:
    """``table`` (the compiled events' crossings) with those of every callable event added, in time order."""
    parts = [(table.event, table.direction, table.t, table.q, table.p)]
    for i in prepared.callables:
        event = prepared.events[i]
        t, q, p, direction = crossings(event.g, dense, f"events[{i}].g")
        keep = direction == event.direction if event.direction else np.ones(len(t), dtype=bool)
        parts.append((np.full(int(keep.sum()), i, dtype=np.int64), direction[keep], t[keep], q[keep], p[keep]))
    n = dense.q.shape[1]
    event, direction, t, q, p = (np.concatenate([np.asarray(part[k]).reshape(len(part[2]), *shape)
                                                 for part in parts])
                                 for k, shape in enumerate(((), (), (), (n,), (n,))))
    order = np.lexsort((event, t))  # by time; at one time, in the list's order
    return EventTable(table.names, event[order], direction[order], t[order], q[order], p[order])


def _g(g, t: np.ndarray, q: np.ndarray, p: np.ndarray, field: str) -> np.ndarray:
    values = np.asarray(g(t, q, p), dtype=float)
    if values.shape != t.shape:
        raise ValueError(f"{field}: a callable g(t, q, p) gets t of shape (K,) and q, p of shape (K, n) and must "
                         f"return K values, got shape {values.shape} for K = {t.shape[0]}")
    return values


def _hermite(s: np.ndarray, h: np.ndarray, x0, d0, x1, d1) -> np.ndarray:
    s = s[:, None]
    s2, s3 = s * s, s * s * s
    return ((2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * h[:, None] * d0 + (3 * s2 - 2 * s3) * x1
            + (s3 - s2) * h[:, None] * d1)


def crossings(g, dense, field: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(t, q, p, direction) of every zero of g on the dense output's interpolant where g changes sign
    between step ends; field names g in errors (a wrong shape, a g not finite at the start)."""
    T = np.asarray(dense.t, dtype=float)
    Q, P, V, F = (np.asarray(a, dtype=float) for a in (dense.q, dense.p, dense.v, dense.f))
    n = Q.shape[1]
    empty = (np.zeros(0), np.zeros((0, n)), np.zeros((0, n)), np.zeros(0, dtype=np.int64))
    if T.size < 2:
        return empty
    G = _g(g, T, Q, P, field)
    if not np.isfinite(G[0]):
        raise ValueError(f"{field} is not finite at the initial state")
    ga, gb = G[:-1], G[1:]
    # As the core: a crossing where g leaves a nonzero value and reaches zero or the other sign.
    steps = np.flatnonzero(np.isfinite(ga) & np.isfinite(gb) & (ga != 0.0) & ((gb == 0.0) | ((ga < 0.0) != (gb < 0.0))))
    if steps.size == 0:
        return empty
    t0, t1 = T[steps], T[steps + 1]
    h = t1 - t0
    ends = (Q[steps], V[steps], Q[steps + 1], V[steps + 1]), (P[steps], F[steps], P[steps + 1], F[steps + 1])

    def on_step(rows: np.ndarray, s: np.ndarray) -> np.ndarray:
        q = _hermite(s, h[rows], *(x[rows] for x in ends[0]))
        p = _hermite(s, h[rows], *(x[rows] for x in ends[1]))
        return _g(g, np.where(s == 1.0, t1[rows], t0[rows] + s * h[rows]), q, p, field)

    a, b = np.zeros(steps.size), np.ones(steps.size)
    fa, fb = ga[steps].copy(), gb[steps].copy()
    side = np.zeros(steps.size, dtype=np.int8)
    tol = 4.0 * _EPS * np.maximum(np.abs(t1), h) / h
    done = fb == 0.0  # on the step's end
    for it in range(400):
        rows = np.flatnonzero(~done & (b - a > tol))
        if rows.size == 0:
            break
        ra, rb, rfa, rfb = a[rows], b[rows], fa[rows], fb[rows]
        with np.errstate(divide="ignore", invalid="ignore"):
            m = 0.5 * (ra + rb) if it % 4 == 3 else (ra * rfb - rb * rfa) / (rfb - rfa)
        m = np.where((m > ra) & (m < rb), m, 0.5 * (ra + rb))
        stuck = ~((m > ra) & (m < rb))
        done[rows[stuck]] = True
        rows, m = rows[~stuck], m[~stuck]
        fm = on_step(rows, m)
        hit = fm == 0.0
        a[rows[hit]] = b[rows[hit]] = m[hit]
        fa[rows[hit]] = fb[rows[hit]] = 0.0
        done[rows[hit]] = True
        done[rows[~np.isfinite(fm)]] = True  # the end with the smaller |g| stands
        go = ~hit & np.isfinite(fm)
        rows, m, fm = rows[go], m[go], fm[go]
        low = (fm < 0.0) == (fa[rows] < 0.0)  # the root is above m
        up, down = rows[low], rows[~low]
        fb[up] = np.where(side[up] == -1, 0.5 * fb[up], fb[up])
        a[up], fa[up], side[up] = m[low], fm[low], -1
        fa[down] = np.where(side[down] == 1, 0.5 * fa[down], fa[down])
        b[down], fb[down], side[down] = m[~low], fm[~low], 1
    s = np.where(np.abs(fa) < np.abs(fb), a, b)
    s = np.where(gb[steps] == 0.0, 1.0, s)
    t = np.where(s == 1.0, t1, t0 + s * h)
    q = _hermite(s, h, *ends[0])
    p = _hermite(s, h, *ends[1])
    direction = np.where(ga[steps] < 0.0, 1, -1).astype(np.int64)
    return t, q, p, direction
