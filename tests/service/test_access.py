"""Who may use the service, against real processes: trusted Host names, Location without the Host
header, the bearer token, and the refusals to start (open bind without a token, unusable database)."""

from __future__ import annotations

import math
import os
import sqlite3

import httpx
import pytest

PENDULUM = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.2,
            "t_end": 20, "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}


def test_a_foreign_host_header_is_refused(server):
    response = server.client.post("/v1/jobs", json=PENDULUM, headers={"Host": "evil.example:666"})
    assert response.status_code == 400 and "trusted_hosts" in response.json()["detail"]
    for host in ("localhost", f"127.0.0.1:{server.port}", "[::1]:80"):
        assert server.client.get("/v1/models", headers={"Host": host}).status_code == 200, host


def test_location_never_carries_the_host_header(start_server):
    server = start_server(RAYDAMP_TRUSTED_HOSTS="*")  # even when every Host is let in
    response = server.client.post("/v1/jobs", json=PENDULUM, headers={"Host": "evil.example:666"})
    assert response.status_code == 202
    assert response.headers["location"] == f"/v1/jobs/{response.json()['id']}"


def test_trusted_hosts_is_a_comma_separated_setting(start_server):
    server = start_server(RAYDAMP_TRUSTED_HOSTS="127.0.0.1, lab.example")
    assert server.client.get("/v1/models", headers={"Host": "lab.example:8000"}).status_code == 200
    assert server.client.get("/v1/models", headers={"Host": "localhost"}).status_code == 400


def test_a_token_is_required_when_set(start_server):
    server = start_server(RAYDAMP_TOKEN="s3cret-token")
    base = str(server.client.base_url)
    with httpx.Client(base_url=base, timeout=30.0) as anonymous:
        for method, path in (("GET", "/v1/jobs"), ("POST", "/v1/jobs"), ("GET", "/v1/models"),
                             ("GET", "/v1/jobs/x/trajectory"), ("DELETE", "/v1/jobs/x")):
            response = anonymous.request(method, path, json=PENDULUM if method == "POST" else None)
            assert response.status_code == 401, (method, path)
            assert response.headers["www-authenticate"] == "Bearer"
        wrong = anonymous.get("/v1/jobs", headers={"Authorization": "Bearer s3cret-tokeN"})
        assert wrong.status_code == 401
        # A big body from someone without the token is refused before it is read.
        assert anonymous.post("/v1/jobs", content=b"x" * 3_000_000).status_code == 401
        assert anonymous.get("/healthz").status_code == 200  # liveness probes need no secret
        # The page shell, its scripts and the API description hold no job data; a browser fetches them
        # by navigation, without a header. The page then asks for the token (tests/service/test_page.py).
        for path in ("/", "/static/page.js", "/vendor/plotly.min.js", "/docs", "/openapi.json"):
            assert anonymous.get(path).status_code == 200, path
        assert anonymous.get("/static/../v1/jobs").status_code in (401, 404)  # no way around through a prefix
    job_id = server.submit(PENDULUM)  # the fixture's client sends the token
    assert server.wait_finished(job_id)["status"] == "completed"
    schema = server.client.get("/openapi.json").json()
    assert schema["components"]["securitySchemes"]["bearer"] == {"type": "http", "scheme": "bearer"}
    assert schema["paths"]["/v1/jobs"]["post"]["security"] == [{"bearer": []}]


def _one_line(result) -> str:
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1, result.stderr[-2000:]
    assert "Traceback" not in result.stderr
    return lines[0]


def test_a_non_loopback_bind_without_a_token_refuses_to_start(tmp_path, run_service):
    result = run_service("--host", "0.0.0.0", "--port", "0", RAYDAMP_DB=str(tmp_path / "db.sqlite3"))
    line = _one_line(result)
    assert "0.0.0.0" in line and "RAYDAMP_TOKEN" in line
    assert not (tmp_path / "db.sqlite3").exists()  # refused before touching anything


def test_a_corrupt_database_refuses_to_start_with_one_line(tmp_path, run_service):
    db = tmp_path / "raydamp.sqlite3"
    db.write_bytes(b"this is not a database, it is a shopping list\n" * 200)
    line = _one_line(run_service("--port", "0", RAYDAMP_DB=str(db)))
    assert str(db) in line and "corrupt" in line and "RAYDAMP_DB" in line


def test_an_unusable_database_path_refuses_to_start_with_one_line(tmp_path, run_service):
    (tmp_path / "afile").write_text("")
    db = tmp_path / "afile" / "raydamp.sqlite3"  # its directory is a file
    line = _one_line(run_service("--port", "0", RAYDAMP_DB=str(db)))
    assert str(db) in line and "RAYDAMP_DB" in line


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes read-only files")
def test_a_read_only_database_refuses_to_start_with_one_line(tmp_path, run_service):
    db = tmp_path / "raydamp.sqlite3"
    sqlite3.connect(db).close()
    db.chmod(0o444)
    tmp_path.chmod(0o555)
    try:
        line = _one_line(run_service("--port", "0", RAYDAMP_DB=str(db)))
    finally:
        tmp_path.chmod(0o755)
    assert "readonly" in line.replace(" ", "") or "permission" in line.lower()


def test_an_sqlite_before_3_35_refuses_to_start_with_one_line(tmp_path, monkeypatch, capsys):
    # A task's claim is one UPDATE ... RETURNING (SQLite 3.35); an older library is named, not worked around.
    import subprocess

    from raydamp_service.__main__ import main
    from raydamp_service.tasks import lock

    db = tmp_path / "raydamp.sqlite3"
    monkeypatch.setattr(sqlite3, "sqlite_version_info", (3, 34, 1))
    monkeypatch.setattr(sqlite3, "sqlite_version", "3.34.1")
    monkeypatch.setenv("RAYDAMP_DB", str(db))
    try:
        with pytest.raises(SystemExit) as stopped:
            main(["--port", "0"])
    finally:
        lock.release(db)  # taken first, and kept by a service that starts
    line = _one_line(subprocess.CompletedProcess([], stopped.value.code, "", capsys.readouterr().err))
    assert str(db) in line and "SQLite 3.34.1 is too old" in line and "needs 3.35 or newer" in line


@pytest.mark.parametrize("name", ["same", "hard link", "symlink"])
def test_a_second_service_on_the_same_database_refuses_to_start(server, run_service, tmp_path, name):
    # It ran its recovery first: the first service's running job went back to "queued" (attempts 2) and both
    # services ran it at once (a CLI and service audit). Now it refuses with one line, and the job is untouched.
    # Through another name of the same file (issue 44, N5) as well: a hard link beside it, a symlink elsewhere.
    # The module's server (runs of up to 10^10 steps) serves the three names: each job is cancelled at the end.
    long_run = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.001,
                "n_steps": 4 * 10**9, "save_every": 10**6, "initial_state": {"q": [1.0], "p": [0.0]}}
    job_id = server.submit(long_run)
    server.wait_for(job_id, lambda job: job["status"] == "running")
    other = {"same": server.db, "hard link": server.db.with_name("linked.sqlite3"),
             "symlink": tmp_path / "elsewhere" / "named.sqlite3"}[name]
    if name == "hard link":
        os.link(server.db, other)
    elif name == "symlink":
        other.parent.mkdir()
        other.symlink_to(server.db)
    line = _one_line(run_service("--port", "0", RAYDAMP_DB=str(other)))
    assert line.startswith("raydamp-service: another raydamp service (pid ") and "RAYDAMP_DB" in line
    job = server.job(job_id)
    assert job["status"] == "running" and job["attempts"] == 1
    assert server.client.post(f"/v1/jobs/{job_id}/cancel").status_code == 202
    assert server.wait_finished(job_id)["status"] == "cancelled"  # its worker free for the next name


def test_an_empty_trusted_hosts_refuses_to_start(tmp_path, run_service):
    # RAYDAMP_TRUSTED_HOSTS= started a service that answered 400 to every request, /healthz too (service audit).
    line = _one_line(run_service("--port", "0", RAYDAMP_DB=str(tmp_path / "db.sqlite3"), RAYDAMP_TRUSTED_HOSTS=""))
    assert line.startswith("raydamp-service: bad setting RAYDAMP_TRUSTED_HOSTS")


def test_raydamp_serve_takes_the_services_options(tmp_path):
    # `raydamp serve` had no --workers, which python -m raydamp_service has and its help said they were the same.
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", "raydamp", "serve", "--workers", "0", "--port", "0"],
                          env={**os.environ, "RAYDAMP_DB": str(tmp_path / "db.sqlite3")}, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 2 and "bad setting RAYDAMP_WORKERS" in done.stderr, done.stderr
