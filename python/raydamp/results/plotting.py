"""Plots of a Solution (matplotlib): ``sol.plot.energy()``, ``.phase()``, ``.projection()``.

Each returns the matplotlib Axes it drew on (a new figure's unless ``ax`` is given), so plots
compose: ``ax = a.plot.energy(); b.plot.energy(ax=ax)`` overlays two runs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .solution import Solution

__all__ = ["SolutionPlots"]


def _axes(ax):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    return ax


def _label(sol: Solution, label: str | None) -> str:
    if label is not None:
        return label
    return sol.method + (f" ({sol.tableau})" if sol.tableau else "") + f", h = {sol.h:g}"


class SolutionPlots:
    """The plots of one solution."""

    def __init__(self, solution: Solution):
        self._sol = solution

    def _coordinate(self, coordinate) -> int:
        names = self._sol.coordinates
        if isinstance(coordinate, str):
            if coordinate not in names:
                raise ValueError(f"coordinate: unknown coordinate {coordinate!r} (known: {', '.join(names)})")
            return names.index(coordinate)
        if isinstance(coordinate, (int, np.integer)) and not isinstance(coordinate, bool) \
                and 0 <= coordinate < len(names):
            return int(coordinate)
        raise ValueError(f"coordinate: a name ({', '.join(names)}) or an index below {len(names)}, got {coordinate!r}")

    def energy(self, *, ax=None, balance: bool | None = None, label: str | None = None):
        """H(t); with ``balance`` (default: when the run recorded the work) also H - H0 + W."""
        sol = self._sol
        ax = _axes(ax)
        ax.plot(sol.t, sol.energy, label=f"H, {_label(sol, label)}")
        if balance is None:
            balance = sol.work is not None
        if balance:
            ax.plot(sol.t, sol.energy_balance, linestyle="--", label=f"H - H0 + W, {_label(sol, label)}")
        ax.set_xlabel("t")
        ax.set_ylabel("energy")
        ax.set_title("energy")
        ax.legend()
        return ax

    def phase(self, coordinate=0, *, ax=None, label: str | None = None):
        """The phase portrait (q_i, p_i) of one coordinate (a name or an index)."""
        sol = self._sol
        i = self._coordinate(coordinate)
        ax = _axes(ax)
        ax.plot(sol.q[:, i], sol.p[:, i], linewidth=0.8, label=_label(sol, label))
        name = sol.coordinates[i]
        ax.set_xlabel(name)
        ax.set_ylabel(f"p_{name}")
        ax.set_title(f"phase portrait of {name}")
        ax.legend()
        return ax

    def projection(self, x=0, y=1, *, ax=None, label: str | None = None):
        """The path in the plane of two coordinates (names or indices), for 2-D and 3-D systems."""
        sol = self._sol
        if sol.q.shape[1] < 2:
            raise ValueError("projection: needs a system of at least two coordinates; use phase() for one")
        i, j = self._coordinate(x), self._coordinate(y)
        ax = _axes(ax)
        ax.plot(sol.q[:, i], sol.q[:, j], linewidth=0.8, label=_label(sol, label))
        ax.set_xlabel(sol.coordinates[i])
        ax.set_ylabel(sol.coordinates[j])
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{sol.coordinates[i]}-{sol.coordinates[j]} projection")
        ax.legend()
        return ax
