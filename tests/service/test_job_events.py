"""Events through the service (issue 41): a job's "events" run, its summary lists the crossings, a terminal
event is a completed job, and a bad event is a 422 naming its JSON path."""

from __future__ import annotations

import math

import pytest
from scipy.special import ellipk

PENDULUM = {"model": "damped_pendulum", "parameters": {"eps": 0.0}, "method": "sv", "composition": "yoshida4",
            "h": 1e-3, "t_end": 10.0, "initial_state": {"q": [1.0], "p": [0.0]}, "work": False,
            "events": [{"g": "q[0]", "direction": -1, "terminal": True, "name": "vertical"}]}


def test_a_terminal_event_is_a_completed_job_whose_summary_lists_it(server):
    job = server.wait_finished(server.submit(PENDULUM))
    assert job["status"] == "completed", job
    summary = job["summary"]
    assert summary["status"] == "event"
    assert summary["events"]["count"] == 1 and summary["events"]["name"] == ["vertical"]
    assert abs(summary["events"]["t"][0] - ellipk(math.sin(0.5) ** 2)) < 1e-12
    assert summary["t_final"] == summary["events"]["t"][0]


@pytest.mark.parametrize("events, field", [
    ([{"g": "q[0] + y"}], ("events", 0, "g")),
    ([{"g": "q[0]", "direction": 2}], ("events", 0, "direction")),
    ([{"g": "q[0]", "when": 1}], ("events", 0, "when")),
])
def test_a_bad_event_is_422_naming_its_path(server, events, field):
    response = server.client.post("/v1/jobs", json={**PENDULUM, "events": events})
    assert response.status_code == 422, response.text
    locs = [tuple(error["loc"]) for error in response.json()["detail"]]
    assert any(loc[:len(field) + 1] == ("body", *field) for loc in locs), locs
