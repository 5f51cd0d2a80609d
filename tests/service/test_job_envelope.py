"""Envelopes through the service (issue 42): a job's "envelope" runs in raydamp, its summary shows the peaks,
and a bad one is a 422 naming its JSON path. The service computes nothing of it."""

from __future__ import annotations

import numpy as np

import raydamp
from raydamp.jobs import job_arguments
from raydamp.materials import Bilinear


def job() -> dict:
    springs = [raydamp.Spring((0,), Bilinear(100.0, 2.0, 0.05)), raydamp.Spring((0, 1), Bilinear(80.0, 1.5, 0.1))]
    return {"system": raydamp.Structure(np.eye(2), springs=springs, alpha=0.3).to_dict(), "method": "3s",
            "h": 0.01, "n_steps": 300, "initial_state": {"q": [0.0, 0.0], "p": [0.0, 0.0]},
            "load": raydamp.Load.harmonic([30.0, 30.0], 6.0, t_end=1.5).to_dict(),
            "envelope": ["drift", "abs_acceleration", "residual_drift"]}


def test_a_jobs_summary_shows_its_envelope_and_a_bad_one_is_422_at_its_path(server):
    done = server.wait_finished(server.submit(job()))
    assert done["status"] == "completed", done
    envelope = done["summary"]["envelope"]
    model, q0, p0, options = job_arguments(job())
    here = raydamp.integrate(model, q0, p0, **options).envelope
    assert envelope["peaks"]["drift"] == here["drift"].values.tolist()
    assert envelope["residuals"]["residual_drift"] == here["residual_drift"].values.tolist()
    response = server.client.post("/v1/jobs", json={**job(), "envelope": ["drift", "storey_shear"]})
    assert response.status_code == 422, response.text
    locs = [tuple(error["loc"]) for error in response.json()["detail"]]
    assert any(loc[:3] == ("body", "envelope", 1) for loc in locs), locs
