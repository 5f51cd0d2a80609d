"""A Structure's per-spring arrays (spring_forces, spring_deformations, hysteretic_work) in files and in
to_xarray: dims (time, spring), each spring's coordinates as spring_i / spring_j, read back bit for bit, also
when written a slice of rows at a time (the service's downloads) and from a stored run (raydamp.results.stored).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import raydamp
from raydamp.materials import Bilinear, BoucWen, ElasticPlastic
from raydamp.results.io import write_solution

SPRING_ARRAYS = ("spring_forces", "spring_deformations", "hysteretic_work")


@pytest.fixture(scope="module")
def frame_run():
    # listed top storey first, of mixed kinds: the core's order (grouped by kind) is not the Structure's
    springs = [raydamp.Spring((1, 2), Bilinear(300.0, 4.0, 0.05)), raydamp.Spring((0, 1), BoucWen(300.0, 4.0, 0.1)),
               raydamp.Spring((0,), ElasticPlastic(300.0, 4.0))]
    frame = raydamp.Structure(np.eye(3), springs=springs, alpha=0.3)
    t = np.arange(201) * 0.01
    a = 30.0 * np.sin(2 * np.pi * 1.5 * t) * np.sin(np.pi * t / t[-1])
    sol = raydamp.integrate(frame, np.zeros(3), np.zeros(3), load=raydamp.GroundMotion((t, a), np.ones(3)),
                            h=0.005, t_end=float(t[-1]), save_every=2, work=True)
    assert sol.status == "completed", sol.message
    assert np.abs(sol.spring_deformations).max(axis=0).min() > 4.0 / 300.0  # every storey yields
    return frame, sol


def _assert_springs_equal(back, sol):
    for name in SPRING_ARRAYS:
        np.testing.assert_array_equal(getattr(back, name), getattr(sol, name), err_msg=name)


def test_to_xarray_has_the_springs_arrays_with_their_coordinates(frame_run):
    _, sol = frame_run
    ds = sol.to_xarray()
    for name in SPRING_ARRAYS:
        assert ds[name].dims == ("time", "spring")
        np.testing.assert_array_equal(ds[name].values, getattr(sol, name))
    np.testing.assert_array_equal(ds["spring_i"].values, [1, 0, -1])
    np.testing.assert_array_equal(ds["spring_j"].values, [2, 1, 0])
    q = ds["q"].values
    ground = np.where(ds["spring_i"].values >= 0, q[:, np.maximum(ds["spring_i"].values, 0)], 0.0)
    np.testing.assert_array_equal(ds["spring_deformations"].values, q[:, ds["spring_j"].values] - ground)


@pytest.mark.parametrize("suffix", [".npz", ".nc"])
def test_a_file_read_back_keeps_the_springs_arrays_bit_for_bit(frame_run, tmp_path, suffix):
    _, sol = frame_run
    sol.save(tmp_path / f"run{suffix}")
    back = raydamp.load(tmp_path / f"run{suffix}")
    _assert_springs_equal(back, sol)
    np.testing.assert_array_equal(back.energy_balance, sol.energy_balance)  # it left out the hysteretic work
    np.testing.assert_array_equal(back.absolute_acceleration(), sol.absolute_acceleration())
    assert np.abs(sol.hysteretic_work[-1]).min() > 0.01  # so that leaving it out would show


@pytest.mark.parametrize("fmt, suffix", [("npz", ".npz"), ("netcdf", ".nc")])
def test_rows_written_a_slice_at_a_time_keep_the_springs_arrays(frame_run, tmp_path, fmt, suffix):
    # the service's downloads: rows read piecewise, here 7 rows a slice (the NetCDF appends along time)
    _, sol = frame_run
    width = 1 + 2 * 3 + 1 + 0 + 2 + 3 * 3  # t, q, p, energy, momentum, work, load_work, the springs' three

    def read(column, start, stop):
        return getattr(sol, column)[start:stop]

    write_solution(tmp_path / f"rows{suffix}", fmt, sol, read, sol.t.size, slice_bytes=7 * 8 * width)
    back = raydamp.load(tmp_path / f"rows{suffix}")
    _assert_springs_equal(back, sol)
    np.testing.assert_array_equal(back.q, sol.q)


def test_csv_has_a_column_per_spring_of_each_array(frame_run, tmp_path):
    _, sol = frame_run
    sol.save(tmp_path / "run.csv")
    header = (tmp_path / "run.csv").read_text().splitlines()[0].split(",")
    table = np.loadtxt(tmp_path / "run.csv", delimiter=",", skiprows=1)
    for name, prefix in zip(SPRING_ARRAYS, ("spring_force", "spring_deformation", "hysteretic_work")):
        columns = [header.index(f"{prefix}_{s}") for s in range(3)]
        np.testing.assert_array_equal(table[:, columns], getattr(sol, name))


def test_a_stored_run_keeps_its_springs_arrays_and_absolute_acceleration(frame_run):
    # raydamp.results.stored: what the service rebuilds from its database
    from raydamp.jobs import PROVENANCE_KEYS, JobSpec
    from raydamp.results.stored import stored_solution

    _, sol = frame_run
    spec = JobSpec.model_validate({k: v for k, v in sol.provenance.items() if k not in PROVENANCE_KEYS})
    arrays = {name: getattr(sol, name) for name in ("t", "q", "p", "energy", "momentum", "work", "load_work",
                                                    *SPRING_ARRAYS)}
    stored = stored_solution(spec, sol.summary(), arrays, origin=spec.model_dump(exclude_none=True),
                             status="completed")
    _assert_springs_equal(stored, sol)
    np.testing.assert_array_equal(stored.absolute_acceleration(), sol.absolute_acceleration())
    ds = stored.to_xarray()
    np.testing.assert_array_equal(ds["spring_i"].values, [1, 0, -1])


def test_a_springless_run_writes_no_spring_arrays(tmp_path):
    structure = raydamp.Structure(np.eye(2), [[2.0, -1.0], [-1.0, 2.0]], alpha=0.1)
    sol = raydamp.integrate(structure, [0.1, 0.0], [0.0, 0.0], h=0.01, n_steps=10)
    ds = sol.to_xarray()
    assert "spring" not in ds.dims and not set(SPRING_ARRAYS) & set(ds.variables)
    sol.save(tmp_path / "run.npz")
    back = raydamp.load(tmp_path / "run.npz")
    assert all(getattr(back, name) is None for name in SPRING_ARRAYS)


def test_a_file_of_a_run_without_the_forces_still_refuses_the_absolute_acceleration(frame_run, tmp_path):
    _, sol = frame_run
    without = dataclasses.replace(sol, spring_forces=None)
    without.save(tmp_path / "run.npz")
    back = raydamp.load(tmp_path / "run.npz")
    assert back.spring_forces is None
    with pytest.raises(ValueError, match=r"^absolute_acceleration: the springs' forces at the saved rows"):
        back.absolute_acceleration()
