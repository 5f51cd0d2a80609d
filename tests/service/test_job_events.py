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


def test_the_events_table_is_in_the_downloads(server, tmp_path):
    import io

    import numpy as np
    import xarray as xr

    spec = {**PENDULUM, "t_end": 12.0, "save_every": 100,
            "events": [{"g": "q[0]", "name": "vertical"}, {"g": "p[0]", "direction": 1, "name": "turn"}]}
    job = server.wait_finished(server.submit(spec))
    assert job["status"] == "completed", job
    listed = job["summary"]["events"]
    assert listed["count"] >= 4 and len(listed["q"]) == listed["count"]
    nc = server.client.get(f"/v1/jobs/{job['id']}/trajectory", params={"format": "netcdf"})
    assert nc.status_code == 200, nc.text
    path = tmp_path / "run.nc"
    path.write_bytes(nc.content)
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert list(ds["event_t"].values) == listed["t"]
        assert [str(n) for n in ds["event_name"].values] == listed["name"]
        np.testing.assert_array_equal(ds["event_q"].values, np.array(listed["q"]))
    csv = server.client.get(f"/v1/jobs/{job['id']}/events.csv")
    assert csv.status_code == 200 and csv.headers["content-type"].startswith("text/csv"), csv.text
    table = np.genfromtxt(io.StringIO(csv.text), delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert table.dtype.names[:3] == ("name", "t", "direction") and len(table.dtype.names) == 5  # q, p of the one
    assert [str(n) for n in table["name"]] == listed["name"]
    assert list(table["t"]) == listed["t"] and list(table["direction"]) == listed["direction"]
    plain = server.wait_finished(server.submit({k: v for k, v in spec.items() if k != "events"}))
    assert server.client.get(f"/v1/jobs/{plain['id']}/events.csv").status_code == 409
