"""``raydamp sweep spec.json --grid eps=0.001:0.1:20 ...``: a grid of runs through
:func:`raydamp.sweep` on Dask (a LocalCluster here, or a scheduler's address), with a progress
bar per chunk, a summary of the members' outcomes, and the Dataset written as NetCDF or Zarr.
Exit codes: 0 every member completed, 1 some member did not (blow-up: the summary names them),
2 a bad file, spec or grid."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from ..results.ensemble_solution import STATUSES
from ..results.io.ensemble import ENSEMBLE_FORMATS
from ..results.io.sweep import save_sweep
from ..run.cluster import local_cluster
from ..run.integrate import CancelToken
from ..run.sweep import check_sweep, parse_grid_item, sweep
from .ctrl_c import ctrl_c_cancels
from .output_paths import file_problem
from .run_command import read_spec
from .thermal_options import THERMAL_KEYS, with_thermal_options

__all__ = ["sweep_file"]

_SHOWN_FAILURES = 10


def _fail(message: str) -> int:
    print(f"raydamp sweep: {message}", file=sys.stderr)
    return 2


def _client(scheduler: str | None, workers: int):
    from dask.distributed import Client

    if scheduler:
        return Client(scheduler, timeout=30), []
    cluster = local_cluster(workers)  # on 127.0.0.1 only
    client = Client(cluster)
    return client, [client, cluster]


def _grid(items: list[str]) -> dict:
    """The --grid axes by name; ValueError for an axis given twice (a dict would keep only the last)."""
    grid: dict = {}
    for item in items:
        name, values = parse_grid_item(item)
        if name in grid:
            raise ValueError(f"--grid {name}: given twice")
        grid[name] = values
    return grid


def _connect(scheduler: str | None, source: str, workers: int):
    """_client's (client, things to close); ValueError naming ``source`` (the flag or the variable)."""
    try:
        return _client(scheduler, workers)
    except ValueError as error:  # a malformed address: Dask's message lacks which setting gave it
        if not scheduler:
            raise
        raise ValueError(f"{source} {scheduler!r}: not a scheduler address such as tcp://host:8786 ({error})") \
            from None
    except (OSError, TimeoutError) as error:
        raise ValueError(f"{source} {scheduler}: cannot connect ({error})") from None


def _summary(ds, seconds: float) -> str:
    status = ds["status"].values
    grid = json.loads(ds.attrs["grid"])
    lines = [f"{'members':<12} {status.size}", f"{'grid':<12} " + " x ".join(
        f"{name} ({np.unique(ds[name].values).size})" for name in grid), f"{'wall time':<12} {seconds:.3g} s"]
    provenance = json.loads(ds.attrs["provenance"])
    if provenance.get("temperature"):  # what repeats the sweep's noise (a seed drawn here is shown only here)
        lines += [f"{key:<12} {provenance[key]}" for key in THERMAL_KEYS if key in provenance]
    for code, name in enumerate(STATUSES):
        count = int((status == code).sum())
        if count:
            lines.append(f"{name:<12} {count}")
    return "\n".join(lines)


def sweep_file(spec_path: str, grid_items: list[str], *, out: str | None = None, chunk_size: int = 1000,
               scheduler: str | None = None, workers: int = 2, progress: bool = True,
               temperature: float | None = None, seed: int | None = None, stream: int | None = None) -> int:
    """Run the sweep; ``temperature``, ``seed`` and ``stream`` (the flags), when given, replace the
    spec file's. Returns the exit code."""
    if out is not None and Path(out).suffix.lower() not in ENSEMBLE_FORMATS:
        return _fail(f"--out: unknown format {Path(out).suffix!r} (known: {', '.join(ENSEMBLE_FORMATS)})")
    zarr_out = out is not None and Path(out).suffix.lower() == ".zarr"
    if out is not None and (problem := file_problem(out, store=zarr_out)):  # before the sweep, not after it
        return _fail(f"--out {out}: {problem}")
    if not grid_items:
        return _fail("--grid: give at least one, e.g. --grid eps=0.001:0.1:20")
    if workers < 1:
        return _fail(f"--workers must be >= 1, got {workers}")
    try:
        spec = with_thermal_options(read_spec(spec_path), temperature, seed, stream)
        grid = _grid(grid_items)
    except ValueError as error:
        return _fail(str(error))
    if isinstance(spec, dict) and spec.get("work"):
        # The same file serves `raydamp run`, where W is recorded; members of a sweep do not record it.
        print("raydamp sweep: note: the spec's \"work\": true is ignored (sweeps do not record the damping work; "
              "a member equals raydamp run with \"work\": false bit for bit)", file=sys.stderr)
        spec = {k: v for k, v in spec.items() if k != "work"}
    source = "--scheduler" if scheduler else "RAYDAMP_DASK_SCHEDULER"
    scheduler = scheduler or os.environ.get("RAYDAMP_DASK_SCHEDULER") or None
    try:
        check_sweep(spec, grid, chunk_size=chunk_size)  # bad input is reported before a cluster starts
    except ValueError as error:
        return _fail(f"{spec_path}: {error}")
    try:
        client, close = _connect(scheduler, source, workers)
    except ValueError as error:
        return _fail(str(error))
    start = time.perf_counter()
    # Ctrl-C cancels the sweep as cancel= does: it returns the finished chunks, the other members
    # "cancelled", and they are written (its loop waits in Python, so the handler runs at once).
    token = CancelToken()
    try:
        with ctrl_c_cancels(token):
            ds = sweep(spec, grid, client=client, chunk_size=chunk_size, progress=True if progress else None,
                       store=out if zarr_out else None, cancel=token)
    except ValueError as error:
        return _fail(f"{spec_path}: {error}")
    finally:
        for thing in close:
            thing.close()
    print(_summary(ds, time.perf_counter() - start))
    if out is not None:
        if not zarr_out:
            save_sweep(ds, out)
        print(f"wrote {out}")
    messages = json.loads(ds.attrs.get("messages", "{}"))
    if messages:
        for member, message in list(messages.items())[:_SHOWN_FAILURES]:
            values = ", ".join(f"{name}={ds[name].values[int(member)]}" for name in json.loads(ds.attrs["grid"]))
            print(f"raydamp sweep: member {member} ({values}): {message}", file=sys.stderr)
        if len(messages) > _SHOWN_FAILURES:
            print(f"raydamp sweep: ... and {len(messages) - _SHOWN_FAILURES} more", file=sys.stderr)
        return 1
    if token.cancelled:
        print("raydamp sweep: stopped early (Ctrl-C): the unfinished members are \"cancelled\"", file=sys.stderr)
        return 1
    return 0
