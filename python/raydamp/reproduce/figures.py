"""Matplotlib figures of the experiments (Agg backend: files only, no display)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .settings import SPLITTINGS  # noqa: E402

COLORS = {"3s": "tab:blue", "2s": "tab:orange", "rks": "tab:green", "heun": "tab:red", "rksb": "tab:purple",
          "rk4": "tab:brown", "sv": "tab:gray"}
STYLES = {"3s": "-", "2s": "--", "rks": ":"}


def _save(fig, out: Path, name: str) -> str:
    path = out / name
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return name


def _wrapped(q: np.ndarray) -> np.ndarray:
    """Angles in [-pi, pi), with NaN where the wrap jumps so lines do not cross the plot."""
    wrapped = (q + np.pi) % (2 * np.pi) - np.pi
    wrapped[1:][np.abs(np.diff(wrapped)) > np.pi] = np.nan
    return wrapped


def phase(r: dict, out: Path) -> list[str]:
    names = []
    for methods, tag, title in ((SPLITTINGS, "splittings", "3S, 2S, RKS (overlaid)"), (("heun",), "heun", "Heun")):
        fig, axes = plt.subplots(2, 2, figsize=(9, 8), sharex=True, sharey=True)
        for ax, h in zip(axes.flat, sorted({h for _, h in r["runs"]})):
            for m in methods:
                sol = r["runs"][m, h]
                ax.plot(_wrapped(sol.q[:, 0]), sol.p[:, 0], lw=0.5, ls=STYLES.get(m, "-"), color=COLORS[m], label=m)
            ax.set_title(f"h = {h}")
            ax.set_xlabel("q (mod 2 pi)")
            ax.set_ylabel("p")
        axes.flat[0].legend(loc="upper right")
        fig.suptitle(f"Damped pendulum phase diagrams: {title}")
        names.append(_save(fig, out, f"fig1_pendulum_phase_{tag}.png"))
    return names


def pendulum_energy(r: dict, out: Path) -> list[str]:
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 8), sharex=True)
    for m, e in r["errors"].items():
        top.plot(r["t"], e, lw=0.8, color=COLORS[m], ls=STYLES.get(m, "-"), label=m)
    top.set_ylabel("H_num - H_ref")
    top.set_title(f"Damped pendulum energy error (h = {r['h']})")
    top.legend()
    for (name, d), color in zip(r["differences"].items(), ("tab:cyan", "tab:olive", "tab:pink")):
        bottom.semilogy(r["t"], np.maximum(d, 1e-18), lw=0.7, color=color, label=f"|H({name.replace('-', ') - H(')})|")
    bottom.set_ylabel("energy difference")
    bottom.set_xlabel("t")
    bottom.set_title("Energy differences between the methods")
    bottom.legend()
    return [_save(fig, out, "fig3_pendulum_energy_error.png")]


def elastic_energy(r: dict, out: Path) -> list[str]:
    fig, axes = plt.subplots(2, 4, figsize=(15, 7), sharex=True)
    for row, eps in zip(axes, (0.01, 0.1)):
        runs = r[eps]["runs"]
        for ax, m in zip(row, (*SPLITTINGS, "heun")):
            for h in sorted({h for _, h in runs}):
                sol = runs[m, h]
                ax.plot(sol.t, sol.energy, lw=0.6, label=f"h = {h}")
            ax.set_title(f"{m}, eps = {eps}")
            if m == "heun":
                ax.set_yscale("log")
            ax.set_xlabel("t")
        row[0].set_ylabel("H")
        row[0].legend(fontsize=7)
    fig.suptitle("Elastic pendulum energy")
    return [_save(fig, out, "fig4_elastic_energy.png")]


def orbits(r: dict, out: Path) -> list[str]:
    fig, axes = plt.subplots(2, 2, figsize=(10, 10))
    panels = ((SPLITTINGS, 0.1, 0.1, "3S, 2S, RKS (h = 0.1, eps = 0.1)"), (("heun",), 0.1, 0.1, "Heun (h = 0.1, eps = 0.1)"),
              (SPLITTINGS, 0.01, 0.1, "3S, 2S, RKS (h = 0.1, eps = 0.01)"), (SPLITTINGS, 0.01, 0.4, "3S, 2S, RKS (h = 0.4, eps = 0.01)"))
    for ax, (methods, eps, h, title) in zip(axes.flat, panels):
        for m in methods:
            sol = r["runs"][m, eps, h]
            ax.plot(sol.q[:, 0], sol.q[:, 1], lw=0.3, color=COLORS[m], ls=STYLES.get(m, "-"), label=m)
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
    return [_save(fig, out, "fig5_elastic_xy.png")]


def equilibrium(r: dict, out: Path) -> list[str]:
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 5))
    sol = r["runs"]["3s"]
    left.semilogy(sol.t, np.maximum(r["distance_to_exact"], 1e-18), lw=0.6, label="distance to the exact RE")
    left.semilogy(sol.t, np.maximum(r["distance_to_modified"], 1e-18), lw=0.6, label="distance to the modified RE")
    left.set_ylim(bottom=1e-6)
    left.set_xlabel("t")
    left.set_ylabel("distance in (rho, z, p_rho, p_z)")
    left.set_title(f"3S from the exact relative equilibrium (k = 10, h = {r['h']})")
    left.legend()
    for m, offsets in r["offsets"].items():
        right.loglog(r["hs"], offsets, "o" + STYLES.get(m, "-"), color=COLORS[m], label=f"{m} (order {r['offset_order'][m]:.2f})")
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
    for name in r["H_range"]:
        axes[1].loglog(r["hs"], r["H_range"][name], "o-", label=f"H, {name}")
        axes[1].loglog(r["hs"], r["Hmod_range"][name], "s--", label=f"H_mod, {name}")
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


def orders(r: dict, out: Path) -> list[str]:
    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    for ax, (name, cases) in zip(axes, r.items()):
        for (m, tab), res in cases.items():
            label = m if tab in (None, m) else f"{m}/{tab}"
            ax.loglog(res.hs, res.errors, "o-", ms=3, label=f"{label} ({res.order:.2f})")
        ax.set_xlabel("h")
        ax.set_ylabel("global error at t_end")
        ax.set_title(f"Convergence, {name} (eps = 0.5)")
        ax.legend(fontsize=7)
    return [_save(fig, out, "fig8_convergence.png")]
