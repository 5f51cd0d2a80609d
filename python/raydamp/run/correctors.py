"""Symplectic correctors for interacting planets without drag (``raydamp.integrate(..., corrector=k)``).

The leapfrog over the Kepler split (sv; 2s and 3s without drag: drift h/2, interaction kick h, drift h/2) is,
to first order in the planets' mass ratio eps, the exact flow seen through a map C that depends on h
(Wisdom, Holman & Touma 1996). Started from C^{-1}(z0) and read through C at every saved row, its error
linear in eps falls from O(eps h^2) to O(eps h^k), leaving the O(eps^2 h^2) part: about 1/eps smaller for
planets of mass ratio 1e-3, and the stepping costs nothing more (C runs once at the start and once per
saved row, 3 k/2 - 3 Kepler drifts and k - 2 kicks each). ``corrector`` is that k: 4, 6, 8 or 10
(methods/corrector.hpp builds each from exact flows and checks its coefficients).

It applies only where the step is that leapfrog and the split near-integrable: a ``raydamp.Planets`` with no
drag (a damping flow adds terms C does not remove), method sv, 2s or 3s without a composition, no load, no
temperature, and whole steps of h (a shortened last step is another leapfrog, with another C). The saved
rows, the energy and the angular momentum are of the corrected states; the rows between the saves, the
events, dense output and envelopes would see the uncorrected ones, and are refused with it, as are sweeps
(their members run through integrate_ensemble, which has no corrector).
"""

from __future__ import annotations

import numpy as np

CORRECTOR_ORDERS = (4, 6, 8, 10)
_LEAPFROGS = ("sv", "2s", "3s")


def check(model, corrector, *, method, composition, load, temperature, save_dofs, events, dense, envelope,
          collapse, h: float, h_last: float) -> int:
    """``corrector`` checked against the run it corrects; a ValueError naming ``corrector`` otherwise."""
    from ..systems.planets import Planets

    if isinstance(corrector, bool) or corrector not in CORRECTOR_ORDERS:
        raise ValueError(f"corrector: must be one of {', '.join(map(str, CORRECTOR_ORDERS))} or None, "
                         f"got {corrector!r}")
    if not isinstance(model, Planets):
        raise ValueError("corrector: applies to raydamp.Planets (interacting planets split as Kepler drift plus "
                         f"interaction kick), not to {type(model).__name__}")
    if model._core_model.eps != 0:
        raise ValueError("corrector: applies without drag (the damping flow adds error terms the corrector does "
                         "not remove); this Planets has eps > 0")
    if method not in _LEAPFROGS or composition is not None:
        raise ValueError(f"corrector: applies to the leapfrog (method sv, 2s or 3s, no composition), got method "
                         f"{method!r}" + (f" with composition {composition!r}" if composition is not None else ""))
    for name, value in (("load", load), ("temperature", temperature or None), ("save_dofs", save_dofs),
                        ("events", events), ("envelope", envelope), ("collapse", collapse)):
        if value is not None:
            raise ValueError(f"corrector: not with {name} (the corrected states are the saved rows alone)")
    if dense:
        raise ValueError("corrector: not with dense=True (dense output would be of the uncorrected states)")
    if h_last != h:
        # the last step's leapfrog is conjugate by the corrector of h_last, not of h: its row would fall back to
        # the O(eps h^2) error
        raise ValueError(f"corrector: t_end must be a whole number of steps of h (the last step would be "
                         f"{h_last!r}, read through the corrector of h = {h!r}); give n_steps, or t_end = n h")
    return int(corrector)


def start(model, corrector: int, h: float, q0: np.ndarray, p0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """C^{-1}(q0, p0): where the leapfrog starts."""
    out = model._core_model.correct(q0.reshape(1, -1), p0.reshape(1, -1), h, corrector, True)
    return out["q"][0], out["p"][0]


def rows(model, corrector: int, h: float, out: dict) -> None:
    """The run's saved rows through C, with their energy and angular momentum, in place in ``out``."""
    if len(out["t"]) == 0:
        return
    fixed = model._core_model.correct(out["q"], out["p"], h, corrector, False)
    for key in ("q", "p", "energy", "momentum"):
        out[key] = fixed[key]
