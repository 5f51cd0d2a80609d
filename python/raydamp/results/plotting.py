"""Plots of a Solution (matplotlib): ``sol.plot.energy()``, ``.phase()``, ``.projection()``.

Each returns the matplotlib Axes it drew on (a new figure's unless ``ax`` is given), so plots
compose: ``ax = a.plot.energy(); b.plot.energy(ax=ax)`` overlays two runs. ``.png(kind, width=,
height=)`` gives one of them as PNG bytes of that many pixels (what the service's plot route sends):
drawn with matplotlib's object API on a Figure of its own (no pyplot state), so calls on different
threads share no figure.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np

__all__ = ["SolutionPlots", "PLOT_KINDS"]

PLOT_KINDS = ("energy", "phase", "projection")


def _axes(ax):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    return ax


def _label(sol: Any, label: str | None) -> str:
    if label is not None:
        return label
    return sol.method + (f" ({sol.tableau})" if sol.tableau else "") + f", h = {sol.h:g}"


class SolutionPlots:
    """The plots of one solution."""

    def __init__(self, solution: Any):
        self._sol = solution

    def _coordinate(self, coordinate, argument: str = "coordinate") -> int:
        """The column of a coordinate given by name or index; errors name the argument (coordinate, x or y)."""
        names = self._sol.coordinates
        if isinstance(coordinate, str):
            if coordinate not in names:
                raise ValueError(f"{argument}: unknown coordinate {coordinate!r} (known: {', '.join(names)})")
            return names.index(coordinate)
        if isinstance(coordinate, (int, np.integer)) and not isinstance(coordinate, bool) \
                and 0 <= coordinate < len(names):
            return int(coordinate)
        raise ValueError(f"{argument}: a name ({', '.join(names)}) or an index below {len(names)}, got {coordinate!r}")

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
            if sol.dofs is not None:  # the system has more; the run saved one (it said "a system of one")
                raise ValueError(f"projection: the run saved one coordinate ({sol.coordinates[0]}, save_dofs); "
                                 "a projection needs two saved; use phase() for one")
            raise ValueError("projection: needs a system of at least two coordinates; use phase() for one")
        i, j = self._coordinate(x, "x"), self._coordinate(y, "y")
        ax = _axes(ax)
        ax.plot(sol.q[:, i], sol.q[:, j], linewidth=0.8, label=_label(sol, label))
        ax.set_xlabel(sol.coordinates[i])
        ax.set_ylabel(sol.coordinates[j])
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{sol.coordinates[i]}-{sol.coordinates[j]} projection")
        ax.legend()
        return ax

    def png(self, kind: str, *, width: int = 800, height: int = 500, coordinate=None, x=None, y=None) -> bytes:
        """The plot ``kind`` ("energy", "phase" of ``coordinate``, "projection" on ``x``, ``y``; each a name or
        an index, by default the first coordinates) as a PNG of width x height pixels. ValueError names the
        argument (kind, width, height, coordinate, or projection for a system of one coordinate)."""
        if kind not in PLOT_KINDS:
            raise ValueError(f"kind: unknown plot {kind!r} (known: {', '.join(PLOT_KINDS)})")
        for name, pixels in (("width", width), ("height", height)):
            if isinstance(pixels, bool) or not isinstance(pixels, (int, np.integer)) or pixels < 1:
                raise ValueError(f"{name}: a positive number of pixels, got {pixels!r}")
        import matplotlib
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        dpi = 100
        # Agg rasterises a path of 20,000 points whole by default: a 3000 x 3000 phase plot took 551 MB at its
        # peak and 2.0 s; in pieces of 1000 points, 62 MB and 1.6 s (benchmarks/bench_service_plots.py).
        with matplotlib.rc_context({"agg.path.chunksize": 1000}):
            figure = Figure(figsize=(width / dpi, height / dpi), dpi=dpi, layout="constrained")
            FigureCanvasAgg(figure)
            ax = figure.add_subplot()
            if kind == "energy":
                self.energy(ax=ax)
            elif kind == "phase":
                self.phase(coordinate if coordinate is not None else 0, ax=ax)
            else:
                self.projection(x if x is not None else 0, y if y is not None else 1, ax=ax)
            out = io.BytesIO()
            figure.savefig(out, format="png", dpi=dpi)
        return out.getvalue()
