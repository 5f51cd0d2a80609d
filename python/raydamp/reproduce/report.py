"""REPORT.md: the claims table and the figures, embedded by relative path."""

from __future__ import annotations

import platform
from pathlib import Path

from .. import __version__
from .claims import Claim
from .settings import Settings

CAPTIONS = {
    "phase": "Damped pendulum phase diagrams, q0 = 0.9 pi, p0 = 0, eps = 0.01 (paper figures 1 and 2).",
    "energy": "Energy error against a DOP853 reference (rtol = atol = 1e-13) and pairwise differences (figure 3).",
    "elastic": "Elastic pendulum energy for h = 0.1 .. 0.4 (figure 4); Heun on a log scale.",
    "orbits": "Elastic pendulum x-y projections (figure 5).",
    "equilibrium": "From the paper's relative-equilibrium data (k = 10, eps = 0.1): drift to the modified relative "
                   "equilibrium, and its O(h^2) offset (figure 6).",
    "modified": "The modified Hamiltonian of Stormer-Verlet (truncated after h^2).",
    "orders": "Global error at t_end against h, every method, both models (eps = 0.5).",
}


def write(path: Path, claims: list[Claim], figures: dict[str, list[str]], settings: Settings, *, quick: bool,
          timings: dict[str, float], total: float) -> None:
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
    for key, names in figures.items():
        lines += [f"### {CAPTIONS.get(key, key)}", ""]
        lines += [f"![{name}]({name})" for name in names]
        lines.append("")
    lines += ["## Time per experiment", "", "| experiment | seconds |", "| --- | --- |"]
    lines += [f"| {k} | {v:.2f} |" for k, v in timings.items()]
    path.write_text("\n".join(lines) + "\n")
