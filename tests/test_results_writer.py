"""raydamp.results.io.write_solution, the one writer of a Solution's CSV, NPZ and NetCDF files (Solution.save
and the service's downloads): written a slice at a time, the file is the file written whole; a reader is
asked for bounded slices only; sol.plot.png, the service's plots."""

from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import pytest
import xarray as xr
from paper import ELASTIC_P0, ELASTIC_Q0
from PIL import Image

import raydamp
from raydamp.models import DampedPendulum, ElasticPendulum
from raydamp.results.io import write_solution


@pytest.fixture(scope="module")
def elastic():  # momentum map J3 and the damping work recorded
    return raydamp.integrate(ElasticPendulum(eps=0.1), ELASTIC_Q0, ELASTIC_P0, method="3s", h=0.05, t_end=20.0,
                             work=True)


@pytest.fixture(scope="module")
def pendulum():  # no momentum map (a (N, 0) column), no work
    return raydamp.integrate(DampedPendulum(eps=0.05), [2.0], [0.0], method="2s", h=0.1, t_end=31.0)


def _row_bytes(sol) -> int:
    return 8 * (2 + 2 * sol.q.shape[1] + sol.momentum.shape[1] + (sol.work is not None))


def _columns(sol) -> dict[str, np.ndarray]:
    names = ["t", "q", "p", "energy", "momentum"] + (["work"] if sol.work is not None else [])
    return {name: getattr(sol, name) for name in names}


def _whole_csv(sol) -> bytes:
    """The CSV as one np.savetxt of the whole table: what save wrote before it wrote in slices."""
    names = ["t", *(f"q_{c}" for c in sol.coordinates), *(f"p_{c}" for c in sol.coordinates), "energy",
             *sol.momentum_names] + (["work"] if sol.work is not None else [])
    table = np.hstack([sol.t[:, None], sol.q, sol.p, sol.energy[:, None], sol.momentum]
                      + ([sol.work[:, None]] if sol.work is not None else []))
    out = io.BytesIO()
    np.savetxt(out, table, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    return out.getvalue()


@pytest.mark.parametrize("name", ["elastic", "pendulum"])
def test_a_file_written_in_slices_is_the_file_written_whole(request, tmp_path, name):
    sol = request.getfixturevalue(name)
    slice_bytes = 7 * _row_bytes(sol) + 3  # 7 rows a slice, the last one shorter
    assert sol.t.size % 7 != 0 and sol.t.size > 50
    for fmt, suffix in (("csv", ".csv"), ("npz", ".npz"), ("netcdf", ".nc")):
        write_solution(tmp_path / f"sliced{suffix}", fmt, sol,
                       lambda column, start, stop: getattr(sol, column)[start:stop],
                       sol.t.size, slice_bytes=slice_bytes)
        sol.save(tmp_path / f"whole{suffix}")
    csv = (tmp_path / "sliced.csv").read_bytes()
    assert csv == _whole_csv(sol) == (tmp_path / "whole.csv").read_bytes()  # the header once, every row once

    # NPZ: every array member holds the bytes np.savez gives it, and attrs the Dataset's attributes.
    np.savez(tmp_path / "savez.npz", **_columns(sol))
    with zipfile.ZipFile(tmp_path / "sliced.npz") as sliced, zipfile.ZipFile(tmp_path / "savez.npz") as savez:
        assert sliced.namelist() == [*savez.namelist(), "attrs.npy"]
        for member in savez.namelist():
            assert sliced.read(member) == savez.read(member), member
    with np.load(tmp_path / "sliced.npz") as data:
        assert json.loads(str(data["attrs"])) == {k: v for k, v in sol.to_xarray().attrs.items()}

    # NetCDF: the Dataset read back is the solution's own, values, names and attributes, as save's is.
    for written in ("sliced.nc", "whole.nc"):
        with xr.open_dataset(tmp_path / written, engine="h5netcdf") as ds:
            assert ds.load().identical(sol.to_xarray()), written
    back = raydamp.load(tmp_path / "sliced.nc")
    for column, values in _columns(sol).items():
        np.testing.assert_array_equal(getattr(back, column), values, err_msg=column)
    assert back.provenance == raydamp.load(tmp_path / "whole.nc").provenance


def test_a_reader_is_asked_for_bounded_slices_of_every_column(tmp_path, elastic):
    """The service's way: rows come from a reader, here every third row of the run."""
    every = 3
    part = raydamp.Solution(**{**{f: getattr(elastic, f) for f in elastic.__dataclass_fields__},
                               **{c: v[::every] for c, v in _columns(elastic).items()}})
    rows, per_slice = part.t.size, 10
    asked: list[tuple[str, int, int]] = []

    def read(column: str, start: int, stop: int) -> np.ndarray:
        asked.append((column, start, stop))
        return getattr(elastic, column)[start * every:stop * every:every]

    head = raydamp.Solution(**{**{f: getattr(elastic, f) for f in elastic.__dataclass_fields__},
                               **{c: v[:1] for c, v in _columns(elastic).items()}})
    for fmt, suffix in (("csv", ".csv"), ("npz", ".npz"), ("netcdf", ".nc")):
        asked.clear()
        write_solution(tmp_path / f"read{suffix}", fmt, head, read, rows, slice_bytes=per_slice * _row_bytes(elastic))
        assert max(stop - start for _, start, stop in asked) == per_slice, fmt
        for column in _columns(elastic):  # each column's rows asked for once, in order
            spans = [(start, stop) for name, start, stop in asked if name == column]
            assert spans == [(s, min(s + per_slice, rows)) for s in range(0, rows, per_slice)], (fmt, column)
    assert (tmp_path / "read.csv").read_bytes() == _whole_csv(part)
    for suffix in (".npz", ".nc"):
        back = raydamp.load(tmp_path / f"read{suffix}")
        for column, values in _columns(part).items():
            np.testing.assert_array_equal(getattr(back, column), values, err_msg=(suffix, column))


def test_file_objects_hold_what_a_path_holds(tmp_path, elastic):
    def read(column, start, stop):
        return getattr(elastic, column)[start:stop]

    for suffix in (".csv", ".npz"):
        elastic.save(tmp_path / f"sol{suffix}")
    out = io.BytesIO()
    write_solution(out, "csv", elastic, read, elastic.t.size, slice_bytes=4096)
    assert out.getvalue() == (tmp_path / "sol.csv").read_bytes()
    out = io.BytesIO()
    write_solution(out, "npz", elastic, read, elastic.t.size, slice_bytes=4096)
    with zipfile.ZipFile(out) as written, zipfile.ZipFile(tmp_path / "sol.npz") as saved:
        assert [written.read(m) for m in saved.namelist()] == [saved.read(m) for m in saved.namelist()]
    with (tmp_path / "object.nc").open("w+b") as file:  # NetCDF appends: the object is read as well
        write_solution(file, "netcdf", elastic, read, elastic.t.size, slice_bytes=4096)
    back = raydamp.load(tmp_path / "object.nc")
    assert back.t.size == elastic.t.size > 4096 // _row_bytes(elastic)  # more than one slice
    np.testing.assert_array_equal(back.p, elastic.p)


def test_unusable_arguments_name_themselves(tmp_path, elastic):
    cases = [(dict(fmt="xlsx"), r"^fmt: unknown format 'xlsx' \(known: csv, npz, netcdf\)"),
             (dict(read=lambda *a: None, rows=0), r"^rows: the number of rows to write, at least 1, got 0"),
             (dict(slice_bytes=0), r"^slice_bytes: a positive number of bytes, got 0")]
    for change, message in cases:
        arguments = {"target": tmp_path / "x", "fmt": "csv", "head": elastic, **change}
        with pytest.raises(ValueError, match=message):
            write_solution(**arguments)


def test_png_plots_have_the_asked_size(elastic, pendulum):
    for sol, kind, options in ((elastic, "energy", {}), (elastic, "phase", {"coordinate": "z"}),
                               (elastic, "projection", {"x": 0, "y": "z"}), (pendulum, "phase", {})):
        png = sol.plot.png(kind, width=321, height=234, **options)
        image = Image.open(io.BytesIO(png))
        assert image.size == (321, 234), kind
        assert np.asarray(image.convert("L"), dtype=float).std() > 5, kind  # something was drawn
    with pytest.raises(ValueError, match=r"^kind: unknown plot 'histogram'"):
        elastic.plot.png("histogram")
    with pytest.raises(ValueError, match=r"^width: a positive number of pixels, got 0"):
        elastic.plot.png("energy", width=0)
    with pytest.raises(ValueError, match=r"^projection: needs a system of at least two coordinates"):
        pendulum.plot.png("projection")
    with pytest.raises(ValueError, match=r"^coordinate: unknown coordinate 'w'"):
        elastic.plot.png("phase", coordinate="w")
