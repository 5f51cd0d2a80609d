"""The job lifecycle against a real service process: results equal raydamp's, survive restarts and crashes."""

from __future__ import annotations

import math
import time

import numpy as np

import raydamp
from raydamp.models import make_model

PENDULUM = {  # the paper's damped pendulum, section 4.3
    "model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.2, "t_end": 200,
    "initial_state": {"q": [0.9 * math.pi], "p": [0.0]},
}
ELASTIC_STATE = {"q": [0.0, 1.55884573, -0.6], "p": [1.34164079, 0.0, 0.0]}  # the paper's, section 6.2
# Heun with a step far beyond its stability limit; eps = 10 makes the growth damping-driven, so
# every saved point (energies included) is still finite when the state overflows.
BLOW_UP = {"model": "elastic_pendulum", "parameters": {"eps": 10.0}, "method": "heun", "step_size": 2.5,
           "n_steps": 1000, "initial_state": ELASTIC_STATE}

# 10^5 steps: not a quick run (JobWork.quick), so it waits in the queue for a worker.
NOT_QUICK = {**PENDULUM, "t_end": 20_000}
# Long enough (about a minute) that a cancel always lands mid-run.
LONG_RUN = {**{k: v for k, v in PENDULUM.items() if k != "t_end"}, "step_size": 0.001, "n_steps": 4 * 10**9,
            "save_every": 10**6}

SUMMARY_NUMBERS = ("step_size", "t_final", "energy_initial", "energy_final", "energy_dissipated",
                   "mean_dissipation_rate", "momentum_drift")


def direct(spec: dict) -> raydamp.Solution:
    """The same problem through raydamp.integrate, no service involved."""
    # A job records the damping work unless asked not to (which runs 3s's steps unmerged).
    options = {"method": spec["method"], "h": spec["step_size"], "save_every": spec.get("save_every", 1),
               "work": spec.get("work", True)}
    for key in ("t_end", "n_steps", "tableau"):
        if key in spec:
            options[key] = spec[key]
    model = make_model(spec["model"], spec["parameters"])
    return raydamp.integrate(model, spec["initial_state"]["q"], spec["initial_state"]["p"], **options)


def assert_matches(job: dict, trajectory: dict, solution: raydamp.Solution) -> None:
    expected = solution.summary()
    for key in ("status", "message", "steps", "failed_step", "saved_points", "method", "tableau"):
        assert job["summary"][key] == expected[key], key
    for key in SUMMARY_NUMBERS:
        if expected[key] is None:
            assert job["summary"][key] is None, key
        else:
            assert abs(job["summary"][key] - expected[key]) <= 1e-12 * max(1.0, abs(expected[key])), key
    for key in ("t", "q", "p", "energy", "momentum"):
        got = np.array(trajectory[key], dtype=float).reshape(getattr(solution, key).shape)
        np.testing.assert_allclose(got, getattr(solution, key), rtol=1e-12, atol=1e-12, err_msg=key)


def steps_for(seconds: float, spec: dict) -> int:
    """Size a run to take about `seconds` here, whatever this machine's speed (a sizing, not a test)."""
    probe = 2_000_000
    start = time.perf_counter()
    direct({**spec, "n_steps": probe, "save_every": probe})
    rate = probe / max(time.perf_counter() - start, 1e-6)
    return int(min(max(rate * seconds, 10**7), 10**9))


def test_pendulum_and_blow_up_match_raydamp_and_survive_a_restart(start_server):
    server = start_server()
    response = server.client.post("/v1/jobs", json=PENDULUM)
    assert response.status_code == 202
    created = response.json()
    assert created["status"] == "queued"
    assert response.headers["location"].endswith(f"/v1/jobs/{created['id']}")
    blow_up_id = server.submit(BLOW_UP)

    job = server.wait_finished(created["id"])
    assert job["status"] == "completed" and job["progress"] == 1.0 and job["error"] is None
    assert job["spec"]["parameters"] == PENDULUM["parameters"] and job["spec"]["t_end"] == 200
    assert job["created_at"] <= job["started_at"] <= job["finished_at"]
    trajectory = server.client.get(job["trajectory"]).json()
    assert trajectory["momentum"][0] == []  # the pendulum has no symmetry
    assert_matches(job, trajectory, direct(PENDULUM))

    expected = direct(BLOW_UP)
    assert expected.status == "non_finite"  # the premise: this spec really blows up
    failed = server.wait_finished(blow_up_id)
    assert failed["status"] == "failed"
    assert failed["failed_step"] == expected.failed_step and failed["error"] == expected.message
    blown = server.client.get(f"/v1/jobs/{blow_up_id}/trajectory").json()
    assert all(math.isfinite(x) for key in ("q", "p", "momentum") for row in blown[key] for x in row)
    assert all(math.isfinite(x) for key in ("t", "energy") for x in blown[key])
    assert_matches(failed, blown, expected)

    before = {job_id: (server.job(job_id), server.client.get(f"/v1/jobs/{job_id}/trajectory").content)
              for job_id in (created["id"], blow_up_id)}
    server.restart()
    for job_id, (job_before, trajectory_before) in before.items():
        assert server.job(job_id) == job_before
        assert server.client.get(f"/v1/jobs/{job_id}/trajectory").content == trajectory_before
    listed = server.client.get("/v1/jobs").json()["jobs"]
    assert [job["id"] for job in listed] == [blow_up_id, created["id"]]  # newest first


def test_a_run_killed_by_a_crash_is_run_again_after_restart(start_server):
    spec = {"model": "elastic_pendulum", "parameters": {}, "method": "3s", "step_size": 0.01,
            "initial_state": ELASTIC_STATE}
    n_steps = steps_for(3.0, spec)
    spec.update(n_steps=n_steps, save_every=n_steps // 1000)
    server = start_server(RAYDAMP_MAX_STEPS=str(10**9))
    job_id = server.submit(spec)
    server.wait_for(job_id, lambda job: job["status"] == "running")
    server.kill()

    server.start()
    job = server.wait_finished(job_id)
    assert job["status"] == "completed" and job["attempts"] == 2
    assert job["summary"]["steps"] == n_steps
    trajectory = server.client.get(f"/v1/jobs/{job_id}/trajectory").json()
    assert_matches(job, trajectory, direct(spec))


def test_concurrent_submissions_answered_202_survive_a_sigkill_right_after(start_server):
    """A 202 is sent once the row is committed: 40
    submissions at once, SIGKILL as soon as the last 202 is in, and after the restart every one of them is
    there and runs exactly once; nothing else appears."""
    import concurrent.futures

    server = start_server(RAYDAMP_WORKERS="1", RAYDAMP_MAX_STEPS=str(10**10))
    blocker = server.submit(LONG_RUN)  # the one worker is busy: the submissions stay queued until the crash
    server.wait_for(blocker, lambda job: job["status"] == "running")
    small = {**PENDULUM, "t_end": 2}
    with concurrent.futures.ThreadPoolExecutor(40) as pool:
        ids = list(pool.map(lambda i: server.submit({**small, "parameters": {"eps": 0.01 + i / 1000}}), range(40)))
    server.kill()

    server.start()
    assert server.client.delete(f"/v1/jobs/{blocker}").status_code == 202  # requeued by recovery; cancelled
    jobs = {job_id: server.wait_finished(job_id) for job_id in ids}
    assert all(job["status"] == "completed" and job["attempts"] == 1 for job in jobs.values())
    # Each job ran its own spec (no row swapped between concurrent submissions), from its own parameters.
    assert sorted(job["spec"]["parameters"]["eps"] for job in jobs.values()) == sorted(
        0.01 + i / 1000 for i in range(40))
    listed = server.client.get("/v1/jobs", params={"limit": 100}).json()["jobs"]
    assert sorted(job["id"] for job in listed) == sorted([*ids, blocker])


def test_cancelling_a_running_job_keeps_its_partial_trajectory(server):
    spec = LONG_RUN
    job_id = server.submit(spec)
    server.wait_for(job_id, lambda job: job["status"] == "running" and job["progress"] > 0)
    response = server.client.post(f"/v1/jobs/{job_id}/cancel")
    assert response.status_code == 202 and response.json()["cancel_requested"]

    job = server.wait_finished(job_id)
    assert job["status"] == "cancelled"
    assert 0 < job["summary"]["steps"] < spec["n_steps"]
    trajectory = server.client.get(f"/v1/jobs/{job_id}/trajectory").json()
    assert len(trajectory["t"]) == job["summary"]["saved_points"] >= 2
    assert trajectory["t"][-1] == job["summary"]["t_final"] < spec["n_steps"] * spec["step_size"]
    assert server.client.post(f"/v1/jobs/{job_id}/cancel").status_code == 409  # nothing left to cancel


def test_cancelling_a_queued_job_and_deleting_a_running_one(server):
    busy = [server.submit(LONG_RUN) for _ in range(2)]  # the service runs two at a time
    for job_id in busy:
        server.wait_for(job_id, lambda job: job["status"] == "running")
    queued = server.submit(NOT_QUICK)  # (a quick job has a lane of its own: it would not wait)
    assert server.job(queued)["status"] == "queued"
    # The JSON, a file and a plot of a queued job: 409, saying that the trajectory comes when the run ends.
    for path in ("trajectory", "trajectory?format=npz", "plots/energy.png"):
        response = server.client.get(f"/v1/jobs/{queued}/{path}")
        assert response.status_code == 409 and "queued; its trajectory is stored when the run ends" in \
            response.json()["detail"], (path, response.text)

    assert server.client.delete(f"/v1/jobs/{queued}").json()["status"] == "cancelled"
    for job_id in busy:
        assert server.client.delete(f"/v1/jobs/{job_id}").status_code == 202
    for job_id in busy:
        assert server.wait_finished(job_id)["status"] == "cancelled"
    cancelled = server.job(queued)
    assert cancelled["attempts"] == 0 and cancelled["trajectory"] is None
    response = server.client.get(f"/v1/jobs/{queued}/trajectory")
    assert response.status_code == 409 and "no trajectory" in response.json()["detail"]


def test_list_is_newest_first_and_bounded(server):
    ids = [server.submit(PENDULUM) for _ in range(3)]
    listed = server.client.get("/v1/jobs", params={"limit": 2}).json()["jobs"]
    assert [job["id"] for job in listed] == ids[::-1][:2]
    assert server.client.get("/v1/jobs", params={"limit": 0}).status_code == 422
    assert server.client.get("/v1/jobs", params={"limit": 10**6}).status_code == 422
    for job_id in ids:
        server.wait_finished(job_id)
    completed = server.client.get("/v1/jobs", params={"status": "completed"}).json()["jobs"]
    assert {job["status"] for job in completed} == {"completed"}


def test_unknown_job_is_404(server):
    for response in (server.client.get("/v1/jobs/nope"), server.client.get("/v1/jobs/nope/trajectory"),
                     server.client.post("/v1/jobs/nope/cancel"), server.client.delete("/v1/jobs/nope")):
        assert response.status_code == 404 and "nope" in response.json()["detail"]


def test_a_job_started_at_rest_is_run_and_not_a_500(server):
    # The fuzz run's body: the quick-run test read initial_state.q of a {"rest": true} start (500). A rest or
    # mode start takes its sizes from the model, so it is not among the quick runs checked inline.
    body = {"h": 7.506959706133062e+21, "model": "damped_pendulum", "initial_state": {"rest": True},
            "t_end": 5e-324, "method": None}
    response = server.client.post("/v1/jobs", json=body)
    assert response.status_code == 202, response.text
    job = server.wait_finished(response.json()["id"])
    assert job["status"] == "completed" and job["summary"]["steps"] == 1
