"""Trajectories as files and plots as PNGs, from a real service process: every format carries
the same numbers as the JSON, an unknown format is a 422 naming `format`, plots have the asked size."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import raydamp
from raydamp.jobs import job_arguments

PENDULUM = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.2,
            "t_end": 40, "initial_state": {"q": [2.827433388], "p": [0.0]}, "save_every": 2}
KEPLER = {"system": {"coordinates": ["x", "y"], "potential": "-1/sqrt(x^2+y^2)", "eps": 0.01,
                     "damping": {"dampers": [{"on": "sqrt(x^2+y^2)", "c": 1}]}, "momenta": {"L": "x*p_y - y*p_x"}},
          "method": "2s", "step_size": 0.01, "n_steps": 2000, "save_every": 10,
          "initial_state": {"q": [1.0, 0.0], "p": [0.0, 1.2]}}


@pytest.fixture(scope="module")
def jobs(server):
    ids = {name: server.submit(spec) for name, spec in (("pendulum", PENDULUM), ("kepler", KEPLER))}
    for job_id in ids.values():
        assert server.wait_finished(job_id)["status"] == "completed"
    return ids


def _json(server, job_id, **params) -> dict:
    response = server.client.get(f"/v1/jobs/{job_id}/trajectory", params=params)
    assert response.status_code == 200, response.text
    return {key: np.array(value, dtype=float) for key, value in response.json().items()}


@pytest.mark.parametrize("name", ["pendulum", "kepler"])
def test_every_format_carries_the_json_numbers(server, jobs, tmp_path, name):
    job_id = jobs[name]
    reference = _json(server, job_id)
    rows = reference["t"].size
    for fmt, suffix in (("npz", ".npz"), ("netcdf", ".nc"), ("nc", ".nc")):  # nc: an alias the README names
        response = server.client.get(f"/v1/jobs/{job_id}/trajectory", params={"format": fmt})
        assert response.status_code == 200, response.text
        assert f'filename="{job_id}-trajectory{suffix}"' in response.headers["content-disposition"]
        path = tmp_path / f"{name}{suffix}"
        path.write_bytes(response.content)
        sol = raydamp.load(path)
        for key in ("t", "q", "p", "energy", "work"):
            np.testing.assert_array_equal(getattr(sol, key).reshape(rows, -1), reference[key].reshape(rows, -1))
        np.testing.assert_array_equal(sol.momentum.reshape(rows, -1), reference["momentum"].reshape(rows, -1))
        spec = PENDULUM if name == "pendulum" else KEPLER
        assert sol.provenance["job_id"] == job_id and sol.provenance["method"] == spec["method"]
        model, q0, p0, options = job_arguments(sol.provenance)
        again = raydamp.integrate(model, q0, p0, **options)
        np.testing.assert_array_equal(again.q, sol.q)  # the provenance reruns the job, bit for bit
    csv = server.client.get(f"/v1/jobs/{job_id}/trajectory", params={"format": "csv"})
    assert csv.status_code == 200 and csv.headers["content-type"].startswith("text/csv")
    header, *lines = csv.text.strip().splitlines()
    table = np.array([[float(v) for v in line.split(",")] for line in lines])
    n = reference["q"].reshape(rows, -1).shape[1]
    np.testing.assert_array_equal(table[:, 0], reference["t"])
    np.testing.assert_array_equal(table[:, 1:1 + n], reference["q"].reshape(rows, -1))
    assert header.split(",")[0] == "t"


def test_the_damping_work_is_kept_and_balances_the_energy(server, jobs):
    """Every job records W(t): H - H0 + W is the method's energy balance residual, O(h^2) and small,
    while the energy itself fell by far more (the check fails if W were missing, zero or mis-sliced)."""
    for name, tolerance in (("pendulum", 1e-2), ("kepler", 1e-4)):  # h = 0.2 near the top; h = 0.01
        data = _json(server, jobs[name])
        balance = data["energy"] - data["energy"][0] + data["work"]
        assert data["work"][0] == 0.0 and np.all(np.diff(data["work"]) >= 0)  # dissipated work only grows
        assert data["energy"][0] - data["energy"][-1] > 50 * np.abs(balance).max(), name
        assert np.abs(balance).max() < tolerance, (name, np.abs(balance).max())
    part = _json(server, jobs["kepler"], start=5, every=3)
    np.testing.assert_array_equal(part["work"], _json(server, jobs["kepler"])["work"][5::3])


def test_a_job_without_work_stores_none_and_runs_merged(server):
    job_id = server.submit({**PENDULUM, "work": False})
    assert server.wait_finished(job_id)["status"] == "completed"
    data = server.client.get(f"/v1/jobs/{job_id}/trajectory").json()
    assert data["work"] is None
    merged = raydamp.integrate(raydamp.models.DampedPendulum(eps=0.01), [2.827433388], [0.0], method="3s", h=0.2,
                               t_end=40, save_every=2)
    assert data["q"] == merged.q.tolist()  # the same run as raydamp's default (work=False), bit for bit
    server.client.delete(f"/v1/jobs/{job_id}")


def test_decimation_applies_to_files(server, jobs, tmp_path):
    reference = _json(server, jobs["kepler"], start=3, stop=150, every=7)
    response = server.client.get(f"/v1/jobs/{jobs['kepler']}/trajectory",
                                 params={"format": "npz", "start": 3, "stop": 150, "every": 7})
    (tmp_path / "d.npz").write_bytes(response.content)
    np.testing.assert_array_equal(raydamp.load(tmp_path / "d.npz").q, reference["q"])


def test_empty_selection_is_422_naming_start(server, jobs):
    """Found by the schemathesis run: this 422's detail was a string, not the declared list."""
    response = server.client.get(f"/v1/jobs/{jobs['pendulum']}/trajectory", params={"format": "csv", "start": 10**6})
    assert response.status_code == 422
    assert [tuple(e["loc"]) for e in response.json()["detail"]] == [("query", "start")]


def test_unknown_format_is_422_naming_format(server, jobs):
    response = server.client.get(f"/v1/jobs/{jobs['pendulum']}/trajectory", params={"format": "xlsx"})
    assert response.status_code == 422
    assert [tuple(e["loc"]) for e in response.json()["detail"]] == [("query", "format")]


@pytest.mark.parametrize(("name", "kind", "params"), [
    ("pendulum", "energy", {}), ("pendulum", "phase", {}), ("kepler", "energy", {"width": 640, "height": 480}),
    ("kepler", "phase", {"coordinate": "y"}), ("kepler", "projection", {"x": "x", "y": "y"})])
def test_plots_are_pngs_of_the_asked_size(server, jobs, name, kind, params):
    response = server.client.get(f"/v1/jobs/{jobs[name]}/plots/{kind}.png", params=params)
    assert response.status_code == 200, response.text
    assert response.headers["content-type"] == "image/png"
    image = Image.open(io.BytesIO(response.content))
    assert image.size == (params.get("width", 800), params.get("height", 500))
    pixels = np.asarray(image.convert("L"), dtype=float)
    assert pixels.std() > 5  # something was drawn, not a blank canvas


def test_impossible_plots_are_422(server, jobs):
    one_dimensional = server.client.get(f"/v1/jobs/{jobs['pendulum']}/plots/projection.png")
    assert one_dimensional.status_code == 422
    assert "at least two coordinates" in json.dumps(one_dimensional.json())
    unknown = server.client.get(f"/v1/jobs/{jobs['kepler']}/plots/phase.png", params={"coordinate": "w"})
    assert unknown.status_code == 422
    assert unknown.json()["detail"][0]["loc"] == ["query", "coordinate"]
    # Each named by its own parameter: a bad y was blamed on x, and "²" (a digit to str.isdigit, not to int())
    # on the path's kind, with int()'s message.
    for kind, params, where in [("projection", {"x": "x", "y": "w"}, "y"), ("projection", {"x": "w"}, "x"),
                                ("phase", {"coordinate": "\u00b2"}, "coordinate")]:
        bad = server.client.get(f"/v1/jobs/{jobs['kepler']}/plots/{kind}.png", params=params)
        assert bad.status_code == 422, bad.text
        detail = bad.json()["detail"][0]
        assert detail["loc"] == ["query", where] and "unknown coordinate" in detail["msg"], detail
    assert server.client.get(f"/v1/jobs/{jobs['kepler']}/plots/histogram.png").status_code == 422
    assert server.client.get("/v1/jobs/nope/plots/energy.png").status_code == 404


def test_a_spec_this_version_refuses_keeps_its_json_and_says_why_files_are_409(start_server):
    """A job stored by an earlier version whose spec this one refuses (save_dofs [] is refused since it saved
    every coordinate; a momentum map named "energy" since the CSV had two such columns): its files and plots,
    whose names and provenance come from the validated spec, were a 500."""
    import sqlite3

    server = start_server()
    job_id = server.submit({"model": "elastic_pendulum", "method": "3s", "h": 0.1, "n_steps": 20,
                            "initial_state": {"q": [0.0, 1.55884573, -0.6], "p": [1.34164079, 0.0, 0.0]}})
    assert server.wait_finished(job_id)["status"] == "completed"
    server.stop()
    with sqlite3.connect(server.db) as db:
        spec = json.loads(db.execute("SELECT spec FROM jobs WHERE id = ?", (job_id,)).fetchone()[0])
        db.execute("UPDATE jobs SET spec = ? WHERE id = ?", (json.dumps({**spec, "save_dofs": []}), job_id))
    server.start()
    assert len(server.client.get(f"/v1/jobs/{job_id}/trajectory").json()["t"]) == 21
    for url in (f"/v1/jobs/{job_id}/trajectory?format=netcdf", f"/v1/jobs/{job_id}/plots/energy.png"):
        response = server.client.get(url)
        assert response.status_code == 409, response.text
        assert "save_dofs" in response.json()["detail"] and "served as JSON only" in response.json()["detail"]


def test_plots_are_drawn_outside_the_servers_process(server, jobs):
    # Drawn in the server, matplotlib held the interpreter lock for the whole drawing (a 3000 x 3000 phase plot
    # held /healthz for 2 s, thirty at once for 4.6 s) and kept the memory it took (22.5 GB after thirty; a
    # service audit). A check process draws them: the server never loads matplotlib's renderer.
    for kind in ("energy", "phase"):
        response = server.client.get(f"/v1/jobs/{jobs['kepler']}/plots/{kind}.png",
                                     params={"width": 1200, "height": 900})
        assert response.status_code == 200 and response.content.startswith(b"\x89PNG")
    maps = Path(f"/proc/{server.process.pid}/maps").read_text()
    assert "_backend_agg" not in maps and "matplotlib" not in maps


def test_a_refused_plot_reads_no_stored_array(tmp_path, monkeypatch):
    """Issue 44, N3: forty plots at once on a large job each read its decimated trajectory in the server before
    32 of them got 429 (+2.7 GB). A plot now takes its place among the checks, then its large-fetch slot, and only
    then reads; a refused one reads nothing."""
    import asyncio
    import time

    import httpx

    import raydamp_service.routes.jobs as routes
    from raydamp_service.app import create_app
    from raydamp_service.config import Settings

    reads = []
    read_arrays = routes.read_arrays
    monkeypatch.setattr(routes, "read_arrays", lambda *args: (reads.append(1), read_arrays(*args))[1])

    async def plots() -> tuple[int, int, dict[str, str]]:
        app = create_app(Settings(db=tmp_path / "jobs.sqlite3", check_workers=1, max_pending_checks=1))
        async with app.router.lifespan_context(app), httpx.AsyncClient(
                transport=httpx.ASGITransport(app=app), base_url="http://127.0.0.1") as client:
            job_id = (await client.post("/v1/jobs", json=PENDULUM)).json()["id"]
            deadline = time.monotonic() + 60
            while (await client.get(f"/v1/jobs/{job_id}")).json()["status"] != "completed":
                assert time.monotonic() < deadline
                await asyncio.sleep(0.02)
            app.state.checks._pending.acquire()  # the one place among the checks is taken
            refused = await client.get(f"/v1/jobs/{job_id}/plots/energy.png")
            before = len(reads)
            app.state.checks._pending.release()
            return refused.status_code, before, dict(refused.headers)

    status, reads_when_refused, headers = asyncio.run(plots())
    assert status == 429 and headers["retry-after"] == "5"
    assert reads_when_refused == 0
