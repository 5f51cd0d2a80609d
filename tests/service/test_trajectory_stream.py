"""Trajectory fetches against a real service: streamed, decimated with start/stop/every, large ones
capped in number, and a 10^6-point fetch growing the server's memory by far less than its body."""

from __future__ import annotations

import gc
import math
import re
import threading
import time
from pathlib import Path

import pytest

from raydamp_service.trajectories.stream import FetchLease

PENDULUM = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.01,
            "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}
ELASTIC = {"model": "elastic_pendulum", "parameters": {"eps": 0.1}, "method": "2s", "step_size": 0.01,
           "n_steps": 2000, "initial_state": {"q": [0.0, 1.55884573, -0.6], "p": [1.34164079, 0.0, 0.0]}}
MILLION = 999_998  # steps: 999,999 saved points, the most max_saved_points = 10^6 allows at save_every 1


# The module's server: large fetches above 50,000 pendulum points (48 bytes each stored), one at a time.
SERVER_ENV = {"RAYDAMP_LARGE_FETCH_BYTES": str(50_000 * 48), "RAYDAMP_MAX_LARGE_FETCHES": "1"}


@pytest.fixture(scope="module")
def fetch_server(module_server):
    return module_server


@pytest.fixture(scope="module")
def jobs(fetch_server) -> dict[str, str]:
    ids = {"small": fetch_server.submit({**PENDULUM, "n_steps": 1000}), "elastic": fetch_server.submit(ELASTIC),
           "million": fetch_server.submit({**PENDULUM, "n_steps": MILLION})}
    for job_id in ids.values():
        assert fetch_server.wait_finished(job_id)["status"] == "completed"
    return ids


@pytest.mark.parametrize(("start", "stop", "every"), [(0, None, 1), (10, 500, 7), (0, None, 400), (999, None, 1),
                                                      (1000, None, 1), (5000, None, 3), (400, 100, 1), (3, 4, 10**9)])
def test_decimation_equals_slicing_the_whole(fetch_server, jobs, start, stop, every):
    for name in ("small", "elastic"):
        whole = fetch_server.client.get(f"/v1/jobs/{jobs[name]}/trajectory").json()
        params = {"start": start, "every": every, **({"stop": stop} if stop is not None else {})}
        response = fetch_server.client.get(f"/v1/jobs/{jobs[name]}/trajectory", params=params)
        assert response.status_code == 200 and response.headers["content-type"] == "application/json"
        part = response.json()
        for key in ("t", "q", "p", "energy", "momentum"):
            assert part[key] == whole[key][start:stop:every], (name, key)


def test_rows_wider_than_a_read_piece_are_read_one_by_one(fetch_server, jobs):
    # every x row bytes above 64 KiB takes the row-by-row path; the result must be the same slice.
    whole = fetch_server.client.get(f"/v1/jobs/{jobs['elastic']}/trajectory").json()
    part = fetch_server.client.get(f"/v1/jobs/{jobs['elastic']}/trajectory", params={"every": 3000 // 2}).json()
    assert part["q"] == whole["q"][::1500] and part["t"] == whole["t"][::1500]


def test_bad_decimation_is_422(fetch_server, jobs):
    for params in ({"every": 0}, {"start": -1}, {"stop": -5}, {"every": "x"}):
        response = fetch_server.client.get(f"/v1/jobs/{jobs['small']}/trajectory", params=params)
        assert response.status_code == 422 and response.json()["detail"][0]["loc"][0] == "query", params


def test_large_fetches_are_capped_and_the_slot_comes_back(fetch_server, jobs):
    url = f"/v1/jobs/{jobs['million']}/trajectory"
    with fetch_server.client.stream("GET", url) as first:  # 10^6 points: larger than any socket buffer
        assert first.status_code == 200
        pieces = first.iter_bytes()  # kept: dropping the iterator would close the connection
        next(pieces)
        second = fetch_server.client.get(url)
        assert second.status_code == 429 and second.headers["retry-after"] == "1"
        assert "max_large_fetches" in second.json()["detail"]
        # Small and decimated fetches are not held up by the large one.
        assert fetch_server.client.get(url, params={"every": 100}).status_code == 200
        assert fetch_server.client.get("/healthz").status_code == 200
    # The client went away mid-body: the slot is released, without waiting for the body to end.
    deadline = time.monotonic() + 30
    while (status := fetch_server.client.get(url, params={"stop": 60_000}).status_code) == 429:
        assert time.monotonic() < deadline, "the large-fetch slot was never released"
        time.sleep(0.1)
    assert status == 200


def _kib(pid: int, field: str) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise LookupError(field)


def test_a_million_point_fetch_streams_in_bounded_memory(fetch_server, jobs):
    """The audit measured +0.9 GB per 10^6-point fetch; the body must now stream in well under 100 MB."""
    pid = fetch_server.process.pid
    url = f"/v1/jobs/{jobs['million']}/trajectory"
    fetch_server.client.get(url, params={"stop": 10}).raise_for_status()  # warm: imports, first connection
    baseline = _kib(pid, "VmRSS")
    peak, done = [baseline], threading.Event()

    def sample() -> None:
        while not done.is_set():
            peak[0] = max(peak[0], _kib(pid, "VmRSS"))
            time.sleep(0.005)

    sampler = threading.Thread(target=sample)
    sampler.start()
    size, tail, momentum_then_work = 0, b"", False
    try:
        with fetch_server.client.stream("GET", url) as response:
            assert response.status_code == 200
            for piece in response.iter_bytes():
                window = tail + piece
                momentum_then_work = momentum_then_work or b'[],[],[]],"work":[0.0,' in window
                size, tail = size + len(piece), window[-200:]
    finally:
        done.set()
        sampler.join()
    growth_mb = (peak[0] - baseline) / 1024
    print(f"10^6-point fetch: {size / 1e6:.0f} MB of JSON, server RSS {baseline / 1024:.0f} MB -> peak "
          f"{peak[0] / 1024:.0f} MB (+{growth_mb:.1f} MB)")
    assert size > 60e6  # the premise: a body far larger than the memory bound
    # ... momentum, then work, then the load's work (null: this run has no load)
    assert momentum_then_work and re.search(rb',[0-9.e+-]+\],"load_work":null\}$', tail), tail[-50:]
    assert growth_mb < 100, growth_mb
    # And the streamed body is the same data: the last points agree with a decimated fetch.
    end = fetch_server.client.get(url, params={"start": MILLION - 2}).json()
    assert len(end["t"]) == 3 and end["t"][-1] == pytest.approx(MILLION * 0.01, rel=1e-12)


def test_a_lease_is_released_once_by_whoever_ends_first():
    semaphore = threading.Semaphore(1)
    assert semaphore.acquire(blocking=False)
    lease = FetchLease(semaphore)
    lease.release()
    lease.release()  # a second release must not hand out a second slot
    assert semaphore.acquire(blocking=False) and not semaphore.acquire(blocking=False)
    FetchLease(semaphore)  # dropped unreleased, as when a client leaves before the first byte
    gc.collect()
    assert semaphore.acquire(blocking=False)
