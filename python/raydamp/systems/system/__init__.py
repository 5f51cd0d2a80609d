"""User-defined systems: expressions, matrices and dashpots, compiled."""

from .compile import NotCompiled, compiled_elsewhere, load_compiled
from .errors import SpecError
from .system import System

__all__ = ["System", "SpecError", "NotCompiled", "compiled_elsewhere", "load_compiled"]
