"""Orbits over HTTP: {"system": {"kind": "planets", ...}} and {"kind": "kepler", ...} run as raydamp.integrate
does (a job's check once failed on both: their forms had no compiled_form), and bad planets are refused with
a 422 naming the path inside "system" (a negative mass, a drag list of the wrong length, a planet at the
central body's position)."""

from __future__ import annotations

import numpy as np
import pytest

import raydamp

PLANETS = {"kind": "planets", "masses": [1e-3, 2e-3], "central_mass": 1.0, "eps": [0.0, 0.01]}


def _start():
    system = raydamp.Planets.from_dict(PLANETS)
    return system.jacobi_state([[1.0, 0.0], [0.0, 1.6]], [[0.0, 1.0], [-0.79, 0.0]])


def test_a_planets_job_matches_python(server):
    q0, p0 = _start()
    job = {"system": PLANETS, "method": "3s", "step_size": 0.05, "n_steps": 400, "save_every": 100,
           "initial_state": {"q": q0.tolist(), "p": p0.tolist()}}
    done = server.wait_finished(server.submit(job))
    assert done["status"] == "completed", done
    trajectory = server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()
    local = raydamp.integrate(raydamp.Planets.from_dict(PLANETS), q0, p0, method="3s", h=0.05, n_steps=400,
                              save_every=100, work=True)
    np.testing.assert_array_equal(np.array(trajectory["q"]), local.q)
    np.testing.assert_array_equal(np.array(trajectory["work"]), local.work)
    assert local.work[-1] > 0


def test_a_kepler_job_matches_python(server):
    system = {"kind": "kepler", "mu": 1.0, "eps": 1e-3}
    job = {"system": system, "method": "2s", "step_size": 0.1, "n_steps": 300, "save_every": 100,
           "initial_state": {"q": [1.0, 0.0], "p": [0.0, 1.1]}}
    done = server.wait_finished(server.submit(job))
    assert done["status"] == "completed", done
    trajectory = server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()
    local = raydamp.integrate(raydamp.Kepler.from_dict(system), [1.0, 0.0], [0.0, 1.1], method="2s", h=0.1,
                              n_steps=300, save_every=100, work=True)
    np.testing.assert_array_equal(np.array(trajectory["q"]), local.q)


@pytest.mark.parametrize("system, loc", [
    ({**PLANETS, "masses": [1e-3, -1e-3]}, ["body", "system", "masses", 1]),
    ({**PLANETS, "eps": [0.0, -0.1]}, ["body", "system", "eps", 1]),
    ({**PLANETS, "eps": [0.1]}, ["body", "system", "eps"]),
    ({**PLANETS, "central_mass": 0.0}, ["body", "system", "central_mass"]),
])
def test_bad_planets_are_422_naming_the_path(server, system, loc):
    q0, p0 = _start()
    job = {"system": system, "method": "3s", "step_size": 0.1, "n_steps": 10,
           "initial_state": {"q": q0.tolist(), "p": p0.tolist()}}
    response = server.client.post("/v1/jobs", json=job)
    assert response.status_code == 422, response.text
    locs = [d["loc"] for d in response.json()["detail"]]
    assert any(list(found)[:len(loc)] == loc for found in locs), locs


def test_a_planet_at_the_central_body_is_422_naming_the_initial_state(server):
    q0, p0 = _start()
    q0[2:] = -1e-3 / 1.001 * q0[:2]  # the outer planet at the central body's position
    job = {"system": PLANETS, "method": "3s", "step_size": 0.1, "n_steps": 10,
           "initial_state": {"q": q0.tolist(), "p": p0.tolist()}}
    response = server.client.post("/v1/jobs", json=job)
    assert response.status_code == 422, response.text
    assert "planet 1 is at the central body" in response.text, response.text
