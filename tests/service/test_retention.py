"""Freeing space against a real service: DELETE of a finished job removes it and its trajectory,
and the retention pass removes the oldest finished jobs until the bounds hold, shrinking the file."""

from __future__ import annotations

import math
import sqlite3
import time
from pathlib import Path

PENDULUM = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.001,
            "n_steps": 100_000, "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}
# 100,001 saved points x (t, q, p, energy) float64: 3.2 MB of trajectory per job.
TRAJECTORY_BYTES = 100_002 * 4 * 8


def database_bytes(db: Path) -> int:
    return sum(path.stat().st_size for path in (db, Path(f"{db}-wal")) if path.exists())


def rows(db: Path, job_id: str) -> tuple[int, int]:
    with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as connection:
        jobs = connection.execute("SELECT COUNT(*) FROM jobs WHERE id = ?", (job_id,)).fetchone()[0]
        trajectories = connection.execute("SELECT COUNT(*) FROM trajectories WHERE job_id = ?", (job_id,)).fetchone()[0]
    return jobs, trajectories


def test_delete_of_a_finished_job_removes_it_and_its_trajectory(start_server):
    server = start_server()
    job_id = server.submit(PENDULUM)
    assert server.wait_finished(job_id)["status"] == "completed"
    assert rows(server.db, job_id) == (1, 1)
    before = database_bytes(server.db)

    response = server.client.delete(f"/v1/jobs/{job_id}")
    assert response.status_code == 204 and response.content == b""
    assert rows(server.db, job_id) == (0, 0)
    assert server.client.get(f"/v1/jobs/{job_id}").status_code == 404
    assert server.client.get(f"/v1/jobs/{job_id}/trajectory").status_code == 404
    assert server.client.delete(f"/v1/jobs/{job_id}").status_code == 404
    assert before - database_bytes(server.db) >= 0.9 * TRAJECTORY_BYTES  # the pages went back to the disk


def test_retention_removes_the_oldest_finished_jobs_and_the_database_shrinks(start_server):
    server = start_server(RAYDAMP_RETAIN_JOBS="0", RAYDAMP_RETAIN_BYTES="0")  # keep everything at first
    ids = [server.submit(PENDULUM) for _ in range(5)]
    finished_at = {job_id: server.wait_finished(job_id)["finished_at"] for job_id in ids}
    assert all(server.job(job_id)["status"] == "completed" for job_id in ids)
    newest = sorted(ids, key=finished_at.get)[-2:]
    server.stop()
    before = database_bytes(server.db)
    assert before >= 5 * TRAJECTORY_BYTES

    server.env.update(RAYDAMP_RETAIN_JOBS="3", RAYDAMP_RETAIN_BYTES=str(int(2.5 * TRAJECTORY_BYTES)),
                      RAYDAMP_RETENTION_INTERVAL_SECONDS="0.5")
    server.start()  # the bytes bound (2 trajectories) is the tighter one
    server.wait_for(newest[-1], lambda job: len(server.client.get("/v1/jobs").json()["jobs"]) == 2, timeout=30)
    kept = [job["id"] for job in server.client.get("/v1/jobs").json()["jobs"]]
    assert sorted(kept) == sorted(newest)  # oldest finished first out
    for job_id in set(ids) - set(newest):
        assert rows(server.db, job_id) == (0, 0)
    # The file shrinks once the WAL is folded back, which waits for readers (this test's polling,
    # on a loaded machine); a later pass finishes what an earlier one could not.
    deadline = time.monotonic() + 30
    while (after := database_bytes(server.db)) > before - 2.7 * TRAJECTORY_BYTES and time.monotonic() < deadline:
        time.sleep(0.2)
    assert before - after >= 2.7 * TRAJECTORY_BYTES, (before, after)
