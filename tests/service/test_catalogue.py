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


def test_compositions_are_raydamps_with_the_near_integrable_tables(server):
    response = server.client.get("/v1/compositions")
    assert response.status_code == 200
    assert response.json() == [composition._asdict() for composition in raydamp.compositions()]
    saba2 = next(row for row in response.json() if row["name"] == "saba2")
    assert saba2["kind"] == "near_integrable" and saba2["eps_order"] == 4 and len(saba2["ends"]) == 3


def test_a_kepler_job_runs_a_near_integrable_table(server):
    system = {"kind": "kepler", "mu": 1.0, "eps": 1e-3}
    job = {"system": system, "method": "2s", "composition": "saba3", "step_size": 0.2, "n_steps": 100,
           "save_every": 50, "initial_state": {"q": [1.0, 0.0], "p": [0.0, 1.1]}}
    done = server.wait_finished(server.submit(job))
    assert done["status"] == "completed", done
    trajectory = server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()
    local = raydamp.integrate(raydamp.Kepler.from_dict(system), [1.0, 0.0], [0.0, 1.1], method="2s",
                              composition="saba3", h=0.2, n_steps=100, save_every=50)
    assert trajectory["q"] == local.q.tolist()
    refused = server.client.post("/v1/jobs", json={**job, "method": "3s"})
    assert refused.status_code == 422 and "near-integrable table" in refused.text, refused.text
    assert "composition" in str([d["loc"] for d in refused.json()["detail"]]), refused.text


def test_health(server):
    response = server.client.get("/healthz")
    assert response.status_code == 200
    assert response.json() == {"status": "ok", "version": raydamp.__version__, "workers": 2}


def test_openapi_describes_every_endpoint(server):
    paths = server.client.get("/openapi.json").json()["paths"]
    assert {"/v1/jobs", "/v1/jobs/{job_id}", "/v1/jobs/{job_id}/trajectory", "/v1/jobs/{job_id}/cancel",
            "/v1/models", "/v1/methods", "/healthz"} <= set(paths)
    assert "Trajectory" in str(paths["/v1/jobs/{job_id}/trajectory"])


def test_openapi_declares_names_limits_and_exclusive_fields(server):
    schema = server.client.get("/openapi.json").json()
    spec = schema["components"]["schemas"]["JobSpec"]
    names = {"model": {model["name"] for model in describe_models()},
             "method": {method.name for method in raydamp.methods()},
             "tableau": {method.tableau for method in raydamp.methods()} - {None}}
    for field, expected in names.items():
        options = spec["properties"][field].get("anyOf", [spec["properties"][field]])
        enum = next(option["enum"] for option in options if "enum" in option)
        assert set(enum) == expected, field
    exclusive = [branch["oneOf"] for branch in spec["allOf"]]
    assert [[b["required"] for b in one_of] for one_of in exclusive] == [[["model"], ["system"]],
                                                                         [["t_end"], ["n_steps"]]]
    limit = next(p for p in schema["paths"]["/v1/jobs"]["get"]["parameters"] if p["name"] == "limit")
    assert limit["schema"]["maximum"] == 1000 and limit["schema"]["minimum"] == 1
    post = schema["paths"]["/v1/jobs"]["post"]["responses"]
    assert {"400", "413", "422", "429"} <= set(post)
    assert "UTF-8" in post["400"]["description"] and "2097152" in post["413"]["description"]


def test_openapi_declares_file_responses_and_every_list_limit(server):
    """Issue 27, point 5: the trajectory's files and the sweeps' list limit were missing from /openapi.json."""
    paths = server.client.get("/openapi.json").json()["paths"]
    content = paths["/v1/jobs/{job_id}/trajectory"]["get"]["responses"]["200"]["content"]
    assert {"application/json", "text/csv", "application/octet-stream", "application/x-netcdf"} <= set(content)
    for listing in ("/v1/jobs", "/v1/sweeps", "/v1/files"):
        limit = next(p for p in paths[listing]["get"]["parameters"] if p["name"] == "limit")
        assert limit["schema"]["maximum"] == 1000, listing
