"""Ensembles (issue 8): one compiled call for many members, on threads, each member equal bit
for bit to a single run; the Dataset layout; NetCDF and Zarr round trips with provenance."""

from __future__ import annotations

import math

import numpy as np
import pytest
import systems

import raydamp
from raydamp.jobs import job_arguments
from raydamp.models import DampedPendulum, ElasticPendulum

ELASTIC_Q0 = [0.0, 1.55884573, -0.6]
ELASTIC_P0 = [1.34164079, 0.0, 0.0]


def same(sol: raydamp.Solution, ref: raydamp.Solution) -> bool:
    """Bit for bit: every saved array and the run's outcome."""
    arrays = ("t", "q", "p", "energy", "momentum")
    # equal_nan: a blown-up run's last finite state can have H = inf - inf, NaN in both
    return (all(np.array_equal(getattr(sol, a), getattr(ref, a), equal_nan=True) for a in arrays)
            and (sol.status, sol.steps, sol.failed_step, sol.message, sol.max_momentum_drift)
            == (ref.status, ref.steps, ref.failed_step, ref.message, ref.max_momentum_drift))


def test_1000_members_equal_1000_single_runs_bit_for_bit():
    rng = np.random.default_rng(8)
    members = 1000
    q0 = rng.uniform(-3.0, 3.0, (members, 1))
    p0 = rng.uniform(-1.0, 1.0, (members, 1))
    eps = rng.uniform(0.0, 0.5, members)
    # 40 steps saved every 7: the grid rows and the off-grid final row both appear.
    ens = raydamp.integrate_ensemble(DampedPendulum(), q0, p0, parameters={"eps": eps}, h=0.05, n_steps=40,
                                     save_every=7, threads=2)
    assert ens.threads == 2 and ens.members == members and ens.success
    for i in range(members):
        ref = raydamp.integrate(DampedPendulum(eps[i]), q0[i], p0[i], h=0.05, n_steps=40, save_every=7)
        assert same(ens.member(i), ref), i


@pytest.mark.parametrize("method, composition", [("3s", None), ("2s", "suzuki4"), ("sv", None)])
def test_pendulums_run_as_lanes_equal_single_runs_bit_for_bit(method, composition):
    # Members sharing eps run as the lanes of one run (256 at most); runs of fewer than 4 go
    # one by one: 300 x 0.1 (lanes 256 + 44), 3 x 0.2 (one by one), 297 x 0.3 (256 + 41).
    eps = np.repeat([0.1, 0.2, 0.3], [300, 3, 297]) if method != "sv" else np.zeros(600)
    q0 = np.linspace(-3.0, 3.0, 600)[:, None]
    p0 = np.cos(np.arange(600.0))[:, None]
    ens = raydamp.integrate_ensemble(DampedPendulum(), q0, p0, parameters={"eps": eps}, method=method,
                                     composition=composition, h=0.1, t_end=3.05, save_every=4, threads=2)
    for i in range(600):
        ref = raydamp.integrate(DampedPendulum(eps[i]), q0[i], p0[i], method=method, composition=composition,
                                h=0.1, t_end=3.05, save_every=4)
        assert same(ens.member(i), ref), i


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_threads_change_nothing_composed_elastic_pendulum(threads):
    rng = np.random.default_rng(1)
    q0 = np.array(ELASTIC_Q0) + rng.normal(0.0, 0.1, (17, 3))
    p0 = np.array(ELASTIC_P0) + rng.normal(0.0, 0.1, (17, 3))
    k = rng.uniform(0.5, 2.0, 17)
    g = np.tile([0.0, 0.0, -1.0], (17, 1)) + rng.normal(0.0, 0.1, (17, 3))
    ens = raydamp.integrate_ensemble(ElasticPendulum(eps=0.2), q0, p0, parameters={"k": k, "g": g}, method="2s",
                                     composition="yoshida4", h=0.02, t_end=1.01, save_every=10, threads=threads)
    assert ens.momentum.shape == (17, ens.t.size, 1) and ens.success
    for i in range(17):
        model = ElasticPendulum(eps=0.2, k=k[i], g=g[i])
        ref = raydamp.integrate(model, q0[i], p0[i], method="2s", composition="yoshida4", h=0.02, t_end=1.01,
                                save_every=10)
        assert same(ens.member(i), ref), i


def test_system_members_rebuilt_per_parameter_set():
    base = systems.elastic_pendulum(eps=0.1)
    eps = np.array([0.1, 0.3, 0.1, 0.3, 0.0, 0.1])
    k = np.array([1.0, 1.0, 2.0, 2.0, 1.0, 1.0])
    q0 = np.tile(ELASTIC_Q0, (6, 1))
    ens = raydamp.integrate_ensemble(base, q0, ELASTIC_P0, parameters={"eps": eps, "k": k}, h=0.05, n_steps=30,
                                     save_every=5)
    for i in range(6):
        model = base.replace(eps=float(eps[i]), parameters={**base.parameters, "k": float(k[i])})
        ref = raydamp.integrate(model, ELASTIC_Q0, ELASTIC_P0, h=0.05, n_steps=30, save_every=5)
        assert same(ens.member(i), ref), i
    # and the members really differ: eps and k both act
    assert len({float(ens.energy_final[i]) for i in range(4)}) == 4


def test_a_member_that_blows_up_stops_alone_keeping_its_rows():
    # V = -x^4: from x = 3 the state overflows within a few dozen steps of h = 0.1; from the
    # equilibrium x = 0 (and x = 1e-3, over these 100 steps) it does not.
    unstable = raydamp.System(["x"], "-x^4", damping={"scalar": 1.0}, eps=0.1)
    q0 = np.array([[0.0], [3.0], [1e-3]])
    ens = raydamp.integrate_ensemble(unstable, q0, [0.0], h=0.1, n_steps=100, save_every=3, threads=2)
    assert ens.status == ("completed", "non_finite", "completed")
    ref = raydamp.integrate(unstable, [3.0], [0.0], h=0.1, n_steps=100, save_every=3)
    assert ref.status == "non_finite" and ref.steps < 100
    blown = ens.member(1)
    assert same(blown, ref)
    assert ens.rows[1] < ens.t.size and np.isnan(ens.q[1, ens.rows[1]:]).all()
    assert np.isfinite(ens.q[1, :ens.rows[1]]).all()
    for i in (0, 2):
        assert same(ens.member(i), raydamp.integrate(unstable, q0[i], [0.0], h=0.1, n_steps=100, save_every=3))


def test_bad_arguments_name_themselves():
    model = DampedPendulum()
    with pytest.raises(ValueError, match=r"q0 must have shape \(members, 1\)"):
        raydamp.integrate_ensemble(model, np.zeros((3, 2)), np.zeros((3, 1)), h=0.1, n_steps=3)
    with pytest.raises(ValueError, match="p0 has 2 members, expected 3"):
        raydamp.integrate_ensemble(model, np.zeros((3, 1)), np.zeros((2, 1)), h=0.1, n_steps=3)
    with pytest.raises(ValueError, match=r"q0 must be finite, got q0\[1, 0\]"):
        raydamp.integrate_ensemble(model, [[0.0], [math.nan]], [0.0], h=0.1, n_steps=3)
    with pytest.raises(ValueError, match="parameters.k: not a parameter"):
        raydamp.integrate_ensemble(model, np.zeros((2, 1)), [0.0], parameters={"k": [1, 2]}, h=0.1, n_steps=3)
    with pytest.raises(ValueError, match=r"member 1: parameters.eps must be a finite number >= 0"):
        raydamp.integrate_ensemble(model, np.zeros((2, 1)), [0.0], parameters={"eps": [0.1, -1.0]}, h=0.1,
                                   n_steps=3)
    with pytest.raises(ValueError, match=r"q0\[1\] must not be the origin"):
        raydamp.integrate_ensemble(ElasticPendulum(), [ELASTIC_Q0, [0, 0, 0]], ELASTIC_P0, h=0.1, n_steps=3)
    with pytest.raises(ValueError, match="threads must be >= 1"):
        raydamp.integrate_ensemble(model, np.zeros((2, 1)), [0.0], h=0.1, n_steps=3, threads=0)
    # the amplification guard, per member: only the strongly damped member is refused
    with pytest.raises(ValueError, match=r"member 1: .*amplif"):
        raydamp.integrate_ensemble(model, np.zeros((2, 1)), [0.0], parameters={"eps": [0.01, 400.0]}, h=0.1,
                                   n_steps=3, composition="yoshida4")


def test_cancel_stops_every_member():
    token = raydamp.CancelToken()
    token.cancel()
    ens = raydamp.integrate_ensemble(DampedPendulum(), np.ones((4, 1)), [0.0], h=0.1, n_steps=10**6,
                                     save_every=10**6, cancel=token)
    assert ens.status == ("cancelled",) * 4 and (ens.steps == 0).all()


@pytest.mark.parametrize("eps_groups", [1, 400])
def test_progress_counts_only_grow_and_end_at_members(eps_groups):
    # One eps: members run as lanes, progress counted per batch; 400 eps: one by one. Two threads race
    # to report (a count of 37 once came before 36: CI's test_ensemble); the counts must only grow.
    members = 400
    eps = np.repeat(np.linspace(0.0, 0.3, eps_groups), members // eps_groups)
    for _ in range(20):
        counts: list[tuple[int, int]] = []
        raydamp.integrate_ensemble(DampedPendulum(), np.linspace(-1, 1, members)[:, None], [0.0],
                                   parameters={"eps": eps}, h=0.1, n_steps=3, threads=2,
                                   progress=lambda done, total: (
                                       counts.append((done, total))))  # noqa: B023 - called before this call returns
        done = [c[0] for c in counts]
        assert done == sorted(set(done)) and done[-1] == members and {c[1] for c in counts} == {members}


def vector_sine_ensemble(**kwargs) -> raydamp.EnsembleSolution:
    # Two eps groups (two lane runs and their tails of fewer than four lanes), 500 steps.
    q0 = np.linspace(-2.5, 2.5, 70)[:, None]
    p0 = 0.1 * np.cos(np.arange(70))[:, None]
    eps = np.r_[np.full(50, 0.1), np.full(20, 0.3)]
    args = dict(parameters={"eps": eps}, h=0.05, n_steps=500, save_every=10, threads=2)
    args.update(kwargs)
    return raydamp.integrate_ensemble(DampedPendulum(), q0, p0, **args)


@pytest.mark.parametrize("method", ["3s", "2s"])
def test_vector_sine_agrees_to_rounding_and_does_not_depend_on_the_cut(method):
    fast = vector_sine_ensemble(method=method, vector_sine=True)
    default = vector_sine_ensemble(method=method)
    assert fast.success and fast.vector_sine and not default.vector_sine
    # raydamp's sine is within 1 ulp of libm's: rounding differences only (measured 8e-16 here)...
    assert np.max(np.abs(fast.q - default.q)) <= 1e-12 and np.max(np.abs(fast.p - default.p)) <= 1e-12
    # ... but differences: with the flag ignored, the two would be equal
    assert not np.array_equal(fast.q, default.q)
    # A member's numbers do not depend on the threads or on which members share its run.
    assert np.array_equal(vector_sine_ensemble(method=method, vector_sine=True, threads=1).q, fast.q)
    alone = raydamp.integrate_ensemble(DampedPendulum(0.3), fast.q0[[57]], fast.p0[[57]], method=method, h=0.05,
                                       n_steps=500, save_every=10, vector_sine=True)
    assert np.array_equal(alone.q[0], fast.q[57]) and np.array_equal(alone.p[0], fast.p[57])
    assert fast.provenance["ensemble"]["vector_sine"] is True and "vector_sine" not in default.provenance["ensemble"]


def test_vector_sine_refused_where_it_does_not_apply():
    with pytest.raises(ValueError, match="vector_sine: only the damped pendulum"):
        raydamp.integrate_ensemble(ElasticPendulum(), [ELASTIC_Q0], [ELASTIC_P0], h=0.1, n_steps=3, vector_sine=True)
    with pytest.raises(ValueError, match="vector_sine: only the damped pendulum"):
        raydamp.integrate_ensemble(DampedPendulum(), [[1.0]], [0.0], method="rks", h=0.1, n_steps=3,
                                   vector_sine=True)
    with pytest.raises(ValueError, match="vector_sine must be True or False"):
        raydamp.integrate_ensemble(DampedPendulum(), [[1.0]], [0.0], h=0.1, n_steps=3, vector_sine=1)


def test_vector_sine_cancelled_members_keep_their_own_rows():
    token = raydamp.CancelToken()
    token.cancel()
    ens = raydamp.integrate_ensemble(DampedPendulum(), np.ones((40, 1)), [0.0], h=0.1, n_steps=10**6,
                                     save_every=10**6, cancel=token, vector_sine=True)
    assert ens.status == ("cancelled",) * 40 and (ens.steps == 0).all() and (ens.rows == 1).all()


@pytest.mark.parametrize("suffix", [".nc", ".zarr"])
def test_vector_sine_survives_a_file_round_trip(tmp_path, suffix):
    ens = vector_sine_ensemble(vector_sine=True, n_steps=20)
    ens.save(tmp_path / f"e{suffix}")
    back = raydamp.load(tmp_path / f"e{suffix}")
    assert back.vector_sine and back.provenance == ens.provenance


def small_ensemble() -> raydamp.EnsembleSolution:
    q0 = np.array(ELASTIC_Q0) + np.linspace(0.0, 0.2, 5)[:, None]
    return raydamp.integrate_ensemble(ElasticPendulum(), q0, ELASTIC_P0, parameters={"eps": np.linspace(0, 0.4, 5)},
                                      h=0.1, t_end=1.05, save_every=4)


def test_to_xarray_dims_coords_and_attrs():
    ens = small_ensemble()
    ds = ens.to_xarray()
    assert ds["q"].dims == ("member", "time", "dof") and ds["q"].shape == (5, ens.t.size, 3)
    assert ds["momentum"].dims == ("member", "time", "momentum_map")
    assert list(ds["dof"].values) == ["x", "y", "z"] and list(ds["momentum_map"].values) == ["J3"]
    assert ds["eps"].dims == ("member",) and np.array_equal(ds["eps"].values, np.linspace(0, 0.4, 5))
    assert np.array_equal(ds["t"].values, ens.t) and ds["t"].values[-1] == pytest.approx(1.05)
    assert ds.attrs["method"] == "3s" and ds.attrs["h"] == 0.1
    assert ds.attrs["raydamp_version"] == raydamp.__version__
    assert '"elastic_pendulum"' in ds.attrs["provenance"]
    # a member picked by its swept parameter
    picked = np.flatnonzero(ds["eps"].values == ens.parameters["eps"][2])
    assert picked.tolist() == [2] and np.array_equal(ds["q"].isel(member=2).values, ens.q[2])


@pytest.mark.parametrize("suffix", [".nc", ".zarr"])
def test_file_round_trip_keeps_provenance(tmp_path, suffix):
    ens = small_ensemble()
    path = tmp_path / f"ensemble{suffix}"
    ens.save(path)
    back = raydamp.load(path)
    assert isinstance(back, raydamp.EnsembleSolution)
    for name in ("t", "q", "p", "energy", "momentum", "rows", "t_final", "q_final", "steps", "q0", "p0"):
        assert np.array_equal(getattr(back, name), getattr(ens, name), equal_nan=True), name
    assert back.status == ens.status and back.message == ens.message
    assert np.array_equal(back.parameters["eps"], ens.parameters["eps"])
    assert back.provenance == ens.provenance
    # a loaded member's provenance runs again to the same numbers
    model, q0, p0, options = job_arguments(back.member(3).provenance)
    assert same(back.member(3), raydamp.integrate(model, q0, p0, **options))


@pytest.mark.parametrize("kind", ["built-in", "system"])
@pytest.mark.parametrize("suffix", [".nc", ".zarr"])
def test_provenance_records_each_members_eps_and_runs_again(tmp_path, kind, suffix):
    # Issue 28, point 5: the provenance once recorded the base model's eps (0.01 here) and only the
    # name of the varied parameter, so the file did not say which eps each member ran with.
    from raydamp.jobs import model_from_spec

    eps = np.array([0.0, 0.05, 0.3])
    base = DampedPendulum(eps=0.01) if kind == "built-in" else systems.damped_pendulum(0.01)
    ens = raydamp.integrate_ensemble(base, [[1.0], [2.0], [3.0]], [0.0], parameters={"eps": eps}, h=0.1,
                                     n_steps=50, save_every=10)
    spec = ens.provenance
    assert spec["ensemble"]["parameters"] == {"eps": [0.0, 0.05, 0.3]}
    # The base is member 0 as it ran, not a model no member was.
    assert (spec["parameters"]["eps"] if kind == "built-in" else spec["system"]["eps"]) == 0.0
    ens.save(tmp_path / f"ensemble{suffix}")
    back = raydamp.load(tmp_path / f"ensemble{suffix}")
    assert back.provenance == spec
    # Run again from the loaded provenance and initial states alone: the same numbers, bit for bit.
    spec = back.provenance
    model = model_from_spec({k: spec[k] for k in ("model", "parameters", "system") if k in spec})
    again = raydamp.integrate_ensemble(model, back.q0, back.p0, parameters=spec["ensemble"]["parameters"],
                                       method=spec["method"], h=spec["h"], n_steps=spec["n_steps"],
                                       save_every=spec["save_every"])
    for name in ("q", "p", "energy", "steps"):
        assert np.array_equal(getattr(again, name), getattr(ens, name)), name
    assert np.array_equal(again.parameters["eps"], eps)
