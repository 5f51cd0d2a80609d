"""Results as files, each kind in its module: a Solution (solution.py: NetCDF, NPZ, CSV, written by
writer.py's ``write_solution`` a slice of rows at a time, also from rows read piecewise), an
EnsembleSolution (ensemble.py: NetCDF, Zarr) and a sweep's Dataset (sweep.py: NetCDF, Zarr);
``load`` reads any of them back by its suffix and the file's ``kind`` attribute."""

from __future__ import annotations

import errno
import os
from pathlib import Path

from ..._validation import _short
from ..ensemble_solution import EnsembleSolution
from ..solution import Solution
from .ensemble import ensemble_from_xarray
from .solution import from_npz, from_xarray
from .writer import write_solution

__all__ = ["load", "write_solution"]


def load(path) -> Solution | EnsembleSolution:
    """Read a solution written by ``Solution.save`` (.nc, .npz) or an ensemble written by
    ``EnsembleSolution.save`` (.nc, .zarr), with its provenance; a sweep's file (.nc, .zarr)
    comes back as its xarray.Dataset."""
    if not isinstance(path, (str, os.PathLike)):  # None was Path's TypeError
        raise ValueError(f"path must be a file path, got {_short(path)}")
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        raise ValueError("path: a .csv file keeps the numbers only; save as .nc or .npz to load it back")
    if suffix not in (".nc", ".zarr", ".npz"):
        raise ValueError(f"path: unknown format {path.suffix!r} (known: .nc, .npz, .zarr)")
    if not path.exists():  # as open() says it; past this, a reader's FileNotFoundError means "not a store"
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), str(path))
    try:
        return _read(path, suffix)
    except PermissionError:
        raise
    except (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError) as error:
        # Another program's file, or a damaged one: a missing variable or attribute (KeyError), a status
        # code past the known ones (IndexError), bytes no reader takes (OSError, ValueError).
        text = str(error)
        text = text if len(text) <= 200 else text[:200] + "..."
        raise ValueError(f"path: not a raydamp result file ({type(error).__name__}: {text})") from None


def _read(path: Path, suffix: str):
    if suffix == ".npz":
        return from_npz(path)
    import xarray as xr

    if suffix == ".zarr":
        with xr.open_zarr(path) as ds:
            return _from_dataset(ds.load())
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return _from_dataset(ds.load())


def _from_dataset(ds):
    kind = ds.attrs.get("kind")
    if kind == "sweep":  # a sweep's result is its Dataset (raydamp.sweep's layout)
        return ds
    return ensemble_from_xarray(ds) if kind == "ensemble" else from_xarray(ds)
