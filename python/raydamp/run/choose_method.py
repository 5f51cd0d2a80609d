"""The method integrate runs when the caller names none (``method=None``), and why.

"3s" for every model, except a :class:`raydamp.LinearStructure` on which 3s would be a trap:

- h omega_max >= 2, omega_max^2 <= ``spectral_bound``: every explicit method (3s, 2s, rks: all are
  Stormer-Verlet in their drift and kick) is unstable, and "midpoint" (the implicit midpoint rule on the
  whole system; order 2 like 3s, A-stable, one sparse solve per step) runs instead. Its error at equal h
  is about twice 3s's (phase error (h omega)^2/12 against Stormer-Verlet's /24; measured 0.145 against
  0.072 in ``raydamp.advise``'s error model).
- otherwise, 3s's beta K damping flow over h is a Chebyshev series of degree d (about
  sqrt(35 h beta L) + 10: one product with K, and for a consistent M one solve with M, per degree).
  From ``DEGREE_LIMIT[mass kind]`` on, "rks" with ``tableau="midpoint"`` runs instead: the same
  Stormer-Verlet drift and kick, so the same stability limit and, measured, the same error at equal h
  (error constant 0.0785 against 3s's 0.0789 on a shear building), but the damping by one sparse solve
  per step with M + (h/2) C, factorised once per run, whatever h rho.

The limits are measured per step (``benchmarks/bench_choose_method.py``; on this 2-core machine):
3s costs about 1.6 + 1.0 to 1.5 d ns per nonzero of K per step with a lumped M, and 4 to 9 d with a
consistent M; rks-midpoint 6 to 11 ns per nonzero of K (one LDL^T solve), midpoint 4 to 7. So 3s
costs at least 1.4 times rks-midpoint's step from d = 12 (lumped: a chain of 200 to 20,000
storeys, a plate of 5,040 to 50,624 DOF) and from d = 4 with a consistent M (a beam, a plate: 3s
already 12 to 22 times rks-midpoint's step at d = 11 to 18).

A caller who names a method, a tableau or a composition gets exactly that (a tableau or a composition
with no method keeps 3s as their base, as before ``method=None`` existed).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from ..systems.series import ChebyshevDegreeError

__all__ = ["DEFAULT_METHOD", "DEGREE_LIMIT", "Choice", "choose_method"]

DEFAULT_METHOD = "3s"
# The Chebyshev degree of 3s's damping flow over one step from which rks-midpoint runs instead.
DEGREE_LIMIT = {"lumped": 12, "consistent": 4}


class Choice(NamedTuple):
    """The method integrate runs, its tableau (None: the method's own), and why (None: the caller named it)."""

    method: str
    tableau: object
    reason: str | None


def choose_method(model, method: str | None, tableau, composition, h: float, thermal: bool = False) -> Choice:
    """What integrate runs for ``method`` (None: choose) with this tableau and composition at step ``h``;
    thermal: at a temperature, where only the splittings with exact noise flows (3s, 2s, baoab) run."""
    if method is not None:
        return Choice(method, tableau, None)
    if tableau is not None or composition is not None:
        return Choice(DEFAULT_METHOD, tableau, "3s: the default, as the base of the tableau or composition given")
    from ..systems.structure import LinearStructure

    if not isinstance(model, LinearStructure) or getattr(model, "springs", ()):  # midpoint runs linear ones only
        return Choice(DEFAULT_METHOD, None, f"3s: the default for a {type(model).__name__}"
                                            f"{' at a temperature' if thermal else ''}")
    try:
        h = float(h)
    except (TypeError, ValueError):
        h = math.nan
    if not (math.isfinite(h) and h > 0):
        return Choice(DEFAULT_METHOD, None, "3s: the default (h is checked next)")
    omega_max = math.sqrt(model.spectral_bound)
    if thermal:
        # Every method with exact noise flows is explicit: past their stability limit none can run (3s ran and
        # blew up, as if the caller had named it). spectral_bound is an upper bound of omega_max^2 (by up to
        # about 12%): an h just below 2 / omega_max may run, named.
        if h * omega_max >= 2.0:
            raise ValueError(f"h: h omega_max may reach h sqrt(spectral_bound) = {h * omega_max:.4g} >= 2 "
                             f"(spectral_bound = {model.spectral_bound:.6g} >= omega_max^2): at a temperature the "
                             "methods that run (3s, 2s, baoab, with exact noise flows) are explicit and unstable "
                             f"there; take h < {2 / omega_max:.6g}, or name the method to run at this h")
        return Choice(DEFAULT_METHOD, None, f"3s: the default at a temperature (OABAO, exact noise flows); h omega_max "
                                            f"= {h * omega_max:.4g} < 2")
    if h * omega_max >= 2.0:
        return Choice("midpoint", None, f"midpoint: h omega_max = {h * omega_max:.4g} >= 2 (omega_max^2 <= "
                                        f"spectral_bound = {model.spectral_bound:.6g}), beyond the stability limit "
                                        "of 3s and every explicit method; midpoint is A-stable, order 2")
    try:
        degree = max(model.chebyshev_degrees(h))
    except ChebyshevDegreeError:  # a flow past the series' degree bound: 3s cannot run at this h, rks-midpoint can
        degree = math.inf
    limit = DEGREE_LIMIT[model.mass_kind]
    if degree >= limit:
        return Choice("rks", "midpoint", f"rks with tableau midpoint: 3s's beta K damping flow over h would be a "
                                         f"Chebyshev series of degree {degree if degree < math.inf else 'above 8192'} "
                                         f"(h rho = {h * model.damping_rate_bound:.4g}; from {limit} on, "
                                         f"with a {model.mass_kind} "
                                         "M, it costs more per step than rks-midpoint's one sparse solve, at the "
                                         "same stability limit and error)")
    return Choice(DEFAULT_METHOD, None, f"3s: h omega_max = {h * omega_max:.4g} < 2 and its damping flow's "
                                        f"Chebyshev degree {degree} < {limit}")
