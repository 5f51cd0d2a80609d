"""`raydamp jobs ...` / `raydamp sweeps ...` against a real server: list, show, fetch (the file equals
what the service holds), delete; the service's refusals exit 1 with its message, no service exits 2."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np

import raydamp

JOB = {"model": "damped_pendulum", "parameters": {"eps": 0.05}, "method": "3s", "step_size": 0.1, "n_steps": 300,
       "save_every": 10, "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}


def cli(server, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "raydamp", args[0], "--url", str(server.client.base_url), *args[1:]],
                          capture_output=True, text=True, timeout=120)


def test_jobs_list_show_fetch_delete(module_server, tmp_path):
    server = module_server
    job_id = server.submit(JOB)
    server.wait_finished(job_id)
    listed = cli(server, "jobs", "list")
    assert listed.returncode == 0 and job_id in listed.stdout and "completed" in listed.stdout, listed.stderr
    shown = cli(server, "jobs", "show", job_id)
    assert shown.returncode == 0 and json.loads(shown.stdout)["summary"]["saved_points"] == 31  # 300 // 10 + 1
    out = tmp_path / "run.nc"
    fetched = cli(server, "jobs", "fetch", job_id, "--out", str(out))
    assert fetched.returncode == 0, fetched.stderr
    sol = raydamp.load(out)
    ref = server.client.get(f"/v1/jobs/{job_id}/trajectory").json()
    assert np.array_equal(sol.q[:, 0], [row[0] for row in ref["q"]])
    assert sol.provenance["method"] == "3s"
    assert cli(server, "jobs", "fetch", job_id, "--out", str(tmp_path / "x.h5")).returncode == 2
    # An id is one path segment: "<id>?x" asked for the job <id>, and "a b" was reported as no service.
    for odd in (f"{job_id}?x", "a b", "../files"):
        answered = cli(server, "jobs", "show", odd)
        assert answered.returncode == 1 and "answered 404" in answered.stderr, (odd, answered.stderr)
    deleted = cli(server, "jobs", "delete", job_id)
    assert deleted.returncode == 0 and "removed" in deleted.stdout
    gone = cli(server, "jobs", "show", job_id)
    assert gone.returncode == 1 and "answered 404" in gone.stderr and job_id in gone.stderr


def test_sweeps_fetch_and_no_service(module_server, tmp_path):
    server = module_server  # the module's last test: it stops the server
    response = server.client.post("/v1/sweeps", json={"job": JOB, "grid": {"eps": [0.0, 0.1, 0.2]}})
    assert response.status_code == 202, response.text
    sweep_id = server.wait_for_sweep(response.json()["id"])["id"]
    listed = cli(server, "sweeps", "list", "--status", "completed")
    assert listed.returncode == 0 and sweep_id in listed.stdout and "3 members" in listed.stdout
    out = tmp_path / "sweep.nc"
    assert cli(server, "sweeps", "fetch", sweep_id, "--out", str(out)).returncode == 0
    assert list(raydamp.load(out)["eps"].values) == [0.0, 0.1, 0.2]
    server.stop()
    down = cli(server, "sweeps", "list")
    assert down.returncode == 2 and "no service at" in down.stderr
