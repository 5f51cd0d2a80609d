"""Results people can keep: provenance, xarray, NetCDF/NPZ/CSV round trips, plots."""

from __future__ import annotations

import json

import matplotlib
import numpy as np
import pytest
from paper import ELASTIC_P0, ELASTIC_Q0
from systems import kepler

import raydamp
from raydamp.jobs import job_arguments
from raydamp.models import DampedPendulum, ElasticPendulum

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def elastic():
    return raydamp.integrate(ElasticPendulum(eps=0.1), ELASTIC_Q0, ELASTIC_P0, method="rks", tableau="midpoint",
                             h=0.1, t_end=20.0, save_every=5, work=True)


@pytest.fixture(scope="module")
def orbit():
    return raydamp.integrate(kepler(0.01), [1.0, 0.0], [0.0, 1.2], method="2s", h=0.01, n_steps=3000,
                             save_every=30)


def test_provenance_reruns_to_the_same_numbers(elastic, orbit):
    for sol in (elastic, orbit):
        again = raydamp.integrate(*job_arguments(sol.provenance)[:3], **job_arguments(sol.provenance)[3])
        np.testing.assert_array_equal(again.q, sol.q)
        np.testing.assert_array_equal(again.p, sol.p)
    assert elastic.provenance["model"] == "elastic_pendulum"
    assert elastic.provenance["parameters"]["g"] == [0.0, 0.0, -1.0]
    assert elastic.provenance["tableau"] == "midpoint" and elastic.provenance["t_end"] == 20.0
    assert orbit.provenance["system"] == kepler(0.01).to_dict() and orbit.provenance["n_steps"] == 3000
    assert orbit.provenance["raydamp_version"] == raydamp.__version__
    json.dumps(orbit.provenance)  # plain JSON


def test_to_xarray_dims_coords_and_attrs(elastic, orbit):
    ds = elastic.to_xarray()
    assert dict(ds.sizes) == {"time": elastic.t.size, "dof": 3, "momentum_map": 1}
    assert list(ds["dof"].values) == ["x", "y", "z"] and list(ds["momentum_map"].values) == ["J3"]
    np.testing.assert_array_equal(ds["q"].values, elastic.q)
    np.testing.assert_array_equal(ds["work"].values, elastic.work)
    assert json.loads(ds.attrs["provenance"])["method"] == "rks"
    assert ds.attrs["status"] == "completed"
    assert list(orbit.to_xarray()["momentum_map"].values) == ["L"]


@pytest.mark.parametrize("suffix", [".nc", ".npz"])
def test_save_and_load_round_trip(tmp_path, elastic, orbit, suffix):
    for sol in (elastic, orbit):
        path = tmp_path / f"sol{suffix}"
        sol.save(path)
        back = raydamp.load(path)
        for name in ("t", "q", "p", "energy", "momentum"):
            np.testing.assert_array_equal(getattr(back, name), getattr(sol, name))
        assert (back.work is None) == (sol.work is None)
        if sol.work is not None:
            np.testing.assert_array_equal(back.work, sol.work)
        assert back.provenance == {**sol.provenance, "coordinates": list(sol.coordinates),
                                   "momentum_names": list(sol.momentum_names)}
        assert back.coordinates == sol.coordinates and back.momentum_names == sol.momentum_names
        assert (back.status, back.steps, back.failed_step, back.method, back.tableau, back.h) == \
               (sol.status, sol.steps, sol.failed_step, sol.method, sol.tableau, sol.h)
        assert back.summary() == sol.summary()


def test_csv_has_the_numbers_with_headers(tmp_path, elastic):
    path = tmp_path / "sol.csv"
    elastic.save(path)
    header = path.read_text().splitlines()[0].split(",")
    assert header == ["t", "q_x", "q_y", "q_z", "p_x", "p_y", "p_z", "energy", "J3", "work"]
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, 1:4], elastic.q)  # %.17g round-trips doubles exactly
    np.testing.assert_array_equal(table[:, 7], elastic.energy)
    with pytest.raises(ValueError, match=r"^path: a \.csv file keeps the numbers only"):
        raydamp.load(path)


def test_unknown_format_names_path(tmp_path, elastic):
    with pytest.raises(ValueError, match=r"^path: unknown format '\.txt'"):
        elastic.save(tmp_path / "sol.txt")


def test_blown_up_run_saves_and_loads_its_failed_step(tmp_path):
    # Heun on the elastic pendulum's spring mode at h = 2.5 amplifies (tests/test_blowup.py).
    sol = raydamp.integrate(ElasticPendulum(eps=0.1), ELASTIC_Q0, ELASTIC_P0, method="heun", h=2.5, n_steps=100_000,
                            save_every=100)
    assert sol.status == "non_finite"
    sol.save(tmp_path / "blown.nc")
    back = raydamp.load(tmp_path / "blown.nc")
    assert back.status == "non_finite" and back.failed_step == sol.failed_step and back.message == sol.message


def test_plots_return_axes_with_the_data(elastic, orbit):
    ax = elastic.plot.energy()
    lines = ax.get_lines()
    assert len(lines) == 2  # H and, since work was recorded, H - H0 + W
    np.testing.assert_array_equal(lines[0].get_ydata(), elastic.energy)
    np.testing.assert_allclose(lines[1].get_ydata(), elastic.energy_balance)
    ax = elastic.plot.phase("z")
    np.testing.assert_array_equal(ax.get_lines()[0].get_xdata(), elastic.q[:, 2])
    assert ax.get_ylabel() == "p_z"
    ax = orbit.plot.projection("x", "y")
    np.testing.assert_array_equal(ax.get_lines()[0].get_ydata(), orbit.q[:, 1])
    # Overlays compose on one axes.
    ax = orbit.plot.energy(label="2s")
    elastic.plot.energy(ax=ax, balance=False, label="rks")
    assert len(ax.get_lines()) == 2
    with pytest.raises(ValueError, match=r"^coordinate: unknown coordinate 'w'"):
        orbit.plot.phase("w")
    pendulum = raydamp.integrate(DampedPendulum(), [1.0], [0.0], h=0.1, n_steps=10)
    with pytest.raises(ValueError, match=r"^projection: needs a system of at least two coordinates"):
        pendulum.plot.projection()
    # A 3-D run that saved one coordinate: it said "a system of at least two coordinates" (API audit).
    one = raydamp.integrate(ElasticPendulum(), [0, 1, 0], [1, 0, 0], h=0.1, n_steps=3, save_dofs=[2])
    with pytest.raises(ValueError, match=r"^projection: the run saved one coordinate \(z, save_dofs\)"):
        one.plot.projection()
    matplotlib.pyplot.close("all")


def test_job_arguments_name_the_bad_field():
    good = {"model": "damped_pendulum", "method": "3s", "step_size": 0.1, "n_steps": 10,
            "initial_state": {"q": [1.0], "p": [0.0]}}
    raydamp.integrate(*job_arguments(good)[:3], **job_arguments(good)[3])
    cases = [({**good, "model": "nope"}, r"^model: unknown model 'nope'"),
             ({**good, "parameters": {"eps": -1}}, r"^parameters\.eps must be >= 0"),
             ({**good, "parameters": {"k": 1}}, r"^parameters\.k: damped_pendulum has no parameter"),
             ({**good, "extra": 1}, r"^extra: unknown key"),
             ({k: v for k, v in good.items() if k != "step_size"}, r"^h: missing"),
             ({**good, "initial_state": [1]}, r"^initial_state: "),
             ({**good, "system": {"coordinates": 1, "potential": "q0^2"}}, r"^model: give exactly one"),
             ({**{k: v for k, v in good.items() if k != "model"}, "system": {"coordinates": 1, "potential": "q0^"}},
              r"^system\.potential: ")]
    for spec, message in cases:
        with pytest.raises(ValueError, match=message):
            job_arguments(spec)


def test_composed_run_keeps_its_composition(tmp_path):
    sol = raydamp.integrate(ElasticPendulum(eps=0.1), ELASTIC_Q0, ELASTIC_P0, method="3s", composition="yoshida4",
                            h=0.1, n_steps=200, save_every=20)
    assert sol.provenance["composition"] == "yoshida4"
    model, q0, p0, options = job_arguments(sol.provenance)
    np.testing.assert_array_equal(raydamp.integrate(model, q0, p0, **options).q, sol.q)
    sol.save(tmp_path / "c.nc")
    assert raydamp.load(tmp_path / "c.nc").composition == "yoshida4"
    plain = raydamp.integrate(ElasticPendulum(eps=0.1), ELASTIC_Q0, ELASTIC_P0, method="3s", h=0.1, n_steps=200)
    assert plain.provenance["composition"] is None
    plain.save(tmp_path / "p.nc")
    assert raydamp.load(tmp_path / "p.nc").composition is None


@pytest.mark.parametrize("suffix", [".nc", ".npz", "xarray"])
def test_the_saved_coordinates_survive_a_round_trip(tmp_path, suffix):
    """Solution.dofs came back None (every coordinate saved) from a file or a Dataset of a run with save_dofs,
    while q held only the saved columns."""
    sol = raydamp.integrate(ElasticPendulum(), ELASTIC_Q0, ELASTIC_P0, h=0.1, n_steps=20, save_dofs=[2, 0])
    if suffix == "xarray":
        from raydamp.results.io.solution import from_xarray

        back = from_xarray(sol.to_xarray())
    else:
        sol.save(tmp_path / f"run{suffix}")
        back = raydamp.load(tmp_path / f"run{suffix}")
    np.testing.assert_array_equal(back.dofs, [2, 0])
    assert back.coordinates == sol.coordinates == ("z", "x")
    np.testing.assert_array_equal(back.q, sol.q)
