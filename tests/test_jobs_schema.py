"""raydamp.jobs: one definition of the job JSON, with h its step size (step_size accepted for one
release), errors at the JSON path the client wrote, and a provenance that runs again."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

import raydamp
from raydamp.jobs import JobError, JobSpec, SweepSpec, client_path, job_arguments, parse_job
from raydamp.models import DampedPendulum

JOB = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.1, "n_steps": 20,
       "initial_state": {"q": [1.0], "p": [0.0]}}


def test_h_and_its_former_name_give_the_same_run():
    by_h = job_arguments(JOB)
    old = {**{k: v for k, v in JOB.items() if k != "h"}, "step_size": 0.1}
    assert job_arguments(old)[3] == by_h[3] and by_h[3]["h"] == 0.1
    assert parse_job(old).h_key == "step_size" and parse_job(JOB).h_key == "h"


@pytest.mark.parametrize(("change", "loc", "message"), [
    ({"h": -1.0}, ("h",), "h: Input should be greater than 0"),
    ({"h": None, "step_size": -1.0}, ("step_size",), "step_size: Input should be greater than 0"),
    ({"step_size": 0.1}, ("step_size",), "step_size: unknown key"),  # both names: the second is extra
    ({"h": None}, ("h",), "h: missing"),
    ({"method": "leapfrog"}, ("method",), "method: unknown method 'leapfrog'"),
    ({"method": "rk", "tableau": {"A": [[0, 0], ["1", 0]], "b": [0.5, 0.5], "c": [0, 1]}}, ("tableau", "A", 1, 0),
     "tableau.A[1][0]: Input should be a valid number"),
    ({"initial_state": {"q": [1.0, 2.0], "p": [0.0]}}, ("initial_state", "q"), "initial_state.q has length 2"),
    ({"parameters": {"eps": -1.0}}, ("parameters", "eps"), "parameters.eps must be >= 0"),
    ({"n_steps": None}, ("t_end",), "t_end: give exactly one of t_end and n_steps"),
])
def test_errors_name_the_path_the_client_wrote(change, loc, message):
    job = {k: v for k, v in {**JOB, **change}.items() if v is not None}
    with pytest.raises(JobError) as caught:
        job_arguments(job)
    assert caught.value.loc == loc and str(caught.value).startswith(message), str(caught.value)


def test_a_solutions_provenance_is_a_job_and_runs_again():
    sol = raydamp.integrate(DampedPendulum(eps=0.01), [1.0], [0.0], method="3s", h=0.1, n_steps=20)
    assert sol.provenance["h"] == 0.1 and "step_size" not in sol.provenance
    model, q0, p0, options = job_arguments(sol.provenance)
    again = raydamp.integrate(model, q0, p0, **options)
    np.testing.assert_array_equal(again.q, sol.q)
    assert sol.summary()["h"] == sol.summary()["step_size"] == 0.1


def test_form_tags_are_not_in_a_path():
    assert client_path(("system", "linear_structure", "K", "coo form", "coo", "rows", 2)) == (
        "system", "K", "coo", "rows", 2)
    assert client_path(("grid", "eps", "range", "num")) == ("grid", "eps", "num")
    assert client_path(("initial_state", "q, p form", "q", 0)) == ("initial_state", "q", 0)
    # a path of ours keeps every part, even one that names a form's key
    assert client_path(("system", "damping", "dampers", 0, "on")) == ("system", "damping", "dampers", 0, "on")
    assert client_path(("initial_state", "mode")) == ("initial_state", "mode")


def test_a_sweeps_job_does_not_record_work_unless_asked_and_then_refuses():
    sweep = SweepSpec.model_validate({"job": JOB, "grid": {"step_size": [0.1, 0.2]}})
    assert "work" not in sweep.job_form() and sweep.job.work is False
    assert SweepSpec.model_validate(sweep.model_dump(mode="json")).job_form() == sweep.job_form()
    asked = SweepSpec.model_validate({"job": {**JOB, "work": True}, "grid": {"eps": [0.1]}})
    with pytest.raises(JobError, match="^job.work: sweeps do not record") as caught:
        asked.job_form()
    assert caught.value.loc == ("job", "work")


def test_the_service_takes_the_librarys_schema():
    schemas = pytest.importorskip("raydamp_service.schemas")
    assert schemas.JobSpec is JobSpec and schemas.SweepSpec is SweepSpec


def _structure_job(rows):
    n = len(rows)
    return {"system": {"kind": "linear_structure", "M": {"diagonal": [1.0] * 4},
                       "K": {"coo": {"shape": [4, 4], "rows": rows, "cols": [0] * n, "values": [1.0] * n}}},
            "method": "3s", "h": 0.1, "n_steps": 10, "initial_state": {"rest": True}}


@pytest.mark.parametrize("bad", [-1, "x", True, 1.5])
def test_many_bad_items_are_one_error_naming_the_first_twenty(bad):
    """Issue 27, F2: 666k bad COO indices were validated into 666k error objects (10 s, 1.7 GB)."""
    rows = [0] * 5 + [bad] * 200_000
    with pytest.raises(ValidationError) as caught:
        JobSpec.model_validate(_structure_job(rows))
    errors = caught.value.errors()
    assert len(errors) == 1 and client_path(errors[0]["loc"]) == ("system", "K", "coo", "rows")
    assert errors[0]["msg"].endswith("items 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, "
                                     "24 and more are not integers >= 0")


def test_a_few_bad_items_are_named_each_at_its_path():
    rows = [0] * 5000
    rows[7], rows[4000] = -1, "x"
    with pytest.raises(ValidationError) as caught:
        JobSpec.model_validate(_structure_job(rows))
    assert sorted(client_path(e["loc"]) for e in caught.value.errors()) == [
        ("system", "K", "coo", "rows", 7), ("system", "K", "coo", "rows", 4000)]


@pytest.mark.parametrize(("system", "path", "words"), [
    ({"coordinates": ["x", "y"], "potential": "x^2", "mass": "1 + x^2"}, ("system", "mass"),
     "must be constant: a mass matrix that depends on q"),
    ({"coordinates": ["x", "y"], "potential": "x^2", "mass": [[1.0, "x"], [0.0, 1.0]]}, ("system", "mass"),
     "must be constant"),
    ({"coordinates": ["x", "y"], "potential": "x^2", "damping": {"scalar": "x" * 20_000}},
     ("system", "damping", "scalar"), "valid number"),
    ({"coordinates": ["x" * 200, "y"], "potential": "x^2"}, ("system", "coordinates", 0), "at most 100 characters"),
    ({"kind": "chain", "n": 4, "bond": "expression", "parameters": {"potential": "r" * 20_000}},
     ("system", "parameters", "potential"), "at most 10000 characters"),
])
def test_one_error_at_the_path_the_client_wrote(system, path, words):
    """Issue 27, point 5: a configuration-dependent mass is one error with the library's explanation (it was
    seven "Input should be a valid number"), and an over-long string is named by its own path (not
    damping.ScalarDamping.scalar, parameters.potential.float or coordinates.list[constrained-str])."""
    with pytest.raises(ValidationError) as caught:
        JobSpec.model_validate({**JOB, "model": None, "parameters": {}, "system": system,
                                "initial_state": {"q": [1.0, 0.0], "p": [0.0, 0.0]}})
    errors = caught.value.errors()
    assert len(errors) == 1 and client_path(errors[0]["loc"]) == path and words in errors[0]["msg"], errors


@pytest.mark.parametrize("axis", ["h", "step_size"])
def test_a_sweep_refuses_a_step_whose_times_overflow_as_a_job_does(axis):
    """Issue 27, point 5: a sweep accepted h = 1e308 over 1000 steps."""
    spec = {"model": "damped_pendulum", "q0": [1.0], "p0": [0.0], "method": "3s", "h": 0.1, "n_steps": 1000}
    with pytest.raises(ValueError, match=rf"^grid\.{axis}: 1000 steps of 1e\+308 end beyond the largest float"):
        raydamp.check_sweep(spec, {axis: [0.1, 1e308]})
    assert raydamp.check_sweep(spec, {axis: [0.1, 0.2]}).members == 2


def test_an_initial_state_from_uploaded_vectors():
    """{"file": id} in place of q or p: resolved by the files the caller gives (a service's uploads), refused
    at initial_state.q.file without them; the tag of the form never shows in a path."""
    from raydamp.jobs import build_job

    base = {"model": "damped_pendulum", "method": "3s", "h": 0.1, "n_steps": 2}
    spec = parse_job({**base, "initial_state": {"q": {"file": "a" * 32}, "p": [0.0]}})
    call = build_job(spec, lambda file_id: (None, np.array([0.5])))
    assert list(call.q0) == [0.5] and call.p0 == [0.0]
    with pytest.raises(JobError, match=r"^initial_state\.q\.file: uploaded files are a service's") as error:
        build_job(spec)
    assert error.value.loc == ("initial_state", "q", "file")
    with pytest.raises(JobError, match=r"^initial_state\.p\.file: String should match pattern") as error:
        parse_job({**base, "initial_state": {"q": [0.0], "p": {"file": "x"}}})
    assert error.value.loc == ("initial_state", "p", "file")


@pytest.mark.parametrize("system", [{"kind": "kepler"}, {"kind": "kepler", "dim": 3, "particles": 2}])
def test_every_system_kind_answers_its_files(system):
    """A Kepler job whose start is uploaded was a 500 in the service (KeplerInput had no files(); found by the
    fuzz test): each kind answers which files it reads, and the start's files are the job's."""
    spec = parse_job({"system": system, "h": 0.1, "t_end": 1.0,
                      "initial_state": {"q": {"file": "a" * 32}, "p": {"file": "b" * 32}}})
    assert spec.uploads() == ("a" * 32, "b" * 32)
    assert list(spec.system.files(("system",))) == [] and list(spec.sizes()) == [] and not spec.compiles()
