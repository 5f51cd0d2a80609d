"""The job JSON's "envelope" and "collapse" (issue 42): typed (a bad one names its JSON path), run as integrate's,
kept in the provenance, and shown in the summary."""

import numpy as np
import pytest
from pydantic import ValidationError

import raydamp
from raydamp.jobs import JobSpec, client_path, job_arguments
from raydamp.materials import Bilinear, ElasticPlastic


def job(**changes):
    springs = [raydamp.Spring((0,), Bilinear(100.0, 2.0, 0.05)), raydamp.Spring((0, 1), ElasticPlastic(80.0, 1.5))]
    system = raydamp.Structure(np.eye(2), springs=springs, alpha=0.3).to_dict()
    load = raydamp.Load.harmonic([30.0, 30.0], 6.0, t_end=1.5)
    return {"system": system, "method": "3s", "h": 0.01, "n_steps": 300, "work": False, "save_every": 300,
            "initial_state": {"q": [0.0, 0.0], "p": [0.0, 0.0]}, "load": load.to_dict(),
            "envelope": ["drift", "displacement", "residual_drift"], **changes}


def test_a_jobs_envelope_runs_as_integrates_and_its_summary_shows_the_peaks():
    model, q0, p0, options = job_arguments(job())
    assert options["envelope"] == ["drift", "displacement", "residual_drift"]
    sol = raydamp.integrate(model, q0, p0, **options)
    direct = raydamp.integrate(model, q0, p0, method="3s", h=0.01, n_steps=300, save_every=300,
                               load=options["load"], envelope=["drift", "displacement", "residual_drift"])
    np.testing.assert_array_equal(sol.envelope["drift"].values, direct.envelope["drift"].values)
    assert (sol.envelope["drift"].values > [0.02, 1.5 / 80.0]).all()  # both springs yielded
    summary = sol.summary()["envelope"]
    assert summary["peaks"]["drift"] == sol.envelope["drift"].values.tolist()
    assert summary["times"]["displacement"] == sol.envelope["displacement_time"].values.tolist()
    assert summary["residuals"]["residual_drift"] == sol.envelope["residual_drift"].values.tolist()
    assert summary["size"] == {"drift": 2, "displacement": 2, "residual_drift": 2}
    assert summary["collapsed_spring"] is None
    # the provenance is the job: it runs again to the same peaks
    again = raydamp.integrate(*job_arguments(sol.provenance)[:3], **job_arguments(sol.provenance)[3])
    np.testing.assert_array_equal(again.envelope["drift"].values, sol.envelope["drift"].values)


def test_a_collapse_limit_in_a_job_stops_it_and_the_summary_names_the_spring():
    model, q0, p0, options = job_arguments(job(collapse=[1.0, 0.05]))
    sol = raydamp.integrate(model, q0, p0, **options)
    assert sol.status == "collapsed" and sol.summary()["envelope"]["collapsed_spring"] == 1
    assert sol.provenance["collapse"] == [1.0, 0.05]


@pytest.mark.parametrize(("changes", "path"), [
    ({"envelope": ["drift", "peak"]}, ("envelope", 1)),
    ({"envelope": []}, ("envelope",)),
    ({"envelope": "drift"}, ("envelope",)),
    ({"collapse": -1.0}, ("collapse",)),
    ({"collapse": [0.1, 0.0]}, ("collapse", 1)),
])
def test_a_bad_envelope_in_json_is_refused_at_its_path(changes, path):
    with pytest.raises(ValidationError) as caught:
        JobSpec.model_validate(job(**changes))
    paths = [client_path(e["loc"]) for e in caught.value.errors()]
    assert any(p[:len(path)] == path for p in paths), paths


def test_a_spring_quantity_on_a_structure_without_springs_names_the_envelope():
    plain = job(envelope=["displacement", "force"])
    plain["system"] = raydamp.LinearStructure(np.eye(2), np.eye(2) * 100.0).to_dict()
    model, q0, p0, options = job_arguments(plain)
    with pytest.raises(ValueError, match=r"^envelope\[1\]: 'force' is a spring's"):
        raydamp.integrate(model, q0, p0, **options)
