"""raydamp.check_sweep's checks, in process (no cluster): a grid's size is bounded from its axes' lengths
before anything is built, every value of every axis runs a step before anything is sent, bools are not
numbers, and a message's axis is the key the client wrote (one part of the path, dots and all)."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest

import raydamp
from raydamp.jobs import SweepSpec
from raydamp.run import sweep as sweep_module
from raydamp.run.sweep import GridTooLarge

SPEC = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "q0": [0.9 * math.pi], "p0": [0.0],
        "method": "3s", "h": 0.1, "t_end": 2.0, "save_every": 4}
JOB = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.1, "n_steps": 20,
       "initial_state": {"q": [1.0], "p": [0.0]}, "work": False}
HUGE = [  # 10^8 members each: the audit's grids that made the service build gigabytes before refusing them
    {"eps": [0.1] * 10_000, "h": [0.1] * 10_000},
    {"eps": {"start": 0.0, "stop": 1.0, "num": 10_000}, "q0[0]": {"start": 0.0, "stop": 1.0, "num": 10_000}},
]


def peak_bytes(call) -> int:
    """The peak of what ``call()`` allocates (numpy's arrays included: numpy reports them to tracemalloc)."""
    tracemalloc.start()
    try:
        call()
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak


@pytest.mark.parametrize("grid", HUGE)
def test_a_huge_grid_is_refused_from_its_axes_lengths_before_anything_is_built(grid):
    """Audit, serious: check_sweep built the whole grid (np.tile of q0 per member, a tuple per member ...)
    before anyone could compare its size with a bound; 10^8 members grew a server by 220 MB/s past 10 GB."""
    def bounded():
        with pytest.raises(GridTooLarge, match=r"^grid: 100000000 members \(the product of the axes' lengths\); "
                                               r"at most max_members = 5000$") as caught:
            raydamp.check_sweep(SPEC, grid, max_members=5000)
        assert caught.value.members == 10**8 and isinstance(caught.value, ValueError)

    def unbounded():  # the library's own bound: the members' initial states alone would pass its memory guard
        with pytest.raises(ValueError, match=r"^grid: 100000000 members \(the product of the axes' lengths\) "
                                             r"would take 6\.0 GiB for their initial states"):
            raydamp.check_sweep(SPEC, grid)

    assert peak_bytes(bounded) < 50 * 2**20
    assert peak_bytes(unbounded) < 50 * 2**20
    spec = SweepSpec.model_validate({"job": JOB, "grid": grid})
    with pytest.raises(ValueError, match=r"^grid: 100000000 members") as caught:
        raydamp.check_sweep(spec.job_form(), spec.grid_arguments())
    assert spec.error_at(caught.value).loc == ("grid",)


def test_a_bound_that_the_grid_meets_builds_it():
    plan = raydamp.check_sweep(SPEC, {"eps": [0.1, 0.2], "q0[0]": [0.5, 1.0, 1.5]}, max_members=6)
    assert plan.members == 6
    with pytest.raises(GridTooLarge, match=r"6 members .* at most max_members = 5$"):
        raydamp.check_sweep(SPEC, {"eps": [0.1, 0.2], "q0[0]": [0.5, 1.0, 1.5]}, max_members=5)
    with pytest.raises(ValueError, match=r"^max_members must be >= 1, got 0"):
        raydamp.check_sweep(SPEC, {"eps": [0.1]}, max_members=0)


@pytest.mark.parametrize("spec, grid, path, message", [
    (SPEC, {"eps": [0.1, -0.5]}, ("grid", "eps"),
     r"^grid\.eps\[1\] = -0\.5: parameters\.eps must be a finite number >= 0, got -0\.5$"),
    (SPEC, {"method": ["3s", "sv"]}, ("grid", "method"), r"^grid\.method\[1\] = 'sv': method: 'sv' ignores damping"),
    ({**SPEC, "composition": "yoshida4"}, {"method": ["3s", "rk4"]}, ("grid", "method"),
     r"^grid\.method\[1\] = 'rk4': composition: 'yoshida4' composes a symmetric order-2 step"),
    (SPEC, {"tableau": ["", "rk4"]}, ("grid", "tableau"),
     r"^grid\.tableau\[1\] = 'rk4': tableau: method '3s' has no Runge-Kutta stage"),
    # a later value of a parameter axis, the run axes and another axis beside it
    (SPEC, {"method": ["3s", "2s"], "q0[0]": [0.5, 1.0], "eps": [0.0, 0.1, 0.2, -1.0]}, ("grid", "eps"),
     r"^grid\.eps\[3\] = -1\.0: parameters\.eps must be a finite number >= 0"),
    # the first member itself, with one axis: that axis's first value
    (SPEC, {"eps": [-0.5, 0.1]}, ("grid", "eps"), r"^grid\.eps\[0\] = -0\.5: parameters\.eps must be"),
])
def test_every_value_of_every_axis_runs_a_step_before_anything_is_sent(spec, grid, path, message):
    """Audit: check_sweep ran one step of the first member only, so a bad later value was accepted and then
    failed its chunk on a worker, losing every member of the sweep."""
    with pytest.raises(ValueError, match=message) as caught:
        raydamp.check_sweep(spec, grid)
    job = {**JOB, "method": spec["method"], **({"composition": spec["composition"]} if "composition" in spec else {})}
    assert SweepSpec.model_validate({"job": job, "grid": grid}).error_at(caught.value).loc == path


def test_the_check_runs_a_step_per_axis_value_not_per_member(monkeypatch):
    """Every value of every axis is run (each eps, each q0[0], each method), the members being the first
    member of each group and those one axis away from the first member: their number grows with the sum
    of the axes' lengths, not with their product."""
    eps, q, methods = np.linspace(0.0, 0.5, 100), np.linspace(-1.0, 1.0, 100), ["3s", "2s", "rks"]
    seen = {"members": 0, "eps": set(), "q0": set(), "method": set()}
    original = sweep_module._run_ensemble

    def counting(model, task, run, cancel):
        seen["members"] += len(task["q0"])
        seen["eps"].update(task["parameters"]["eps"].tolist())
        seen["q0"].update(task["q0"][:, 0].tolist())
        seen["method"].add(run["method"])
        return original(model, task, run, cancel)

    monkeypatch.setattr(sweep_module, "_run_ensemble", counting)
    plan = raydamp.check_sweep(SPEC, {"method": methods, "eps": eps, "q0[0]": q})
    assert plan.members == 30_000
    assert seen["eps"] == set(eps.tolist()) and seen["q0"] == set(q.tolist()) and seen["method"] == set(methods)
    assert seen["members"] <= len(methods) + len(eps) + len(q)


@pytest.mark.parametrize("grid, message", [
    ({"h": [True]}, r"^grid\.h\[0\]: expected a real number, got the bool True$"),
    ({"eps": [0.1, False]}, r"^grid\.eps\[1\]: expected a real number, got the bool False$"),
    ({"q0[0]": np.array([True, False])}, r"^grid\.q0\[0\]: expected a list of real numbers, got an array of bools$"),
])
def test_a_bool_in_an_axis_is_not_a_number(grid, message):
    """Audit: {"h": [True]} ran with h = 1.0, where integrate refuses h=True."""
    with pytest.raises(ValueError, match=message):
        raydamp.check_sweep(SPEC, grid)


def test_an_axis_named_with_a_dot_is_one_part_of_the_path():
    """Audit: error_at split "grid.load.omega" at every dot, giving the path grid/load/omega; the client's
    key is "load.omega"."""
    spec = SweepSpec.model_validate({"job": JOB, "grid": {"load.omega": ["abc"]}})
    with pytest.raises(ValueError, match=r"^grid\.load\.omega: not a parameter of the model") as caught:
        raydamp.check_sweep(spec.job_form(), spec.grid_arguments())
    assert spec.error_at(caught.value).loc == ("grid", "load.omega")
    # a range's key stays a part of its own; a value's index is not one (a range's values have no path)
    assert spec.error_at(ValueError("grid.load.omega.num must be >= 1, got 0")).loc == ("grid", "load.omega", "num")
    assert spec.error_at(ValueError("grid.load.omega[2] = 1.0: ...")).loc == ("grid", "load.omega")
    q_axis = SweepSpec.model_validate({"job": JOB, "grid": {"q0[0]": [1.0]}})
    assert q_axis.error_at(ValueError("grid.q0[0][1] = 2.0: ...")).loc == ("grid", "q0[0]")


def test_an_axis_over_a_systems_expression_parameter_is_checked_at_64_values_ends_included(monkeypatch):
    """Each value of such an axis compiles a model (about 5 ms, as the run does): a check of every value of a
    1000-value axis took 5.5 s, past a service's check budget for a couple of thousand. 64 values after the
    first, spread with both ends, are stepped (a System's expression parameters enter its potential and
    momentum maps only, where any finite value builds a model)."""
    system = {"coordinates": ["x"], "potential": "k*x^2/2 + x^4/4", "parameters": {"k": 1.0},
              "damping": {"scalar": 1.0}, "eps": 0.1}
    spec = {**{k: v for k, v in SPEC.items() if k not in ("model", "parameters")}, "system": system}
    stepped = []
    original = sweep_module._run_ensemble

    def counting(model, task, run, cancel):
        stepped.extend(task["parameters"].get("k", np.zeros(0)).tolist())
        return original(model, task, run, cancel)

    monkeypatch.setattr(sweep_module, "_run_ensemble", counting)
    k = np.linspace(1.0, 2.0, 1000)
    assert raydamp.check_sweep(spec, {"k": k}).members == 1000
    assert len(set(stepped)) == 65 and {k[0], k[1], k[-1]} <= set(stepped)
    stepped.clear()
    raydamp.check_sweep(spec, {"k": k[:64], "eps": np.linspace(0.0, 1.0, 500)})  # eps recompiles nothing
    assert len(set(stepped)) == 64


@pytest.mark.parametrize("processes", [False, True])
def test_the_local_cluster_listens_on_loopback_only(processes):
    """raydamp's own LocalCluster (the service's, a sweep's without a client): Dask's defaults opened the
    scheduler's HTTP server on every interface (port 8787, even with dashboard_address=None), so a service
    bound to 127.0.0.1 answered Dask's pages on the machine's other addresses."""
    import psutil
    from dask.distributed import Client

    from raydamp.run.cluster import local_cluster

    def listening() -> set:  # of this process and its children (other tests' servers among them)
        me = psutil.Process()
        return {c.laddr for p in (me, *me.children(recursive=True)) for c in p.net_connections("inet")
                if c.status == psutil.CONN_LISTEN}

    before = listening()
    with local_cluster(1, processes=processes) as cluster, Client(cluster) as client:
        assert client.submit(lambda x: x + 1, 1).result() == 2
        opened = listening() - before
    assert opened and all(address.ip == "127.0.0.1" for address in opened), opened
