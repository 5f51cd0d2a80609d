"""Matplotlib figures of the experiments (Agg backend: files only, no display).

Curves that agree to plot resolution (the splittings, one method at several step
sizes) are drawn in layers: the first widest and pale, each next one narrower, dashed
or dotted, on top, so every legend entry stays visible. ``legibility.problems`` checks
each figure before it is saved; what it finds is kept in ``PROBLEMS`` for the report.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from . import legibility  # noqa: E402
from .settings import SPLITTINGS  # noqa: E402

# One colour per method ...
COLORS = {"3s": "tab:blue", "2s": "tab:orange", "rks": "tab:green", "heun": "tab:red", "rksb": "tab:purple",
          "rk4": "tab:brown", "sv": "tab:gray"}
# ... and, where the splittings overlay each other, one layer each: widest at the bottom.
LAYERS = {"3s": {"ls": "-", "lw": 3.0, "alpha": 0.45, "zorder": 2},
          "2s": {"ls": "--", "lw": 1.8, "alpha": 0.9, "zorder": 3},
          "rks": {"ls": ":", "lw": 1.0, "alpha": 1.0, "zorder": 4},
          "heun": {"ls": "-", "lw": 1.0, "alpha": 1.0, "zorder": 1}}
# One line style per tableau (figure 8); None is a method without one.
TABLEAU_STYLES = {None: "-", "heun": "--", "rk4": "-.", "midpoint": ":", "euler": (0, (5, 1, 1, 1, 1, 1))}
MARKERS = {"3s": "o", "2s": "s", "rks": "^", "rksb": "v", "heun": "D", "rk4": "P", "sv": "x"}

# What legibility.problems found in each saved figure (file name -> list of findings).
PROBLEMS: dict[str, list[str]] = {}


def _layer(m: str, scale: float = 1.0) -> dict:
    style = dict(LAYERS[m])
    style["lw"] *= scale
    return {"color": COLORS[m], **style}


def _save(fig, out: Path, name: str) -> str:
    path = out / name
    fig.tight_layout()
    PROBLEMS[name] = legibility.problems(fig)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return name


def _wrapped(q: np.ndarray) -> np.ndarray:
    """Angles in [-pi, pi), with NaN where the wrap jumps so lines do not cross the plot."""
    wrapped = (q + np.pi) % (2 * np.pi) - np.pi
    wrapped[1:][np.abs(np.diff(wrapped)) > np.pi] = np.nan
    return wrapped


def _log_floor(*arrays, percentile: float = 1.0) -> float:
    """A lower limit for a log axis: a decade below the given percentile of the positive
    data, so an exact zero (at t = 0) or a rare dip does not stretch the axis."""
    data = np.concatenate([np.asarray(a, dtype=float).ravel() for a in arrays])
    data = data[np.isfinite(data) & (data > 0)]
    return 10.0 ** np.floor(np.log10(np.percentile(data, percentile)))


def phase(r: dict, out: Path) -> list[str]:
    names = []
    for methods, tag, title in ((SPLITTINGS, "splittings", "3S, 2S, RKS (overlaid)"), (("heun",), "heun", "Heun")):
        fig, axes = plt.subplots(2, 2, figsize=(9, 8), sharex=True, sharey=True)
        for ax, h in zip(axes.flat, sorted({h for _, h in r["runs"]})):
            for m in methods:
                sol = r["runs"][m, h]
                ax.plot(_wrapped(sol.q[:, 0]), sol.p[:, 0], label=m, **_layer(m, 0.5))
            ax.set_title(f"h = {h}")
            ax.set_xlabel("q (mod 2 pi)")
            ax.set_ylabel("p")
            if len(methods) > 1:
                ax.legend(loc="upper right", fontsize=8)
        fig.suptitle(f"Damped pendulum phase diagrams: {title}")
        names.append(_save(fig, out, f"fig1_pendulum_phase_{tag}.png"))
    return names


# Pairwise energy differences (figure 3, lower): the two pairs with 3s agree to plot
# resolution, so the first is the wide pale layer under the second.
ZOOM_T = 30.0
PAIR_STYLES = {"3s-2s": {"color": "tab:purple", "ls": "-", "lw": 3.0, "alpha": 0.45, "zorder": 2},
               "3s-rks": {"color": "tab:cyan", "ls": "--", "lw": 1.2, "alpha": 1.0, "zorder": 3},
               "2s-rks": {"color": "tab:olive", "ls": "-", "lw": 0.8, "alpha": 1.0, "zorder": 4}}


def pendulum_energy(r: dict, out: Path) -> list[str]:
    fig = plt.figure(figsize=(9, 11))
    top, middle, bottom = fig.add_subplot(3, 1, 1), fig.add_subplot(3, 1, 2), fig.add_subplot(3, 1, 3)
    for m, e in r["errors"].items():
        top.plot(r["t"], e, label=m, **_layer(m))
    top.set_ylabel("H_num - H_ref")
    top.set_xlabel("t")
    top.set_title(f"Damped pendulum energy error (h = {r['h']})")
    top.legend()
    # The splittings agree to plot resolution: a stretch of time where the layers show.
    early = r["t"] <= ZOOM_T
    for m in SPLITTINGS:
        middle.plot(r["t"][early], r["errors"][m][early], label=m, **_layer(m))
    middle.set_ylabel("H_num - H_ref")
    middle.set_xlabel("t")
    middle.set_title(f"The splittings' energy error, t in [0, {ZOOM_T:g}] (they agree to plot resolution)")
    low, high = middle.get_ylim()
    middle.set_ylim(low, high + 0.3 * (high - low))  # room for the legend
    middle.legend(loc="upper center", ncol=3)
    t = r["t"][1:]  # the differences are exactly 0 at t = 0: not a point of a log plot
    for name, d in r["differences"].items():
        bottom.semilogy(t, d[1:], label=f"|H({name.replace('-', ') - H(')})|", **PAIR_STYLES[name])
    data = [d[1:] for d in r["differences"].values()]
    bottom.set_ylim(_log_floor(*data), 30 * max(d.max() for d in data))  # room for the legend on top
    bottom.set_ylabel("energy difference")
    bottom.set_xlabel("t")
    bottom.set_title("Energy differences between the methods")
    bottom.legend(loc="upper center", ncol=3, fontsize=9)
    return [_save(fig, out, "fig3_pendulum_energy_error.png")]


def _step_size_styles(hs) -> dict:
    """One layer per step size: the smallest h widest at the bottom."""
    widths = (3.4, 2.2, 1.4, 0.9, 0.6)
    dashes = ("-", "--", "-.", ":", "-")
    colors = plt.get_cmap("Dark2").colors
    return {h: {"color": colors[i % len(colors)], "ls": dashes[i % len(dashes)], "lw": widths[min(i, len(widths) - 1)],
                "alpha": 0.55 if i == 0 else 1.0, "zorder": 2 + i} for i, h in enumerate(sorted(hs))}


def elastic_energy(r: dict, out: Path) -> list[str]:
    fig, axes = plt.subplots(2, 4, figsize=(16, 8), sharex=True)
    for row, eps in zip(axes, (0.01, 0.1)):
        runs = r[eps]["runs"]
        styles = _step_size_styles({h for _, h in runs})
        for ax, m in zip(row, (*SPLITTINGS, "heun")):
            for h, style in styles.items():
                sol = runs[m, h]
                ax.plot(sol.t, sol.energy, label=f"h = {h}", **style)
            ax.set_title(f"{m}, eps = {eps}")
            if m == "heun":
                ax.set_yscale("log")
            ax.set_xlabel("t")
            ax.tick_params(labelbottom=True)  # sharex hides the top row's labels otherwise
            ax.legend(fontsize=7, loc="upper left" if m == "heun" else "lower left")
        row[0].set_ylabel("H")
    fig.suptitle("Elastic pendulum energy (splittings: the h curves agree to plot resolution, drawn in layers)")
    return [_save(fig, out, "fig4_elastic_energy.png")]


def orbits(r: dict, out: Path) -> list[str]:
    fig, axes = plt.subplots(2, 2, figsize=(10, 10))
    panels = ((SPLITTINGS, 0.1, 0.1, "3S, 2S, RKS (h = 0.1, eps = 0.1)"),
              (("heun",), 0.1, 0.1, "Heun (h = 0.1, eps = 0.1)"),
              (SPLITTINGS, 0.01, 0.1, "3S, 2S, RKS (h = 0.1, eps = 0.01)"),
              (SPLITTINGS, 0.01, 0.4, "3S, 2S, RKS (h = 0.4, eps = 0.01)"))
    for ax, (methods, eps, h, title) in zip(axes.flat, panels):
        for m in methods:
            sol = r["runs"][m, eps, h]
            ax.plot(sol.q[:, 0], sol.q[:, 1], label=m, **_layer(m, 0.3))
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        if len(methods) > 1:
            ax.legend(loc="upper right", fontsize=8)
    return [_save(fig, out, "fig5_elastic_xy.png")]


def _circle(radius: float, n: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    phi = np.linspace(0.0, 2 * np.pi, n)
    return radius * np.cos(phi), radius * np.sin(phi)


def equilibrium(r: dict, out: Path) -> list[str]:
    fig, axes = plt.subplots(2, 2, figsize=(13, 11))
    (xy, zoom), (left, right) = axes
    exact, modified = r["exact"], r["modified"]
    # The paper's x-y view: the orbit is a horizontal circle; the exact and the modified
    # relative equilibria are circles 1.6e-3 apart in radius, visible only in a zoom.
    for m in SPLITTINGS:
        sol = r["runs"][m]
        xy.plot(sol.q[:, 0], sol.q[:, 1], label=m, **_layer(m, 0.6))
    xy.set_aspect("equal")
    xy.set_xlabel("x")
    xy.set_ylabel("y")
    # At full scale the circles are the trajectory's own: a pale band underneath.
    xy.plot(*_circle(exact.rho), color="0.8", lw=7.0, zorder=1, label="exact RE")
    xy.set_title(f"x-y trajectories, k = 10, eps = 0.1, h = {r['h']}, t in [0, {r['runs']['3s'].t[-1]:g}]")
    xy.legend(loc="center", fontsize=8)
    # Zoom on the crossing of y = 0 (x > 0). Saved states are drawn as points: at h = 0.1
    # a revolution has ~50 of them, and the chords between them cut inside the circle by
    # ~2e-3, more than the offset shown here. The first revolutions leave the exact
    # circle; the last ones of each method lie on the modified circle.
    period = 2 * np.pi * exact.rho**2 / abs(exact.mu)  # m = 1
    early = r["runs"]["3s"].t <= 3 * period
    zoom.plot(r["runs"]["3s"].q[early, 0], r["runs"]["3s"].q[early, 1], "x", color="k", ms=5, zorder=6,
              label="3s, first 3 revolutions")
    for m, marker, size in (("3s", "o", 11), ("2s", "s", 7), ("rks", "^", 4)):
        sol = r["runs"][m]
        late = sol.t >= sol.t[-1] - 40 * period
        zoom.plot(sol.q[late, 0], sol.q[late, 1], ls="none", marker=marker, ms=size, mfc="none",
                  color=COLORS[m], zorder=3, label=f"{m}, last 40 revolutions")
    zoom.plot(*_circle(exact.rho, 20_000), color="k", ls="--", lw=0.9, zorder=5, label="exact RE")
    zoom.plot(*_circle(modified.rho, 20_000), color="0.75", lw=6.0, zorder=1, label="modified RE (3s)")
    gap = abs(exact.rho - modified.rho)
    zoom.set_xlim(modified.rho - 4 * gap, exact.rho + 2 * gap)
    zoom.set_ylim(-0.1, 0.1)
    zoom.set_xlabel("x")
    zoom.set_ylabel("y")
    zoom.set_title("zoom where the orbit crosses y = 0 (x > 0), saved states")
    zoom.legend(loc="center left", fontsize=8)
    sol = r["runs"]["3s"]
    left.semilogy(sol.t, r["distance_to_exact"], color="k", lw=0.8, label="distance to the exact RE")
    left.semilogy(sol.t, r["distance_to_modified"], color=COLORS["3s"], lw=0.8, label="distance to the modified RE")
    left.set_ylim(bottom=_log_floor(r["distance_to_modified"][1:], percentile=0.1))
    left.set_xlabel("t")
    left.set_ylabel("distance in (rho, z, p_rho, p_z)")
    left.set_title(f"3S from the exact relative equilibrium (h = {r['h']})")
    left.legend()
    for m, offsets in r["offsets"].items():
        style = _layer(m)
        right.loglog(r["hs"], offsets, marker=MARKERS[m], ms=4 + 3 * (m == "3s"),
                     label=f"{m} (order {r['offset_order'][m]:.2f})", **style)
    right.loglog(r["hs"], r["offsets"]["3s"][-1] * (r["hs"] / r["hs"][-1]) ** 2, "k:", lw=0.8, label="h^2")
    right.set_xlabel("h")
    right.set_ylabel("|modified RE - exact RE|")
    right.set_title("Offset of the modified relative equilibrium")
    right.legend()
    return [_save(fig, out, "fig6_relative_equilibrium.png")]


def modified_energy(r: dict, out: Path) -> list[str]:
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.5))
    sol, hmod = r["sv_run"]
    axes[0].plot(sol.t, sol.energy - sol.energy[0], lw=0.6, label="H - H(0)")
    axes[0].plot(sol.t, hmod - hmod[0], lw=0.8, label="H_mod - H_mod(0)")
    axes[0].set_title(f"sv, damped pendulum at eps = 0 (h = {sol.h})")
    axes[0].set_xlabel("t")
    axes[0].legend()
    for name, color in zip(r["H_range"], ("tab:blue", "tab:orange")):
        axes[1].loglog(r["hs"], r["H_range"][name], "o-", color=color, label=f"H, {name}")
        axes[1].loglog(r["hs"], r["Hmod_range"][name], "s--", color=color, label=f"H_mod, {name}")
    axes[1].set_xlabel("h")
    axes[1].set_ylabel("range over t in [0, 100]")
    axes[1].set_title("H oscillates at O(h^2), H_mod at O(h^4)")
    axes[1].legend(fontsize=7)
    sol, hmod, h = r["decay_run"]
    axes[2].plot(sol.t[1:], np.diff(sol.energy), lw=0.5, label=f"H (rises at {r['H_rises']} steps)")
    axes[2].plot(sol.t[1:], np.diff(hmod), lw=0.8, label=f"H_mod (rises at {r['Hmod_rises']} steps)")
    axes[2].axhline(0.0, color="k", lw=0.5)
    axes[2].set_title(f"Change per step, 3s, elastic pendulum, eps = 0.01, h = {h}")
    axes[2].set_xlabel("t")
    axes[2].legend(fontsize=8)
    return [_save(fig, out, "fig7_modified_energy.png")]


GROUP_WIDTHS = (4.0, 2.4, 1.4, 0.8, 0.5)
GROUP_MARKERS = (12.0, 9.0, 6.5, 4.5, 3.0)


def orders(r: dict, out: Path) -> list[str]:
    fig, axes = plt.subplots(1, 2, figsize=(14, 6))
    for ax, (name, cases) in zip(axes, r.items()):
        # Methods whose errors agree to plot resolution (2s, rks/rk4, rks/midpoint, ...)
        # form a group, drawn in layers: widest and with the largest markers first.
        ranked = sorted(cases.items(), key=lambda item: item[1].errors[-1])
        groups: list[list] = []
        for case, res in ranked:
            if groups and np.abs(np.log(res.errors / groups[-1][0][1].errors)).max() < 0.2:
                groups[-1].append((case, res))
            else:
                groups.append([(case, res)])
        handles = {}
        for group in groups:
            for i, ((m, tab), res) in enumerate(group):
                label = m if tab in (None, m) else f"{m}/{tab}"
                alone = len(group) == 1
                (handles[m, tab],) = ax.loglog(
                    res.hs, res.errors, color=COLORS[m], ls=TABLEAU_STYLES[None if tab in (None, m) else tab],
                    lw=1.5 if alone else GROUP_WIDTHS[min(i, len(GROUP_WIDTHS) - 1)],
                    alpha=0.5 if i == 0 and not alone else 1.0, marker=MARKERS[m],
                    ms=6.0 if alone else GROUP_MARKERS[min(i, len(GROUP_MARKERS) - 1)], mfc="none", zorder=2 + i,
                    label=f"{label} ({res.order:.2f})")
        ordered = [handles[case] for case in cases]  # the legend in catalogue order
        ax.legend(handles=ordered, fontsize=7, ncol=2, title="colour: method; line: tableau", title_fontsize=7)
        ax.set_xlabel("h")
        ax.set_ylabel("global error at t_end")
        ax.set_title(f"Convergence, {name} (eps = 0.5)")
    return [_save(fig, out, "fig8_convergence.png")]
