"""GET /v1/models, /v1/methods and /healthz report raydamp's own catalogue."""

from __future__ import annotations

import raydamp
from raydamp.models import describe_models


def test_models_are_raydamps(server):
    response = server.client.get("/v1/models")
    assert response.status_code == 200
    assert response.json() == describe_models()
    pendulum = next(model for model in response.json() if model["name"] == "damped_pendulum")
    assert pendulum["parameters"] == [{"name": "eps", "default": 0.01, "description": "damping coefficient, >= 0"}]


def test_methods_are_raydamps(server):
    response = server.client.get("/v1/methods")
    assert response.status_code == 200
    assert response.json() == [method._asdict() for method in raydamp.methods()]


def test_health(server):
    response = server.client.get("/healthz")
    assert response.status_code == 200
    assert response.json() == {"status": "ok", "version": raydamp.__version__, "workers": 2}


def test_openapi_describes_every_endpoint(server):
    paths = server.client.get("/openapi.json").json()["paths"]
    assert {"/v1/jobs", "/v1/jobs/{job_id}", "/v1/jobs/{job_id}/trajectory", "/v1/jobs/{job_id}/cancel",
            "/v1/models", "/v1/methods", "/healthz"} <= set(paths)
    assert "Trajectory" in str(paths["/v1/jobs/{job_id}/trajectory"])
