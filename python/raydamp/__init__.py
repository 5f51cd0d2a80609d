"""raydamp: structure-preserving integrators for Hamiltonian systems with Rayleigh damping.

The splitting methods of Modin & Soderlind, "Geometric integration of Hamiltonian
systems perturbed by Rayleigh damping": explicit, Stormer-Verlet when undamped,
with the right dissipation rate, conserved momentum maps and kept relative
equilibria.

>>> import raydamp
>>> sol = raydamp.integrate(raydamp.models.DampedPendulum(eps=0.01), [0.9 * 3.14159], [0.0],
...                         method="3s", h=0.2, t_end=200)
"""

from . import materials, models
from ._core import __version__
from .loads import GroundMotion, Load
from .methods.catalogue import CompositionInfo, MethodInfo, TableauInfo, compositions, methods, tableaux
from .results.ensemble_solution import EnsembleSolution
from .results.io import load
from .results.solution import Solution
from .run.advise import Advice, MethodAdvice, advise
from .run.ductility import ductility_spectrum
from .run.ensemble import integrate_ensemble
from .run.events import Event
from .run.ida import ida
from .run.integrate import CancelToken, integrate, steps_for
from .run.spectrum import response_spectrum
from .run.sweep import SweepPlan, check_sweep, parse_grid_item, sweep
from .systems.chain import Chain, chain_mode_energies
from .systems.kepler import Kepler
from .systems.planets import Planets
from .systems.rayleigh import modal_damping_ratio, rayleigh_coefficients
from .systems.series import ChebyshevDegreeError
from .systems.structure import LinearStructure
from .systems.system import SpecError, System
from .systems.yielding import Spring, Structure

__all__ = ["__version__", "models", "Load", "GroundMotion", "System", "Chain", "chain_mode_energies", "Kepler",
           "Planets",
           "LinearStructure", "Structure", "Spring", "materials", "SpecError", "ChebyshevDegreeError", "integrate",
           "steps_for", "advise", "Advice",
           "MethodAdvice", "CancelToken", "Solution", "integrate_ensemble", "EnsembleSolution", "sweep",
           "check_sweep", "parse_grid_item", "SweepPlan", "load", "rayleigh_coefficients", "modal_damping_ratio",
           "methods", "tableaux", "compositions", "MethodInfo", "TableauInfo", "CompositionInfo",
           "response_spectrum", "ductility_spectrum", "Event", "ida"]

# Subpackages a user reaches as attributes (raydamp.analysis.kinetic_temperature, as the README writes it),
# imported when first used: raydamp.analysis needs SciPy (the analysis extra), and `import raydamp` needs NumPy
# alone. (Without this, raydamp.analysis after `import raydamp` was an AttributeError.)
_SUBPACKAGES = frozenset({"analysis", "cli", "jobs", "loads", "methods", "reproduce", "results", "run", "systems"})


def __getattr__(name: str):
    if name in _SUBPACKAGES:
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
