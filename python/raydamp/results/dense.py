"""Dense output: (q, p) at any time inside a run, from what the step loop kept at every step end.

Between two step ends t0 < t1 (h = t1 - t0, s = (t - t0) / h), q is the cubic Hermite interpolant
on q and its rate v = M^-1 p, and p on p and its rate f = pdot = -grad V - eps D M^-1 p + f(t):

    x(t) = (2s^3 - 3s^2 + 1) x0 + (s^3 - 2s^2 + s) h x0' + (3s^2 - 2s^3) x1 + (s^3 - s^2) h x1'.

With exact end values it is fourth order in h, so it keeps a method's order up to 4 (an order-6 or
order-8 composition's dense output is order 4). The run keeps t, q, p, v and f at every step end:
``8 (n_steps + 1) (1 + 4 n)`` bytes (``raydamp.run.events.dense_bytes``), whatever ``save_every``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["DenseOutput"]


class DenseOutput:
    """Every step end of a run: ``t`` (K,), ``q``, ``p``, ``v`` = M^-1 p, ``f`` = pdot (K, n)."""

    def __init__(self, t: np.ndarray, q: np.ndarray, p: np.ndarray, v: np.ndarray, f: np.ndarray):
        self.t, self.q, self.p, self.v, self.f = t, q, p, v, f

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.t, self.q, self.p, self.v, self.f))

    def at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """(q, p) at time(s) t inside the run: shape (n,) each for a scalar t, (len(t), n) for an array.
        A t outside [t[0], t[-1]] is a ValueError naming it."""
        times = np.asarray(t, dtype=float)
        flat = np.atleast_1d(times)
        if len(self.t) == 0 or not np.all(np.isfinite(flat)) or flat.min() < self.t[0] or flat.max() > self.t[-1]:
            raise ValueError(f"t must lie inside the run [{self.t[0] if len(self.t) else 'nan'}, "
                             f"{self.t[-1] if len(self.t) else 'nan'}], got {t!r}")
        k = np.clip(np.searchsorted(self.t, flat, side="right") - 1, 0, max(len(self.t) - 2, 0))
        if len(self.t) == 1:
            q, p = self.q[k], self.p[k]
        else:
            t0, t1 = self.t[k], self.t[k + 1]
            h = (t1 - t0)[:, None]
            s = ((flat - t0) / (t1 - t0))[:, None]
            s2, s3 = s * s, s * s * s
            w00, w10, w01, w11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, 3 * s2 - 2 * s3, s3 - s2
            q = w00 * self.q[k] + w10 * h * self.v[k] + w01 * self.q[k + 1] + w11 * h * self.v[k + 1]
            p = w00 * self.p[k] + w10 * h * self.f[k] + w01 * self.p[k + 1] + w11 * h * self.f[k + 1]
        if times.ndim == 0:
            return q[0], p[0]
        return q, p

    def __repr__(self) -> str:
        return f"DenseOutput({len(self.t)} step ends, {self.nbytes / 2**20:.1f} MiB)"
