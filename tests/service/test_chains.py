"""Chains over HTTP: {"system": {"kind": "chain", ...}} with a mode start, a 10^6-site run through a
real server process saving three sites, the worker's peak memory bounded, and bad chains refused
with a 422 naming the path inside "system"."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import raydamp

SMALL = {"kind": "chain", "n": 64, "bond": "fput", "parameters": {"alpha": 0.25, "beta": 1.0},
         "boundary": "fixed", "dampers": {"bonds": [9, 19, 29], "c": 0.1}, "eps": 1.0}


def _peak_rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    raise AssertionError("no VmHWM in /proc status")


@pytest.mark.parametrize("on_site", [None, {"kind": "phi4", "k2": -0.5}])
def test_chain_job_matches_python(server, on_site, tmp_path):
    system = SMALL if on_site is None else {**SMALL, "on_site": on_site}
    job = {"system": system, "method": "3s", "step_size": 0.1, "n_steps": 500, "save_every": 100,
           "initial_state": {"mode": 1, "amplitude": 0.5}, "save_dofs": [0, 31, 63]}
    done = server.wait_finished(server.submit(job))
    assert done["status"] == "completed", done
    trajectory = server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()
    chain = raydamp.Chain.from_dict(system)
    q0, p0 = chain.normal_mode(1, 0.5)
    # A job records the damping work (work defaults to true), which runs 3s's steps unmerged.
    local = raydamp.integrate(chain, q0, p0, method="3s", h=0.1, n_steps=500, save_every=100, save_dofs=[0, 31, 63],
                              work=True)
    np.testing.assert_array_equal(np.array(trajectory["q"]), local.q)
    np.testing.assert_array_equal(np.array(trajectory["energy"]), local.energy)
    assert np.array(trajectory["q"]).shape == (6, 3)
    if on_site is None:  # the download says which coordinates it holds (its dofs were lost: None, "all")
        download = tmp_path / "chain.nc"
        download.write_bytes(server.client.get(f"/v1/jobs/{done['id']}/trajectory?format=netcdf").content)
        np.testing.assert_array_equal(raydamp.load(download).dofs, [0, 31, 63])


def test_million_site_chain_through_the_service(start_server):
    """10^6 sites, 3s with a dashpot on every 1000th bond, 600 steps saved every 300 at three sites.
    The run's own arrays (the state, its block checkpoints and the step's scratch vectors) are a
    few tens of MB; the bound below leaves room for the interpreter and the libraries."""
    server = start_server()
    pid = server.process.pid
    before = _peak_rss_mib(pid)
    n = 10**6
    system = {"kind": "chain", "n": n, "bond": "fput", "parameters": {"alpha": 0.25, "beta": 1.0},
              "dampers": {"bonds": list(range(999, n + 1, 1000)), "c": 0.1}}
    job = {"system": system, "method": "3s", "step_size": 0.05, "n_steps": 600, "save_every": 300,
           "initial_state": {"mode": 1, "amplitude": 1.0}, "save_dofs": [0, n // 2, n - 1]}
    done = server.wait_finished(server.submit(job), timeout=300)
    assert done["status"] == "completed", done
    trajectory = server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()
    assert np.array(trajectory["q"]).shape == (3, 3)
    # Mode 1 of the linear chain barely moves in 30 time units at the middle: still near its amplitude.
    assert 0.9 < trajectory["q"][-1][1] <= 1.0
    energy = np.array(trajectory["energy"])
    assert energy[-1] < energy[0]  # the dashpots took energy
    peak = _peak_rss_mib(pid)
    print(f"\nservice process peak RSS: {before:.0f} MiB before the job, {peak:.0f} MiB after")
    assert peak - before < 400, (before, peak)


@pytest.mark.parametrize("system, loc", [
    ({**SMALL, "n": 1}, ["body", "system", "n"]),
    ({**SMALL, "dampers": {"bonds": [65], "c": 0.1}}, ["body", "system", "dampers", "bonds", 0]),
    ({**SMALL, "parameters": {"gamma": 1.0}}, ["body", "system", "parameters", "gamma"]),
    ({**SMALL, "bond": "toda", "parameters": {"b": -1.0}}, ["body", "system", "parameters", "b"]),
    ({**SMALL, "on_site": {"kind": "quartic"}}, ["body", "system", "on_site", "kind"]),
    ({**SMALL, "on_site": {"kind": "sine", "g": -1.0}}, ["body", "system", "on_site", "g"]),
    ({**SMALL, "on_site": {"kind": "sine", "k": 1.0}}, ["body", "system", "on_site", "k"]),
])
def test_bad_chains_are_422_naming_the_path(server, system, loc):
    job = {"system": system, "method": "3s", "step_size": 0.1, "n_steps": 10,
           "initial_state": {"mode": 1, "amplitude": 0.5}}
    response = server.client.post("/v1/jobs", json=job)
    assert response.status_code == 422, response.text
    locs = [d["loc"] for d in response.json()["detail"]]
    assert any(list(found)[:len(loc)] == loc for found in locs), locs
