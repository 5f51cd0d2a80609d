"""Holonomic constraints g(q) = 0 of a System: their compiled functions, and the checks of an initial
state against them.

Each constraint is an expression in the coordinates and parameters, parsed by raydamp's own parser
(spec.py) and turned into SymEngine from our tree. The step loop (cpp/include/raydamp/constraints/) calls
two compiled functions: q -> (g_1..g_k, s_1..s_k), each constraint and its scale, and q -> the
structural non-zeros of the Jacobian G = dg/dq, row by row, whose pattern is fixed here once; a third,
(q, v) -> (v^T Hess g_i(q) v)_i, gives the multipliers after a run (``Solution.multipliers``).

The scale s_i is the sum of the absolute values of g_i's top-level terms: for a rod written
``x^2 + y^2 - l^2`` it is x^2 + y^2 + l^2, about 2 l^2, so the tolerance |g_i| <= tol s_i is
|r - l| <= tol l, a tolerance relative to the rod's length (OpenMM's convention for bonds).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import symengine as se

from .errors import SpecError

__all__ = ["constraint_functions", "ConstraintChecks"]


def _terms(expr: se.Basic) -> list[se.Basic]:
    return list(expr.args) if isinstance(expr, se.Add) else [expr]


def constraint_functions(spec, symbols: dict[str, se.Basic], q: list[se.Symbol], v: list[se.Symbol]):
    """(values, nonzeros, curvatures, (rows, cols)): the 2k expressions g then s, G's non-zero entries row by
    row, each constraint's v^T Hess g_i v (in q and v), and where each non-zero sits in the k x n matrix G."""
    values, scales, nonzeros, curvatures, rows, cols = [], [], [], [], [], []
    for i, constraint in enumerate(spec.constraints):
        g = constraint.to_symengine(symbols)
        values.append(g)
        scales.append(sum((se.Abs(t) for t in _terms(g)), se.Integer(0)))
        found = False
        rate = se.Integer(0)  # dg/dt along v: G_i v
        for j, qj in enumerate(q):
            d = se.diff(g, qj)
            if d != 0:
                nonzeros.append(d)
                rows.append(i)
                cols.append(j)
                rate += d * v[j]
                found = True
        # v^T Hess g_i v = d(G_i v)/dq . v, over the coordinates g_i depends on.
        curvatures.append(sum((se.diff(rate, q[j]) * v[j] for j, r in zip(cols, rows) if r == i), se.Integer(0)))
        if not found:
            raise SpecError(("constraints", i), f"{constraint.text!r} does not depend on the coordinates "
                                                "(its gradient is zero)")
    return values + scales, nonzeros, curvatures, (tuple(rows), tuple(cols))


class ConstraintChecks:
    """The constraints at an initial state, in Python (once per run, not in the step loop)."""

    def __init__(self, spec, compiled, inverse_mass: np.ndarray):
        self.spec = spec
        self.k = len(spec.constraints)
        self.n = spec.n
        self._values = compiled.constraint_values
        self._jacobian = compiled.constraint_jacobian
        self._rows = np.asarray(compiled.constraint_pattern[0], dtype=np.intp)
        self._cols = np.asarray(compiled.constraint_pattern[1], dtype=np.intp)
        self._inverse = inverse_mass

    def values(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        out = np.asarray(self._values(np.ascontiguousarray(q, dtype=float)), dtype=float).reshape(-1)
        return out[:self.k], out[self.k:]

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        entries = np.asarray(self._jacobian(np.ascontiguousarray(q, dtype=float)), dtype=float).reshape(-1)
        G = np.zeros((self.k, self.n))
        G[self._rows, self._cols] = entries
        return G

    def _text(self, i: int) -> str:
        return self.spec.constraints[i].text

    def _normal_matrix(self, name: str, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        G = self.jacobian(q)
        if not np.isfinite(G).all():
            i = int(np.argmax(~np.isfinite(G).all(axis=1)))
            raise SpecError(("constraints", i), f"the gradient of {self._text(i)!r} is not finite at {name} = "
                                                f"{q.tolist()}")
        S = G @ self._inverse @ G.T
        scale = max(float(np.abs(np.diag(S)).max()), np.finfo(float).tiny)
        if np.linalg.cond(S) * np.finfo(float).eps > 1e-4 or not np.abs(np.diag(S)).min() > 1e-14 * scale:
            raise ValueError(f"{name}: the constraints' gradients are dependent there (G M^-1 G^T is singular, "
                             f"condition number {np.linalg.cond(S):.3g}): each constraint must remove its own "
                             "direction of motion")
        return G, S

    def check_configuration(self, name: str, q: np.ndarray) -> np.ndarray:
        """q on g = 0 (to the tolerance), or projected onto it when project_initial; refuses naming the worst
        constraint and its residual."""
        g, s = self.values(q)
        if not (np.isfinite(g).all() and np.isfinite(s).all()):
            i = int(np.argmax(~np.isfinite(g)))
            raise SpecError(("constraints", i), f"{self._text(i)!r} is not finite at {name} = {q.tolist()}")
        self._normal_matrix(name, q)
        if self._satisfied(g, s):
            return q
        if not self.spec.project_initial:
            i = int(np.argmax(np.abs(g) / np.maximum(s, np.finfo(float).tiny)))
            raise ValueError(f"{name}: does not satisfy constraints[{i}] ({self._text(i)!r}): g = {g[i]:.3g}, "
                             f"allowed {self.spec.constraint_tol * s[i]:.3g} (constraint_tol times its scale "
                             f"{s[i]:.3g}); give a {name} on the constraints, or project_initial=True to move it "
                             "onto them")
        return self._project(name, q)

    def _satisfied(self, g: np.ndarray, s: np.ndarray) -> bool:
        return bool((np.abs(g) <= self.spec.constraint_tol * s).all())

    def _project(self, name: str, q: np.ndarray) -> np.ndarray:
        # The M-closest point of g = 0 near q: q - M^-1 G^T L, Newton on L with the Jacobian at each iterate.
        x = q.astype(float).copy()
        G0 = self.jacobian(q)
        lam = np.zeros(self.k)
        for _ in range(100):
            g, s = self.values(x)
            if self._satisfied(g, s):
                return x
            J = self.jacobian(x) @ self._inverse @ G0.T
            try:
                step = np.linalg.solve(J, g)
            except np.linalg.LinAlgError:
                break
            lam += step
            x = q - self._inverse @ G0.T @ lam
            if not np.isfinite(x).all():
                break
        raise ValueError(f"{name}: project_initial could not move it onto the constraints (Newton did not converge "
                         "from there); give a closer one")

    def check_momenta(self, name: str, q: np.ndarray, p: np.ndarray) -> np.ndarray:
        """p on the tangent space at q (G M^-1 p = 0, relative to |G_i| |M^-1 p|), or projected there when
        project_initial."""
        G, S = self._normal_matrix("q0", q)
        v = self._inverse @ p
        r = G @ v
        size = np.linalg.norm(G, axis=1) * max(float(np.linalg.norm(v)), np.finfo(float).tiny)
        tol = max(self.spec.constraint_tol, 1e-13)
        if (np.abs(r) <= tol * size).all():
            return p
        if not self.spec.project_initial:
            i = int(np.argmax(np.abs(r) / size))
            raise ValueError(f"{name}: is not tangent to constraints[{i}] ({self._text(i)!r}) at q0: its rate "
                             f"(G M^-1 p)[{i}] = {r[i]:.3g}, allowed {tol * size[i]:.3g}; give a {name} with "
                             "G(q0) M^-1 p0 = 0, or project_initial=True to project it")
        return p - G.T @ np.linalg.solve(S, r)


def describe(spec) -> dict[str, Any]:
    """The constraints' part of the plain form (present only when the system has constraints)."""
    out: dict[str, Any] = {"constraints": [c.text for c in spec.constraints]}
    if spec.constraint_tol != 1e-12:
        out["constraint_tol"] = spec.constraint_tol
    if spec.project_initial:
        out["project_initial"] = True
    return out
