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


def test_head_answers_as_get_without_a_body(module_server):
    # Every GET route answered HEAD with 405 (curl -I, link checkers; a service audit).
    client = module_server.client
    job_id = module_server.submit({"model": "damped_pendulum", "h": 0.1, "n_steps": 100,
                                   "initial_state": {"q": [1.0], "p": [0.0]}})
    module_server.wait_finished(job_id)
    for path in ("/healthz", "/", "/docs", "/openapi.json", "/v1/jobs", "/v1/models", f"/v1/jobs/{job_id}",
                 f"/v1/jobs/{job_id}/trajectory", f"/v1/jobs/{job_id}/trajectory?format=csv",
                 "/v1/jobs/0123456789abcdef0123456789abcdef"):
        head, get = client.head(path), client.get(path)
        assert (head.status_code, head.headers["content-type"]) == (get.status_code, get.headers["content-type"]), path
        assert head.content == b"" and get.content, path


def test_a_json_head_takes_no_large_fetch_slot_and_a_files_does(start_server):
    # One slot, and every trajectory of this job is large: a HEAD reads no body, so it needs none (and a HEAD
    # that took one gave it back only after its client had the answer: the next request could find it taken).
    server = start_server(RAYDAMP_LARGE_FETCH_BYTES="1024", RAYDAMP_MAX_LARGE_FETCHES="1")
    job_id = server.submit({"model": "damped_pendulum", "h": 0.01, "n_steps": 200_000,  # some 20 MB of JSON:
                            "initial_state": {"q": [1.0], "p": [0.0]}})  # more than the sockets buffer
    server.wait_finished(job_id)
    for _ in range(5):
        assert server.client.head(f"/v1/jobs/{job_id}/trajectory").status_code == 200
    response = server.client.get(f"/v1/jobs/{job_id}/trajectory")
    assert response.status_code == 200 and len(response.json()["t"]) == 200_001
    with server.client.stream("GET", f"/v1/jobs/{job_id}/trajectory") as holding:  # unread: holds the slot
        assert holding.status_code == 200
        assert server.client.get(f"/v1/jobs/{job_id}/trajectory").status_code == 429
        assert server.client.head(f"/v1/jobs/{job_id}/trajectory").status_code == 200
        # A file's HEAD writes the file before its headers: it takes a slot like its GET (a review found 50 such
        # HEADs at once writing 50 files).
        assert server.client.head(f"/v1/jobs/{job_id}/trajectory?format=csv").status_code == 429


def test_a_trailing_slash_is_404_not_a_redirect_built_from_host(module_server):
    # It was a 307 to http://<the request's Host>/v1/jobs: an open redirect with trusted_hosts "*" (service audit).
    response = module_server.client.get("/v1/jobs/", follow_redirects=False)
    assert response.status_code == 404 and "location" not in response.headers
