"""Reproduce the paper's numerical experiments: figures and a claims report.

``raydamp reproduce --out DIR`` (or ``python -m raydamp reproduce``) runs everything.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path

from . import experiments
from .claims import Claim, evaluate
from .settings import Settings

__all__ = ["run", "Settings", "Claim", "evaluate"]

# (result key, experiment, figure function name)
STAGES: tuple[tuple[str, Callable, str | None], ...] = (
    ("phase", experiments.pendulum_phase, "phase"),
    ("energy", experiments.pendulum_energy, "pendulum_energy"),
    ("elastic", experiments.elastic_energy, "elastic_energy"),
    ("orbits", experiments.elastic_orbits, "orbits"),
    ("momentum", experiments.momentum, None),
    ("equilibrium", experiments.equilibrium, "equilibrium"),
    ("modified", experiments.modified_energy_study, "modified_energy"),
    ("orders", experiments.orders, "orders"),
    ("undamped", experiments.undamped_equivalence, None),
    ("conjugacy", experiments.conjugacy, None),
    ("invariance", experiments.coordinate_invariance, None),
    ("rate", experiments.dissipation_rate, None),
)


class _ProgressBar:
    def __init__(self, total: int, stream=sys.stderr, width: int = 30):
        self.total, self.stream, self.width, self.done = total, stream, width, 0

    def step(self, label: str) -> None:
        filled = self.width * self.done // self.total
        self.stream.write(f"\r[{'#' * filled}{'.' * (self.width - filled)}] {self.done}/{self.total} {label:<24}")
        self.stream.flush()
        self.done += 1

    def close(self) -> None:
        self.stream.write(f"\r[{'#' * self.width}] {self.total}/{self.total} done{' ' * 24}\n")
        self.stream.flush()


def run(out: str | Path, *, quick: bool = False, progress: bool = True) -> list[Claim]:
    """Run every experiment, write the figures and REPORT.md into ``out``, return the claims."""
    from . import figures, report

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    settings = Settings.quick() if quick else Settings()
    bar = _ProgressBar(len(STAGES)) if progress else None
    results, figure_files, timings = {}, {}, {}
    start = time.perf_counter()
    for key, experiment, figure in STAGES:
        if bar:
            bar.step(key)
        t0 = time.perf_counter()
        results[key] = experiment(settings)
        if figure:
            figure_files[key] = getattr(figures, figure)(results[key], out)
        timings[key] = time.perf_counter() - t0
    if bar:
        bar.close()
    claims = evaluate(results)
    legible = {name: figures.PROBLEMS.get(name, []) for names in figure_files.values() for name in names}
    report.write(out / "REPORT.md", claims, figure_files, settings, quick=quick, timings=timings,
                 total=time.perf_counter() - start, legibility=legible)
    return claims
