"""A sweep's Dataset (:func:`raydamp.sweep`'s layout) as a file: NetCDF or Zarr."""

from __future__ import annotations

from pathlib import Path

from .ensemble import ENSEMBLE_FORMATS

__all__ = ["save_sweep"]


def save_sweep(ds, path) -> None:
    """Write a :func:`raydamp.sweep` Dataset to ``path``: .nc (NetCDF via h5netcdf) or .zarr."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".nc":
        ds.to_netcdf(path, engine="h5netcdf")
    elif suffix == ".zarr":
        ds.to_zarr(path, mode="w", zarr_format=2)
    else:
        raise ValueError(f"path: unknown format {path.suffix!r} for a sweep (known: {', '.join(ENSEMBLE_FORMATS)})")
