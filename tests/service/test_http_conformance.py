"""HTTP answers a generic client (or Schemathesis' allow_header_conformance check) relies on, beyond the
schema's bodies: a 405 names in Allow every method its path takes, as /openapi.json documents them."""

from __future__ import annotations

import pytest


@pytest.mark.parametrize(("path", "allowed"), [
    ("/v1/jobs", {"GET", "POST"}),
    ("/v1/jobs/0123456789abcdef0123456789abcdef", {"GET", "DELETE"}),
    ("/v1/sweeps", {"GET", "POST"}),
    ("/v1/sweeps/0123456789abcdef0123456789abcdef", {"GET", "DELETE"}),
    ("/v1/files", {"GET", "POST"}),
    ("/v1/files/0123456789abcdef0123456789abcdef", {"GET", "DELETE"}),
])
def test_a_405_lists_every_method_of_its_path(module_server, path, allowed):
    # Starlette answered with the methods of the first route whose path matched: "Allow: POST" for
    # OPTIONS /v1/jobs (found by `make fuzz`, Schemathesis ST205).
    response = module_server.client.request("OPTIONS", path)
    assert response.status_code == 405
    assert set(response.headers["allow"].split(", ")) == allowed
    documented = module_server.client.get("/openapi.json").json()["paths"]
    template = path if path in documented else path.rsplit("/", 1)[0] + "/{" + path.split("/")[2][:-1] + "_id}"
    assert {method.upper() for method in documented[template]} == allowed


def test_other_http_errors_keep_their_answer(module_server):
    response = module_server.client.get("/v1/jobs/0123456789abcdef0123456789abcdef")
    assert response.status_code == 404
    assert response.json() == {"detail": "no job with id '0123456789abcdef0123456789abcdef'"}
    assert "allow" not in response.headers


def test_an_undocumented_path_keeps_its_routes_methods(module_server):
    response = module_server.client.post("/healthz")  # documented: GET only
    assert response.status_code == 405 and response.headers["allow"] == "GET"
    response = module_server.client.post("/")  # the page: not in /openapi.json
    assert response.status_code == 405 and response.headers["allow"] == "GET"
