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


def test_ensemble_members_record_their_springs_as_single_runs_do(frame_run, tmp_path):
    """Each member's spring forces and deformations equal its single run's, bit for bit: its rows on the save
    grid and, for a member that collapsed, its last state off it (each member its own record), in the
    Structure's order of the springs (not the core's); the .nc and .zarr files keep them, with spring_i/_j."""
    frame, _ = frame_run
    t = np.arange(201) * 0.01
    records = [raydamp.GroundMotion((t[:n], 30.0 * np.sin(2 * np.pi * f * t[:n])), np.ones(3))
               for n, f in ((201, 1.5), (151, 1.2), (201, 2.0))]
    q0 = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, -0.01], [0.0, 0.02, 0.0]])
    options = {"h": 0.005, "t_end": 2.0, "save_every": 3}
    # a collapse limit between the members' peak drifts: those past it stop early, their last state off the grid
    peaks = sorted(np.abs(raydamp.integrate(frame, q0[i], np.zeros(3), load=records[i], **options)
                          .spring_deformations).max() for i in range(3))
    limit = 0.5 * (peaks[0] + peaks[1])
    ens = raydamp.integrate_ensemble(frame, q0, np.zeros_like(q0), load=records, threads=2, collapse=limit,
                                     **options)
    assert ens.status.count("collapsed") == 2 and ens.spring_forces.shape == (3, ens.t.size, 3), ens.status
    assert any(ens.t_final[i] not in ens.t for i in range(3))  # the premise: a last state off the grid
    for i in range(3):
        one = raydamp.integrate(frame, q0[i], np.zeros(3), load=records[i], collapse=limit, **options)
        member = ens.member(i)
        assert one.status == ens.status[i] and peaks[0] > 4.0 / 300.0  # the premise: every member yields
        # a collapse limit given as one number is one number in the job JSON (it raised a TypeError)
        assert member.provenance["collapse"] == one.provenance["collapse"] == limit
        np.testing.assert_array_equal(member.t, one.t)
        np.testing.assert_array_equal(member.spring_forces, one.spring_forces)
        np.testing.assert_array_equal(member.spring_deformations, one.spring_deformations)
    for suffix in (".nc", ".zarr"):
        ens.save(tmp_path / f"ensemble{suffix}")
        back = raydamp.load(tmp_path / f"ensemble{suffix}")
        for name in ("spring_forces", "spring_deformations", "spring_forces_final", "spring_deformations_final"):
            np.testing.assert_array_equal(getattr(back, name), getattr(ens, name), err_msg=name)
        np.testing.assert_array_equal(back.member(1).spring_forces, ens.member(1).spring_forces)
    ds = ens.to_xarray()
    assert ds["spring_forces"].dims == ("member", "time", "spring")
    assert ds["spring_i"].values.tolist() == [1, 0, -1] and ds["spring_j"].values.tolist() == [2, 1, 0]
    springless = raydamp.integrate_ensemble(raydamp.Structure(np.eye(3), np.eye(3), alpha=0.3), q0,
                                            np.zeros_like(q0), h=0.01, n_steps=10)
    assert springless.spring_forces is None and "spring" not in springless.to_xarray().dims
