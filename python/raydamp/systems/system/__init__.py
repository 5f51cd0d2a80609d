"""User-defined systems: expressions, matrices and dashpots, compiled."""

from .errors import SpecError
from .system import System

__all__ = ["System", "SpecError"]
