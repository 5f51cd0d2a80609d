"""User-defined systems over HTTP: the System.to_dict() JSON as "system", run, returned, and
every bad or hostile system refused with a 422 whose loc is the path inside "system"."""

from __future__ import annotations

import json

import numpy as np
import pytest

import raydamp

ELASTIC_SYSTEM = {
    "coordinates": ["x", "y", "z"],
    "potential": "k/2*(sqrt(x^2+y^2+z^2) - l)^2 - m*g*z",
    "parameters": {"k": 1.0, "l": 1.0, "m": 1.0, "g": -1.0},
    "mass": 1.0,
    "damping": {"dampers": [{"on": "sqrt(x^2+y^2+z^2)", "c": 1.0}]},
    "eps": 0.1,
    "momenta": {"J3": "x*p_y - y*p_x"},
}
Q0, P0 = [0.0, 1.55884573, -0.6], [1.34164079, 0.0, 0.0]
JOB = {"system": ELASTIC_SYSTEM, "method": "3s", "step_size": 0.1, "n_steps": 2000, "save_every": 10,
       "initial_state": {"q": Q0, "p": P0}}
KEPLER = {"coordinates": ["x", "y"], "potential": "-1/sqrt(x^2+y^2)", "eps": 0.01,
          "damping": {"dampers": [{"on": "sqrt(x^2+y^2)", "c": 1}]}, "momenta": {"L": "x*p_y - y*p_x"},
          "name": "kepler with drag"}


def with_system(**changes) -> dict:
    return {**JOB, "system": {**ELASTIC_SYSTEM, **changes}}


def test_system_job_matches_python(server):
    job = server.wait_finished(server.submit(JOB))
    assert job["status"] == "completed", job
    assert job["spec"]["system"]["potential"] == ELASTIC_SYSTEM["potential"]
    trajectory = server.client.get(f"/v1/jobs/{job['id']}/trajectory").json()
    local = raydamp.integrate(raydamp.System.from_dict(ELASTIC_SYSTEM), Q0, P0, method="3s", h=0.1, n_steps=2000,
                              save_every=10)
    np.testing.assert_allclose(np.array(trajectory["q"]), local.q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(np.array(trajectory["momentum"])[:, 0], local.momentum[:, 0], rtol=0, atol=1e-13)
    assert job["summary"]["momentum_drift"] <= 1e-12


def test_listing_shows_the_system_name(server):
    job_id = server.submit({**JOB, "system": KEPLER, "initial_state": {"q": [1.0, 0.0], "p": [0.0, 1.2]}})
    server.wait_finished(job_id)
    listed = {j["id"]: j for j in server.client.get("/v1/jobs").json()["jobs"]}
    assert listed[job_id]["model"] == "kepler with drag"


def test_openapi_documents_the_system_schema(server):
    schemas = server.client.get("/openapi.json").json()["components"]["schemas"]
    assert "SystemInput" in schemas
    assert {"coordinates", "potential", "mass", "damping", "eps", "momenta"} <= set(
        schemas["SystemInput"]["properties"])


HOSTILE = [
    ("python injection", with_system(potential="__import__('os').system('x')"), ("system", "potential")),
    ("attribute access", with_system(potential="x.real"), ("system", "potential")),
    ("tower of powers", with_system(potential="2^2^40"), ("system", "potential")),
    ("python power tower", with_system(potential="2**2**40"), ("system", "potential")),
    ("huge expression", with_system(potential="x+" * 500_000 + "x"), ("system", "potential")),
    ("deep parentheses", with_system(potential="(" * 10_000 + "x" + ")" * 10_000), ("system", "potential")),
    ("unknown name", with_system(potential="k2*x"), ("system", "potential")),
    ("unknown function", with_system(potential="gamma(x)"), ("system", "potential")),
    ("bad damper expression", with_system(damping={"dampers": [{"on": "sqrt(x^2+", "c": 1}]}),
     ("system", "damping", "dampers", 0, "on")),
    ("damper singular at q0", {**with_system(damping={"dampers": [{"on": "1/x", "c": 1}]}),
                               "initial_state": {"q": [0.0, 1.0, 0.0], "p": P0}},
     ("system", "damping", "dampers", 0, "on")),
    ("NaN parameter", None, ("system", "parameters", "k")),
    ("non-SPD mass", with_system(mass=[[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), ("system", "mass")),
    ("non-PSD damping", with_system(damping={"matrix": [[1, 0, 0], [0, -1, 0], [0, 0, 1]]}),
     ("system", "damping", "matrix")),
    ("two damping forms", with_system(damping={"scalar": 1.0, "diagonal": [1, 1, 1]}), ("system", "damping")),
    ("model and system", {**JOB, "model": "elastic_pendulum"}, ("system",)),
    ("neither model nor system", {k: v for k, v in JOB.items() if k != "system"}, ("model",)),
    ("parameters beside a system", {**JOB, "parameters": {"eps": 0.1}}, ("parameters",)),
    ("wrong q length", {**JOB, "initial_state": {"q": [1.0, 2.0], "p": P0}}, ("initial_state", "q")),
    ("momentum of an unknown coordinate", with_system(momenta={"J": "x*p_w"}), ("system", "momenta", "J")),
    # Accepted before, and its CSV had two columns named "energy" (or t, work, q_x).
    ("momentum named as a saved column", with_system(momenta={"energy": "x*p_y - y*p_x"}),
     ("system", "momenta", "energy")),
    ("momentum named as a coordinate's column", with_system(momenta={"q_x": "x*p_y - y*p_x"}),
     ("system", "momenta", "q_x")),
    ("state-dependent mass", with_system(mass="1 + x^2"), ("system", "mass")),
    ("lone surrogate", None, ("system", "potential")),
]


def _body(case: str, spec: dict | None) -> bytes:
    if case == "NaN parameter":
        return json.dumps(with_system(parameters={**ELASTIC_SYSTEM["parameters"], "k": float("nan")}),
                          allow_nan=True).encode()
    if case == "lone surrogate":
        return json.dumps(with_system(potential="x + \ud800")).encode()  # ensure_ascii writes \\ud800
    return json.dumps(spec).encode()


@pytest.mark.parametrize(("case", "spec", "field"), HOSTILE, ids=[case[0] for case in HOSTILE])
def test_hostile_or_broken_systems_are_422_naming_the_path(server, case, spec, field):
    response = server.client.post("/v1/jobs", content=_body(case, spec), headers={"content-type": "application/json"})
    assert response.status_code == 422, response.text[:500]
    detail = response.json()["detail"]
    locs = [tuple(error["loc"]) for error in detail]
    assert any(loc[1:len(field) + 1] == field for loc in locs), locs
    assert len(response.content) < 100_000  # the huge input is not echoed back whole
    assert server.client.get("/healthz").status_code == 200


def test_expression_errors_name_the_column(server):
    detail = server.client.post("/v1/jobs", json=with_system(potential="x + k2*y")).json()["detail"]
    assert "column 5" in detail[0]["msg"] and "k2" in detail[0]["msg"]
    assert detail[0]["msg"].startswith("system.potential: ")


def test_nothing_hostile_was_queued(server):
    before = len(server.client.get("/v1/jobs").json()["jobs"])
    for case, spec, _ in HOSTILE:
        server.client.post("/v1/jobs", content=_body(case, spec), headers={"content-type": "application/json"})
    assert len(server.client.get("/v1/jobs").json()["jobs"]) == before
