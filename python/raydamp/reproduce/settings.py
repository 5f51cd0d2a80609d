"""Time spans and step sizes of the paper's experiments, full and reduced."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Settings:
    pendulum_t_end: float = 200.0  # paper section 4.3
    elastic_t_end: float = 200.0  # energy plots (paper figure 4)
    orbit_t_end: float = 1000.0  # x-y projections (figure 5): long enough to see Heun drift
    heun_drift_t_end: float = 4000.0  # Heun's outward drift, long enough to tell its shape
    equilibrium_t_end: float = 3000.0  # figure 6: until the distance to the modified RE has converged (~2e-6)
    pendulum_hs: tuple[float, ...] = (0.2, 0.3, 0.4, 0.5)
    elastic_hs: tuple[float, ...] = (0.1, 0.2, 0.3, 0.4)
    equilibrium_hs: tuple[float, ...] = (0.4, 0.2, 0.1, 0.05)
    modified_energy_hs: tuple[float, ...] = (0.2, 0.1, 0.05)
    convergence_hs: tuple[float, ...] = (0.1, 0.05, 0.025, 0.0125)
    convergence_t_end: float = 10.0
    convergence_eps: float = 0.5
    # Theorem 4.3: the grid of the issue-11 check (cheap enough to run in full always)
    rate_t_end: float = 20.0
    rate_eps: tuple[float, ...] = (1e-3, 1e-2, 1e-1)
    rate_hs: tuple[float, ...] = (0.1, 0.05, 0.025)

    @classmethod
    def quick(cls) -> Settings:
        """A reduced run for CI: shorter time spans, same step sizes. The orbits and the
        relative equilibrium keep their spans: their claims are about where a long run
        settles, and they cost about a second."""
        return cls(pendulum_t_end=40.0, elastic_t_end=40.0, heun_drift_t_end=1000.0, convergence_t_end=2.0)


# The paper's initial data.
PENDULUM_EPS = 0.01
PENDULUM_Q0, PENDULUM_P0 = (0.9 * math.pi,), (0.0,)
ELASTIC_Q0, ELASTIC_P0 = (0.0, 1.55884573, -0.6), (1.34164079, 0.0, 0.0)
# Section 6.2's "exact relative equilibrium" data; an equilibrium only for k = 10 (see the report).
EQUILIBRIUM_Q0, EQUILIBRIUM_P0 = (0.0, 1.0392304845413263, -0.6), (1.3416407864998736, 0.0, 0.0)
SPLITTINGS = ("3s", "2s", "rks")
