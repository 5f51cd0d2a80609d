"""The kinetic temperature kT_kin = <p^T M^{-1} p> / n of saved momenta (equipartition of the kinetic
energy: <p^T M^{-1} p> = n kT at thermal equilibrium), written once for raydamp.analysis and for the
summary of a run at a temperature."""

from __future__ import annotations

import numpy as np

__all__ = ["kinetic_temperature_of", "summary_kinetic_temperature", "SUMMARY_ROWS"]

# The summary's estimate reads at most this many saved points (one compiled call each, ~2 us for a small
# model): a million saved points would otherwise add seconds to a run that took less. Evenly spaced over
# the second half, they are far apart in time, so the estimate's relative standard error is about
# sqrt(2 / (n x rows)) for n coordinates.
SUMMARY_ROWS = 2000


def kinetic_temperature_of(model, p: np.ndarray) -> float:
    """<p^T M^{-1} p> / n over the rows of p (full momentum vectors of ``model``)."""
    core = model._core_model
    return float(np.mean([2.0 * core.kinetic(row) for row in p]) / model.dim)


def summary_kinetic_temperature(solution) -> float | None:
    """The kinetic temperature over the second half of a run's saved points (the first half is its
    burn-in), at most SUMMARY_ROWS of them evenly spaced; None for a run without noise, or one that saved
    only some coordinates. An ensemble's member or a loaded run reads its temperature and model from its
    provenance (None when the model cannot be rebuilt, as a structure whose uploaded files are not at hand)."""
    origin = solution.origin
    if isinstance(origin, tuple):
        noisy = origin[3].get("thermal") is not None
    else:
        noisy = isinstance(origin, dict) and bool(origin.get("temperature"))
    if not noisy or solution.dofs is not None:
        return None
    try:
        model = solution._model("kinetic_temperature")
    except ValueError:
        return None
    t = solution.t
    rows = np.flatnonzero(t >= t[0] + 0.5 * (t[-1] - t[0]))
    if rows.size > SUMMARY_ROWS:
        rows = rows[np.linspace(0, rows.size - 1, SUMMARY_ROWS).round().astype(int)]
    return kinetic_temperature_of(model, solution.p[rows])
