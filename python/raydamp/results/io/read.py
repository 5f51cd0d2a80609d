"""Results read back from files (``raydamp.load``): a Solution (.nc, .npz: io/dataset.py's layout), an
EnsembleSolution (.nc, .zarr: io/ensemble.py's) or a sweep's Dataset, told apart by the suffix and the file's
``kind`` attribute."""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path

import numpy as np

from ..._validation import _short
from ...jobs.statuses import STATUSES
from ..ensemble_solution import EnsembleSolution
from ..solution import Solution
from .ensemble import ENSEMBLE_SPRING_ARRAYS
from .solution import from_npz, from_xarray

__all__ = ["load", "ensemble_from_xarray"]


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


def ensemble_from_xarray(ds) -> EnsembleSolution:
    """An EnsembleSolution from ``ensemble_to_xarray``'s Dataset, provenance included."""
    attrs = dict(ds.attrs)
    codes = np.asarray(ds["status"].values)
    if codes.size and not ((codes >= 0) & (codes < len(STATUSES))).all():  # was STATUSES[c]'s IndexError
        raise ValueError(f"status: codes must be 0..{len(STATUSES) - 1} ({' '.join(STATUSES)}), got "
                         f"{int(codes[(codes < 0) | (codes >= len(STATUSES))][0])}")
    status = tuple(STATUSES[int(c)] for c in codes)
    steps = np.asarray(ds["steps"].values, np.int64)
    messages = json.loads(attrs["messages"])
    message = tuple(messages.get(str(i), f"completed {steps[i]} steps") for i in range(len(status)))
    members = ds.sizes["member"]

    def values(name):
        return np.asarray(ds[name].values, float)

    return EnsembleSolution(
        t=values("t"), q=values("q"), p=values("p"), energy=values("energy"),
        momentum=values("momentum").reshape(members, ds.sizes["time"], -1),
        rows=np.asarray(ds["rows"].values, np.int64),
        t_final=values("t_final"), q_final=values("q_final"), p_final=values("p_final"),
        energy_final=values("energy_final"), momentum_final=values("momentum_final").reshape(members, -1),
        status=status, steps=steps, failed_step=np.asarray(ds["failed_step"].values, np.int64), message=message,
        max_momentum_drift=values("max_momentum_drift"), q0=values("q0"), p0=values("p0"),
        parameters={name: values(name) for name in json.loads(attrs["parameters"])}, method=str(attrs["method"]),
        tableau=str(attrs["tableau"]) or None, composition=str(attrs["composition"]) or None, h=float(attrs["h"]),
        wall_time=float(attrs["wall_time"]), threads=int(attrs["threads"]), origin=json.loads(attrs["provenance"]),
        **{name: values(name) for name in ENSEMBLE_SPRING_ARRAYS if name in ds})
