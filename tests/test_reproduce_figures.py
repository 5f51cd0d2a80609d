"""Issue 11, points 10-12: every legend entry of every figure is a line a reader can see.

The check (raydamp.reproduce.legibility) first shows it catches what the issue found
in the old figures, then runs on every figure the reproduction draws."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from raydamp.reproduce import figures, legibility  # noqa: E402
from raydamp.reproduce.settings import Settings  # noqa: E402

T = np.linspace(0.0, 10.0, 400)
CURVE = np.sin(T)


def _problems(*lines, legend=True, log=False):
    fig, ax = plt.subplots()
    for y, style in lines:
        ax.plot(T, y, **style)
    if log:
        ax.set_yscale("log")
    if legend:
        ax.legend()
    try:
        return legibility.problems(fig)
    finally:
        plt.close(fig)


def test_identical_curves_in_the_same_style_but_colour_are_caught():
    """The old figure 3: |H(3s) - H(2s)| drawn exactly under |H(3s) - H(rks)|."""
    found = _problems((CURVE, {"color": "tab:cyan", "lw": 0.7, "label": "a"}),
                      (CURVE + 1e-6, {"color": "tab:pink", "lw": 0.7, "label": "b"}))
    assert found == ["axes 0: 'a' is hidden under 'b'"]


def test_layers_make_coinciding_curves_legible():
    wide_under = _problems((CURVE, {"lw": 3.0, "label": "a"}), (CURVE, {"lw": 1.0, "label": "b"}))
    dashed_over = _problems((CURVE, {"lw": 1.0, "label": "a"}), (CURVE, {"lw": 1.0, "ls": "--", "label": "b"}))
    own_markers = _problems((CURVE, {"lw": 1.0, "marker": "o", "markevery": 20, "label": "a"}),
                            (CURVE, {"lw": 1.0, "label": "b"}))
    assert wide_under == dashed_over == own_markers == []


def test_gaps_of_two_dashed_lines_do_not_count():
    found = _problems((CURVE, {"lw": 1.0, "label": "a"}), (CURVE, {"lw": 1.0, "ls": "--", "label": "b"}),
                      (CURVE, {"lw": 1.0, "ls": ":", "label": "c"}))
    assert found == ["axes 0: 'a' shows only in the gaps of 'b', 'c'"]


def test_shared_style_missing_legend_and_out_of_view_are_caught():
    """The old figure 8 (3s and rk4 both blue, solid, 'o'), figure 4's Heun panels (no
    legend), and a log axis whose data are all <= 0."""
    shared = _problems((CURVE, {"color": "C0", "marker": "o", "label": "3s"}),
                       (CURVE + 5, {"color": "C0", "marker": "o", "label": "rk4"}))
    assert shared == ["axes 0: '3s' and 'rk4' share colour, line style and marker"]
    assert _problems((CURVE, {"label": "a"}), (CURVE + 5, {"label": "b"}), legend=False) == [
        "axes 0: 2 labelled lines and no legend"]
    found = _problems((np.exp(T), {"label": "a"}), (-np.exp(T), {"label": "b"}), log=True)
    assert "axes 0: 'b' has no point inside the axes" in found


def test_graphs_sampled_differently_are_compared_along_x():
    """Figure 4: one method at several step sizes, saved at different times."""
    t2 = np.linspace(0.0, 10.0, 97)
    fig, ax = plt.subplots()
    ax.plot(T, np.exp(-T / 5), lw=1.0, label="h = 0.1")
    ax.plot(t2, np.exp(-t2 / 5), lw=1.0, label="h = 0.4")
    ax.legend()
    assert legibility.problems(fig) == ["axes 0: 'h = 0.1' is hidden under 'h = 0.4'"]
    plt.close(fig)


def test_orbits_traced_at_different_phases_are_compared_as_sets():
    phi = np.linspace(0.0, 40 * np.pi, 5000)
    fig, ax = plt.subplots()
    ax.plot(np.cos(phi), np.sin(phi), lw=1.0, label="3s")
    ax.plot(np.cos(phi + 0.3), np.sin(phi + 0.3), lw=1.0, label="2s")
    ax.legend()
    assert legibility.problems(fig) == ["axes 0: '3s' is hidden under '2s'"]
    plt.close(fig)


def test_figure_3_log_axis_starts_where_the_data_is(tmp_path, monkeypatch):
    """Not at the exact zero of t = 0 (which stretched the old axis to 1e-18)."""
    kept = {}
    original = figures._save

    def keep(fig, out, name):
        kept[name] = [ax.get_ylim() for ax in fig.axes]
        return original(fig, out, name)

    monkeypatch.setattr(figures, "_save", keep)
    out = tmp_path
    from raydamp.reproduce import experiments

    figures.pendulum_energy(experiments.pendulum_energy(Settings.quick()), out)
    bottom = kept["fig3_pendulum_energy_error.png"][2][0]
    assert 1e-10 <= bottom <= 1e-7  # measured: 1e-8 (a decade below the 1st percentile)
