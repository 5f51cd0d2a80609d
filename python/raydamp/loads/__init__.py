"""Time-dependent loads and ground motion: :class:`Load`, :class:`GroundMotion`."""

from .ground import GroundMotion
from .load import Load
from .records import read_record

__all__ = ["Load", "GroundMotion", "read_record"]
