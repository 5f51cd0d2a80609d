"""REPORT.md: the claims table and the figures, embedded by relative path."""

from __future__ import annotations

import platform
from pathlib import Path

from .._core import __version__
from .claims import Claim
from .settings import Settings

CAPTIONS = {
    "phase": "Damped pendulum phase diagrams, q0 = 0.9 pi, p0 = 0, eps = 0.01 (paper figures 1 and 2).",
    "energy": "Energy error against a DOP853 reference (rtol = atol = 1e-13), the splittings' error over the first "
              "30 time units (they agree to plot resolution: 3S widest at the bottom, 2S dashed, RKS dotted on top), "
              "and the pairwise differences from the first step on (figure 3).",
    "elastic": "Elastic pendulum energy for h = 0.1 .. 0.4 (figure 4), the smallest h widest at the bottom; Heun on "
               "a log scale.",
    "orbits": "Elastic pendulum x-y projections (figure 5); 3S, 2S, RKS overlaid, 3S widest at the bottom, RKS on "
              "top: they trace the same band.",
    "equilibrium": "From the paper's relative-equilibrium data (k = 10, eps = 0.1): the x-y view with a zoom where "
                   "the orbit crosses y = 0 (saved states: the first revolutions leave the exact circle, the last "
                   "lie on the modified one), the distance to both equilibria until it has converged, and the "
                   "O(h^2) offset (figure 6).",
    "modified": "The modified Hamiltonian of Stormer-Verlet (truncated after h^2).",
    "orders": "Global error at t_end against h, every method, both models (eps = 0.5): colour per method, line "
              "style per tableau; errors that agree are drawn widest and with the largest markers first.",
}


def write(path: Path, claims: list[Claim], figures: dict[str, list[str]], settings: Settings, *, quick: bool,
          timings: dict[str, float], total: float, legibility: dict[str, list[str]] | None = None) -> None:
    passed = sum(c.passed for c in claims)
    lines = [
        "# Reproduction of Modin & Soderlind, *Geometric integration of Hamiltonian systems perturbed by "
        "Rayleigh damping*",
        "",
        f"raydamp {__version__}, Python {platform.python_version()}, {platform.machine()}; "
        f"{'REDUCED (quick) settings' if quick else 'full settings'}: pendulum t in [0, {settings.pendulum_t_end:g}], "
        f"elastic t in [0, {settings.elastic_t_end:g}], orbits to t = {settings.orbit_t_end:g}; "
        f"ran in {total:.1f} s.",
        "",
        f"**{passed} of {len(claims)} claims hold.** A failed row is a place where the paper and a computation "
        "disagree; its note explains why. Theorem numbers follow the paper's LaTeX source "
        "(Theorem 4.3: dissipation rate; Lemma 4.4: form of the modified Hamiltonian; Theorem 4.6: monotone "
        "decay for 3S; Proposition 5.2: momentum maps; Theorem 6.2: relative equilibria).",
        "",
        "| where | the paper says | measured | criterion | result |",
        "| --- | --- | --- | --- | --- |",
    ]
    for c in claims:
        cells = (c.where, c.claim, c.measured, c.criterion, "PASS" if c.passed else "FAIL")
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    notes = [c for c in claims if c.note]
    if notes:
        lines += ["", "## Discrepancies and notes", ""]
        lines += [f"- **{c.where}** ({'PASS' if c.passed else 'FAIL'}): {c.note}" for c in notes]
    lines += ["", "## Figures", ""]
    if legibility is not None:
        found = [f"{name}: {problem}" for name, problems in legibility.items() for problem in problems]
        lines += ["Legibility check (raydamp.reproduce.legibility: every legend entry has a line in view, no two "
                  "lines share colour, line style and marker, and a line that coincides with another to 1.5 pixels "
                  "shows through: wider underneath, its own markers, or the gaps of a dashed line): "
                  + ("every figure passes." if not found else f"{len(found)} problems:"), ""]
        lines += [f"- {problem}" for problem in found]
        if found:
            lines.append("")
    for key, names in figures.items():
        lines += [f"### {CAPTIONS.get(key, key)}", ""]
        lines += [f"![{name}]({name})" for name in names]
        lines.append("")
    lines += ["## Time per experiment", "", "| experiment | seconds |", "| --- | --- |"]
    lines += [f"| {k} | {v:.2f} |" for k, v in timings.items()]
    path.write_text("\n".join(lines) + "\n")
