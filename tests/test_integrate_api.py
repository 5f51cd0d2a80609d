"""raydamp.integrate as a user meets it: arguments, errors, saving, progress, cancellation, threads."""

from __future__ import annotations

import math
import threading
from pathlib import Path

import numpy as np
import pytest
import tomllib
from paper import ELASTIC_P0, ELASTIC_Q0, PENDULUM_P0, PENDULUM_Q0, paper_problem

import raydamp
from raydamp.models import DampedPendulum, ElasticPendulum


def pendulum_run(**kwargs):
    args = dict(h=0.1, n_steps=10)
    args.update(kwargs)
    return raydamp.integrate(DampedPendulum(), PENDULUM_Q0, PENDULUM_P0, **args)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"h": 0.0}, "h must be > 0"),
    ({"h": -0.1}, "h must be > 0"),
    ({"h": math.nan}, "h must be finite"),
    ({"h": math.inf}, "h must be finite"),
    ({"h": "0.1"}, "h must be a real number"),
    ({"method": "leapfrog"}, "method: unknown method 'leapfrog'"),
    ({"method": "rks", "tableau": "dopri5"}, "tableau: unknown tableau 'dopri5'"),
    ({"method": "3s", "tableau": "heun"}, "tableau: method '3s' has no Runge-Kutta stage"),
    ({"method": "rksb", "tableau": "midpoint"}, "tableau: method 'rksb' needs an explicit tableau"),
    ({"method": "sv"}, "method: 'sv' ignores damping"),
    ({"save_every": 0}, "save_every must be >= 1"),
    ({"save_every": 1.5}, "save_every must be an integer"),
    ({"n_steps": None}, "give exactly one of t_end and n_steps"),
    ({"t_end": 1.0}, "give exactly one of t_end and n_steps"),
    ({"n_steps": 0}, "n_steps must be >= 1"),
    ({"n_steps": None, "t_end": -1.0}, "t_end must be > 0"),
    ({"progress": 3}, "progress must be callable"),
    ({"cancel": threading.Event()}, "cancel must be a raydamp.CancelToken"),
    ({"n_steps": 10**12}, "save_every: .* GiB"),
    ({"save_every": 10**20}, "save_every must be <= "),
    ({"n_steps": 2**63}, "n_steps must be <= "),
    ({"n_steps": None, "t_end": 1e300, "h": 1e-300}, "t_end: reaching t_end"),
    # Accepted before: t ran to inf and the run said "completed".
    ({"n_steps": 3, "h": 1e308}, "h: 3 steps of h = 1e[+]308 end beyond the largest float"),
    # The core reads an empty list as "every coordinate": the run saved them all, dofs said none, and
    # Solution.save failed on the mismatch.
    ({"save_dofs": []}, "save_dofs: an empty list saves no coordinate"),
    ({"save_dofs": np.array(0)}, "save_dofs must be a list of coordinate indices"),  # was a TypeError
    ({"save_dofs": {0}}, "save_dofs must be a list of coordinate indices"),  # a set has no order to keep
])
def test_bad_arguments_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        pendulum_run(**kwargs)


@pytest.mark.parametrize(("q0", "p0", "message"), [
    ([0.0, 1.0], PENDULUM_P0, "q0 must have length 1"),
    (PENDULUM_Q0, [[0.0]], "p0 must have length 1"),
    ([math.nan], PENDULUM_P0, "q0 must be finite"),
    (PENDULUM_Q0, [math.inf], "p0 must be finite"),
    (["a"], PENDULUM_P0, "q0 must be an array"),
])
def test_bad_initial_state_is_named(q0, p0, message):
    with pytest.raises(ValueError, match=message):
        raydamp.integrate(DampedPendulum(), q0, p0, h=0.1, n_steps=10)


def test_elastic_pendulum_refuses_the_origin():
    with pytest.raises(ValueError, match="q0 must not be the origin"):
        raydamp.integrate(ElasticPendulum(), [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], h=0.1, n_steps=10)


def test_steps_for():
    assert raydamp.steps_for(200.0, 0.2) == (1000, 0.2)
    n, last = raydamp.steps_for(1.0, 0.3)
    assert n == 4 and last == pytest.approx(0.1)
    # A step far longer than the span is one short step, never zero steps.
    assert raydamp.steps_for(1e-300, 1e300) == (1, 1e-300)
    with pytest.raises(ValueError, match="t_end must be > 0"):
        raydamp.steps_for(0.0, 0.1)


def test_model_argument_must_be_a_model():
    with pytest.raises(ValueError, match="model must be a raydamp model"):
        raydamp.integrate("damped_pendulum", PENDULUM_Q0, PENDULUM_P0, h=0.1, n_steps=10)


def test_saving_shapes_and_final_row():
    sol = raydamp.integrate(ElasticPendulum(), ELASTIC_Q0, ELASTIC_P0, h=0.1, n_steps=10, save_every=3)
    np.testing.assert_allclose(sol.t, [0.0, 0.3, 0.6, 0.9, 1.0], atol=1e-15)
    assert sol.q.shape == sol.p.shape == (5, 3)
    assert sol.energy.shape == (5,) and sol.momentum.shape == (5, 1)
    assert sol.steps == 10 and sol.status == "completed" and sol.success
    pend = pendulum_run()
    assert pend.momentum.shape == (11, 0)  # no symmetry: empty momentum
    assert pend.summary()["momentum_drift"] is None


def test_t_end_not_a_multiple_of_h_lands_on_t_end():
    sol = pendulum_run(n_steps=None, t_end=1.0, h=0.3)
    assert sol.steps == 4 and sol.t[-1] == 1.0
    exact = pendulum_run(n_steps=None, t_end=200.0, h=0.2)
    assert exact.steps == 1000 and exact.t[-1] == pytest.approx(200.0, abs=1e-12)


def test_energy_and_summary_are_consistent():
    model, q0, p0 = paper_problem("damped_pendulum", 0.01)
    sol = raydamp.integrate(model, q0, p0, h=0.2, t_end=200.0, save_every=50)
    assert sol.energy[0] == pytest.approx(1 - math.cos(0.9 * math.pi), rel=1e-15)
    for k in (0, 5, -1):
        assert sol.energy[k] == pytest.approx(model.energy(sol.q[k], sol.p[k]), rel=1e-15)
    s = sol.summary()
    assert s["energy_dissipated"] == pytest.approx(s["energy_initial"] - s["energy_final"], rel=1e-14)
    assert s["mean_dissipation_rate"] == pytest.approx(s["energy_dissipated"] / 200.0, rel=1e-12)
    assert s["steps"] == 1000 and s["status"] == "completed"
    # Dissipation is physical: energy falls, and by much more than one step's error.
    assert 0.5 < s["energy_dissipated"] < s["energy_initial"]


def test_energy_dissipated_under_a_load_is_the_damping_work(tmp_path):
    """Under a load H(0) - H(t) mixes the load's work with the damping's (it was -1.5 on the page beside a damping
    work of 616,012): a driven run's energy_dissipated is the damping work W(t_final), nan (null in the summary)
    without work=True; a free run keeps H(0) - H(t_final), which there is W to the method's error."""
    model = raydamp.LinearStructure(np.array([[2.0]]), np.array([[3.0]]), alpha=0.125)
    force = raydamp.Load.harmonic([0.7], 1.4)
    sol = raydamp.integrate(model, [0.0], [0.0], method="gauss4", h=0.01, t_end=100, load=force, work=True)
    assert sol.energy_dissipated == sol.work[-1] and sol.work[-1] > 1.0  # W grows with each forced period
    assert sol.initial_energy - sol.final_energy < 0  # the load put energy in: the old figure's sign
    s = sol.summary()
    assert s["energy_dissipated"] == s["work_final"] and s["mean_dissipation_rate"] == pytest.approx(
        s["work_final"] / 100.0, rel=1e-12)
    unrecorded = raydamp.integrate(model, [0.0], [0.0], method="gauss4", h=0.01, t_end=100, load=force)
    assert math.isnan(unrecorded.energy_dissipated) and unrecorded.summary()["energy_dissipated"] is None
    assert unrecorded.summary()["mean_dissipation_rate"] is None
    sol.save(tmp_path / "forced.npz")  # read back, the run knows its load from the provenance
    assert raydamp.load(tmp_path / "forced.npz").energy_dissipated == sol.work[-1]
    # At a temperature the noise puts energy in too (here H(0) - H(t) = -1.48 beside W = 18.1).
    hot = raydamp.integrate(DampedPendulum(eps=0.5), [0.5], [0.0], method="baoab", h=0.05, t_end=50, temperature=0.5,
                            seed=1, work=True)
    assert hot.energy_dissipated == hot.work[-1] > 1.0 and hot.initial_energy - hot.final_energy < 0
    free = raydamp.integrate(model, [1.0], [0.0], method="gauss4", h=0.01, t_end=100, work=True)
    assert free.energy_dissipated == free.initial_energy - free.final_energy
    assert free.energy_dissipated == pytest.approx(free.work[-1], rel=1e-9)  # gauss4 balances energy exactly


def test_progress_is_called_a_bounded_number_of_times():
    calls = []
    pendulum_run(n_steps=1_000_000, save_every=10**6, progress=lambda done, total: calls.append((done, total)))
    assert 50 <= len(calls) <= 102
    assert calls[-1] == (1_000_000, 1_000_000)
    assert all(a[0] < b[0] for a, b in zip(calls, calls[1:]))


def test_progress_true_draws_a_bar_as_sweep_does(capsys):
    """integrate(progress=True) was refused ("progress must be callable") while sweep(progress=True) drew a bar:
    it draws a tqdm bar over the steps (on stderr), ends at the run's step count, and the run is the one without
    it, bit for bit. progress=False is none."""
    plain = pendulum_run(n_steps=20_000, save_every=1000)
    barred = pendulum_run(n_steps=20_000, save_every=1000, progress=True)
    np.testing.assert_array_equal(barred.q, plain.q)
    err = capsys.readouterr().err
    assert "integrate" in err and "20000/20000" in err, err[-300:]
    pendulum_run(n_steps=100, progress=False)
    assert capsys.readouterr().err == ""


def test_progress_exception_propagates():
    def boom(done, total):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        pendulum_run(n_steps=100_000, progress=boom)


def test_cancel_from_another_thread_keeps_the_points_so_far():
    token = raydamp.CancelToken()
    seen = threading.Event()

    def progress(done, total):
        seen.set()

    canceller = threading.Thread(target=lambda: (seen.wait(30), token.cancel()))
    canceller.start()
    sol = pendulum_run(n_steps=500_000_000, save_every=100_000, progress=progress, cancel=token)
    canceller.join()
    assert sol.status == "cancelled" and token.cancelled
    assert 0 < sol.steps < 500_000_000
    assert sol.t[-1] == pytest.approx(sol.steps * 0.1)
    assert np.all(np.isfinite(sol.q))


def test_loop_releases_the_gil():
    # Another Python thread keeps running while a long integration is under way.
    counter = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            counter[0] += 1

    started = []
    worker = threading.Thread(target=spin)
    worker.start()
    pendulum_run(n_steps=20_000_000, save_every=10**7,
                 progress=lambda done, total: started.append(counter[0]))
    stop.set()
    worker.join()
    # Between the first and last progress call the spinning thread advanced a lot.
    assert started[-1] - started[0] > 1000


def test_methods_catalogue():
    rows = raydamp.methods()
    names = {m.name for m in rows}
    # midpoint and gauss4: LinearStructure only (tests/test_implicit_structure.py)
    assert names == {"sv", "3s", "baoab", "2s", "rks", "rksb", "heun", "rk4", "rk", "midpoint", "gauss4"}
    by_key = {(m.name, m.tableau): m for m in rows}
    # rk: any explicit tableau on the whole system (rk4 by default); never an implicit one.
    assert {m.tableau for m in rows if m.name == "rk"} == {"euler", "heun", "rk4"}
    assert by_key[("rk", "rk4")].default and by_key[("rk", "rk4")].order == 4
    assert by_key[("rks", "midpoint")].explicit is False
    assert by_key[("rks", "heun")].default and by_key[("rks", "heun")].order == 2
    assert by_key[("rk4", "rk4")].order == 4
    assert by_key[("sv", None)].damped is False
    assert {t.name: t.order for t in raydamp.tableaux()} == {"euler": 1, "heun": 2, "midpoint": 2, "rk4": 4}


def test_version_comes_from_the_build():
    pyproject = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    assert raydamp.__version__ == pyproject["project"]["version"]


@pytest.mark.parametrize("method", ["3s", "2s", "rks"])
def test_shortened_last_step_uses_its_own_damping_factors(method):
    # The exact damping flows cache exp/phi1 per sub-step length; the short last step
    # must not reuse the full step's factors.
    model = ElasticPendulum(0.3)
    full = raydamp.integrate(model, ELASTIC_Q0, ELASTIC_P0, method=method, h=0.3, t_end=1.0)
    assert full.steps == 4 and full.t[-1] == 1.0
    three = raydamp.integrate(model, ELASTIC_Q0, ELASTIC_P0, method=method, h=0.3, n_steps=3)
    last = raydamp.integrate(model, three.q[-1], three.p[-1], method=method, h=1.0 - 3 * 0.3, n_steps=1)
    np.testing.assert_array_equal(full.q[-1], last.q[-1])
    np.testing.assert_array_equal(full.p[-1], last.p[-1])


def test_each_model_kind_binds_its_own_integrate():
    # A regression test: integrate and integrate_ensemble were overloads of one _core
    # function, and pybind11 3 raises and clears an AttributeError for every kind a call
    # does not match; that was 20 of the 25 us of a 10-step call (bench_steps.py shows
    # the time). Each kind's class now has one function of each, with no overloads.
    from raydamp import _core

    assert not hasattr(_core, "integrate") and not hasattr(_core, "integrate_ensemble")
    kinds = [c for c in vars(_core).values() if isinstance(c, type) and hasattr(c, "integrate")]
    assert len(kinds) >= 10, [k.__name__ for k in kinds]
    for kind in kinds:
        for name in ("integrate", "integrate_ensemble"):
            doc = getattr(kind, name).__doc__
            assert doc.count(f"{name}(") == 1, f"{kind.__name__}.{name} is overloaded:\n{doc}"
    for model in (DampedPendulum(), ElasticPendulum()):
        assert type(model._core_model) in kinds


def test_the_summary_is_the_job_summary_schema_the_service_describes():
    """Solution.summary() is built by raydamp.jobs.JobSummary, the one definition the service's job views and
    OpenAPI document use: every key is a field and every field a key, and a value without a field is refused
    where it is built, so a new summary value is added in one place. Read back, a summary stored by another
    version validates: a key this version does not know is dropped (a service rolled back, or a field removed:
    step_size after its release), not a failed job view."""
    from raydamp.jobs import JobSummary
    from raydamp.jobs.summary import summary_values

    model, q0, p0 = paper_problem("damped_pendulum", 0.01)
    s = raydamp.integrate(model, q0, p0, h=0.2, n_steps=10, work=True).summary()
    assert list(s) == list(JobSummary.model_fields)
    assert s["work_final"] is not None and s["energy_balance_max"] is not None
    assert JobSummary.model_validate(s).model_dump() == s
    with pytest.raises(ValueError, match="extra"):
        summary_values(**s, energy_drift=0.0)  # a value no field declares
    assert JobSummary.model_validate({**s, "energy_drift": 0.0}).model_dump() == s


@pytest.mark.parametrize(("work", "load", "save_dofs"), [
    (False, None, None), (True, None, None), (True, "harmonic", None), (False, "harmonic", [2, 0]),
    (True, "empty", [1]), (True, "harmonic", [1, 2, 0])])
def test_row_bytes_counts_the_arrays_a_run_saves(work, load, save_dofs):
    """raydamp.run.integrate.row_bytes (the service bounds a job's stored trajectory by it) is the float64s of
    one saved point as the Solution holds them: W only with work, W_f only with work and a load that has
    terms (a load without terms records none)."""
    from raydamp.run.integrate import row_bytes

    forcing = {None: None, "empty": raydamp.Load(), "harmonic": raydamp.Load.harmonic([0.1, 0.0, 0.2], 1.3)}[load]
    model = ElasticPendulum()
    sol = raydamp.integrate(model, ELASTIC_Q0, ELASTIC_P0, h=0.1, n_steps=7, work=work, load=forcing,
                            save_dofs=save_dofs)
    arrays = [sol.t, sol.energy, sol.q, sol.p, sol.momentum, sol.work, sol.load_work]
    per_point = sum(a.size for a in arrays if a is not None) // sol.t.size
    assert row_bytes(model, save_dofs, work=work, load=forcing) == 8 * per_point
    assert (sol.load_work is not None) == (work and load == "harmonic")


def test_a_models_facts_are_not_read_for_another_model_at_its_address():
    """integrate caches a model's dimension by id(model) with a weak reference: a model made where a collected
    one lived (ids are reused at once in CPython) must not run with the old one's dimension."""
    for _ in range(20):
        pendulum = DampedPendulum(eps=0.1)
        assert raydamp.integrate(pendulum, [1.0], [0.0], method="3s", h=0.1, n_steps=2).q.shape == (3, 1)
        del pendulum
        elastic = ElasticPendulum()
        assert raydamp.integrate(elastic, ELASTIC_Q0, ELASTIC_P0, method="3s", h=0.1, n_steps=2).q.shape == (3, 3)
        del elastic


@pytest.mark.parametrize("given", ["list", "array", "int array", "0-d array"])
def test_the_provenance_keeps_the_start_as_it_was_at_the_call(given):
    """The Solution keeps the run's own copy of q0 and p0: changing the caller's array afterwards changes neither
    the provenance nor a rerun."""
    make = {"list": lambda: [1.0], "array": lambda: np.array([1.0]), "int array": lambda: np.array([1]),
            "0-d array": lambda: np.array(1.0)}[given]
    q0, p0 = make(), make()
    sol = raydamp.integrate(DampedPendulum(eps=0.1), q0, p0, method="3s", h=0.1, n_steps=2)
    for start in (q0, p0):
        if given == "list":
            start[0] = 5.0
        else:
            start[...] = 5
    assert sol.provenance["initial_state"] == {"q": [1.0], "p": [1.0]}


def test_a_solution_from_integrate_has_every_field():
    """integrate fills a Solution's fields without its __init__ (a short call's cost): every field is there, with
    the value the dataclass would hold."""
    import dataclasses

    sol = raydamp.integrate(DampedPendulum(eps=0.1), [1.0], [0.0], method="3s", h=0.1, n_steps=2)
    rebuilt = raydamp.Solution(**{f.name: getattr(sol, f.name) for f in dataclasses.fields(raydamp.Solution)})
    for f in dataclasses.fields(raydamp.Solution):
        ours, theirs = getattr(sol, f.name), getattr(rebuilt, f.name)
        assert type(ours) is type(theirs), f.name
        if isinstance(ours, np.ndarray):
            np.testing.assert_array_equal(ours, theirs)
    assert sol.status == "completed" and sol.work is None and sol.dofs is None and sol.wall_time > 0
