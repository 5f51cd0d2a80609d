"""Results as files, each kind in its module: a Solution (solution.py: NetCDF, NPZ, CSV, written by
writer.py's ``write_solution`` a slice of rows at a time, also from rows read piecewise), an
EnsembleSolution (ensemble.py: NetCDF, Zarr) and a sweep's Dataset (sweep.py: NetCDF, Zarr);
``load`` reads any of them back by its suffix and the file's ``kind`` attribute."""

from __future__ import annotations

from .read import load
from .writer import write_solution

__all__ = ["load", "write_solution"]
