"""Diagnostics that show the paper's claims: energy balance, modified energy,
reference solutions (and the exact response of a linear system to a piecewise-linear load),
momentum drift, temperatures, relative equilibria and convergence orders.

Needs SciPy (``pip install raydamp[analysis]``) for the reference solver and root finding.
"""

from .convergence import ConvergenceResult, convergence
from .energy import energy_error, modified_energy, reference_solution
from .linear_response import piecewise_linear_response
from .momentum import momentum_drift
from .relative_equilibrium import (
    RelativeEquilibrium,
    cartesian_state,
    distance_from,
    modified_relative_equilibrium,
    reduced_coordinates,
    reduced_hessian,
    relative_equilibrium,
)
from .temperature import configurational_temperature, kinetic_temperature

__all__ = [
    "ConvergenceResult", "convergence", "energy_error", "modified_energy", "reference_solution",
    "piecewise_linear_response",
    "momentum_drift", "kinetic_temperature", "configurational_temperature", "RelativeEquilibrium", "cartesian_state",
    "distance_from", "modified_relative_equilibrium",
    "reduced_coordinates", "reduced_hessian", "relative_equilibrium",
]
