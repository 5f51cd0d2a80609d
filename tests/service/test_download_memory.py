"""Trajectories are bounded in bytes, not points (issue 27, F3: a default-accepted job of 60,000 points x 1000
coordinates, 960 MB stored, took the service to 4 GB; four parallel NPZ downloads gave two 500s). Scaled down:
a 64 MB trajectory, files written a slice at a time, four downloads at once in every format."""

from __future__ import annotations

import io
import threading
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from starlette.background import BackgroundTask

SITES, STEPS = 400, 10_000  # 10,001 points x (3 + 2 x 400) floats: 64 MB stored
CHAIN = {"system": {"kind": "chain", "n": SITES, "bond": "fput"}, "method": "3s", "h": 0.05, "n_steps": STEPS,
         "initial_state": {"mode": 1, "amplitude": 0.5}}
STORED = (STEPS + 1) * (3 + 2 * SITES) * 8
SERVER_ENV = {"RAYDAMP_MAX_TRAJECTORY_BYTES": str(80 * 2**20), "RAYDAMP_MAX_LARGE_FETCHES": "4"}


def _kib(pid: int, field: str) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise LookupError(field)


@pytest.fixture(scope="module")
def large_job(module_server) -> str:
    job_id = module_server.submit(CHAIN)
    assert module_server.wait_finished(job_id)["status"] == "completed"
    return job_id


def test_a_trajectory_over_the_byte_limit_is_refused_at_submission(module_server):
    response = module_server.client.post("/v1/jobs", json={**CHAIN, "n_steps": 2 * STEPS})
    assert response.status_code == 422, response.text
    detail = response.json()["detail"][0]
    assert detail["loc"] == ["body", "save_every"], detail
    assert "max_trajectory_bytes" in detail["msg"] and "save_dofs" in detail["msg"], detail
    # Saving fewer points or fewer coordinates brings it under the limit.
    for fewer in ({"save_every": 2}, {"save_dofs": list(range(SITES // 2))}):
        job_id = module_server.submit({**CHAIN, "n_steps": 2 * STEPS, **fewer})
        module_server.wait_finished(job_id)  # not running while the next test measures the server


def test_four_parallel_downloads_stay_within_a_bound_and_agree(module_server, large_job):
    raydamp = pytest.importorskip("raydamp")
    server, url = module_server, f"/v1/jobs/{large_job}/trajectory"
    pid = server.process.pid
    for fmt in ("json", "csv", "npz", "netcdf"):  # warm: imports, the first connection of each kind
        server.client.get(url, params={"format": fmt, "stop": 3}).raise_for_status()
    baseline = _kib(pid, "VmRSS")
    peak, done = [baseline], threading.Event()

    def sample() -> None:
        while not done.is_set():
            peak[0] = max(peak[0], _kib(pid, "VmRSS"))
            time.sleep(0.005)

    bodies: dict[str, bytes] = {}
    statuses: dict[str, int] = {}

    def download(fmt: str) -> None:
        response = server.client.get(url, params={"format": fmt}, timeout=300)
        statuses[fmt] = response.status_code
        bodies[fmt] = response.content if fmt != "json" else b""  # the JSON is read, not kept

    sampler = threading.Thread(target=sample)
    sampler.start()
    try:
        threads = [threading.Thread(target=download, args=(fmt,)) for fmt in ("json", "csv", "npz", "netcdf")]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        done.set()
        sampler.join()
    assert statuses == {"json": 200, "csv": 200, "npz": 200, "netcdf": 200}, statuses
    growth = (peak[0] - baseline) * 1024
    print(f"\nfour downloads of a {STORED / 2**20:.0f} MB trajectory: server RSS {baseline / 1024:.0f} -> "
          f"{peak[0] / 1024:.0f} MiB (+{growth / 2**20:.0f} MiB)")
    # Read whole, each download held the trajectory at least once (4 x 64 MB) and its file besides.
    assert growth < STORED, f"the server grew by {growth / 2**20:.0f} MiB for a {STORED / 2**20:.0f} MB trajectory"

    # Written a slice at a time, the files are still raydamp's: each reads back whole and equal.
    with zipfile.ZipFile(io.BytesIO(bodies["npz"])) as archive:
        assert sorted(archive.namelist()) == ["attrs.npy", "energy.npy", "momentum.npy", "p.npy", "q.npy", "t.npy",
                                              "work.npy"]
    tmp = Path(server.db).parent
    (tmp / "whole.npz").write_bytes(bodies["npz"])
    (tmp / "whole.nc").write_bytes(bodies["netcdf"])
    from_npz, from_nc = raydamp.load(tmp / "whole.npz"), raydamp.load(tmp / "whole.nc")
    assert from_npz.q.shape == (STEPS + 1, SITES) and from_npz.provenance["job_id"] == large_job
    for name in ("t", "q", "p", "energy", "momentum", "work"):
        np.testing.assert_array_equal(getattr(from_nc, name), getattr(from_npz, name), err_msg=name)
    lines = bodies["csv"].splitlines()
    assert len(lines) == STEPS + 2 and lines[0].startswith(b"t,q_")
    for row in (0, 4321, STEPS):
        values = np.array(lines[row + 1].split(b","), dtype=float)
        np.testing.assert_array_equal(values[:1 + SITES], np.r_[from_npz.t[row], from_npz.q[row]])
    # A decimated selection across slices is the same slice of the whole.
    part = server.client.get(url, params={"format": "npz", "start": 5, "every": 7})
    (tmp / "part.npz").write_bytes(part.content)
    np.testing.assert_array_equal(raydamp.load(tmp / "part.npz").q, from_npz.q[5::7])


def test_a_plot_of_a_large_trajectory_reads_a_bounded_part(module_server, large_job):
    response = module_server.client.get(f"/v1/jobs/{large_job}/plots/phase.png", params={"coordinate": "3"})
    assert response.status_code == 200 and response.content.startswith(b"\x89PNG")


@pytest.mark.parametrize("fmt", ["json", "csv"])  # a streamed body, and a file sent from disk
def test_a_client_that_stops_reading_gives_its_large_fetch_slot_back(start_server, fmt):
    """Two sockets that asked for a large trajectory and never read held both large-fetch slots for as long
    as they stayed open: every other large fetch got 429 (an audit). A response that sends nothing for
    send_timeout_seconds is dropped, and its slot given back at once."""
    import socket

    server = start_server(RAYDAMP_MAX_LARGE_FETCHES="1", RAYDAMP_LARGE_FETCH_BYTES=str(2**20),
                          RAYDAMP_SEND_TIMEOUT_SECONDS="2")
    job_id = server.submit({"model": "damped_pendulum", "method": "3s", "h": 0.01, "n_steps": 200_000,
                            "initial_state": {"q": [1.0], "p": [0.0]}})  # 8 MB stored, some 20 MB of JSON
    assert server.wait_finished(job_id)["status"] == "completed"
    url = f"/v1/jobs/{job_id}/trajectory?format={fmt}"

    def status() -> int:  # a fetch's status, its body left unread (the connection closed: its slot freed)
        with server.client.stream("GET", url) as response:
            return response.status_code

    stalled = socket.socket()
    stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    stalled.connect((server.client.base_url.host, server.client.base_url.port))
    stalled.sendall(f"GET {url} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
    try:
        assert stalled.recv(12) == b"HTTP/1.1 200"  # its response began: it holds the slot; then nothing is read
        assert status() == 429
        deadline = time.monotonic() + 60
        # 2 s without a piece leaving, then the stalled response is dropped. Whole fetches: one that got the
        # slot and was closed unread would hold it a moment longer.
        while (response := server.client.get(url)).status_code == 429:
            assert time.monotonic() < deadline, "the stalled fetch kept its slot"
            time.sleep(0.2)
        assert response.status_code == 200 and len(response.content) > 2**20
    finally:
        stalled.close()



@pytest.mark.parametrize("min_rate, dropped", [(1e6, True), (0.0, False)])
def test_a_client_that_reads_too_slowly_gives_its_large_fetch_slot_back(min_rate, dropped):
    """Two clients reading a 193 MB trajectory at 50 KB/s sent every piece within send_timeout_seconds and held
    both large-fetch slots for an hour: every other large fetch got 429 (a service audit). Past
    send_timeout_seconds, a response read slower than min_send_bytes_per_second on average is dropped, its
    body's source closed and its slot given back. In-process: a client taking 20 ms a 10 kB piece (500 kB/s)."""
    import asyncio

    from raydamp_service.edge.deadlines import TimedStreamingResponse

    produced, released = [], []

    def pieces():
        for i in range(100):
            produced.append(i)
            yield b"x" * 10_000

    async def scenario():
        response = TimedStreamingResponse(pieces(), send_seconds=0.3, min_rate=min_rate,
                                          background=BackgroundTask(lambda: released.append(True)))
        received = asyncio.Event()

        async def receive():
            await received.wait()  # the client never leaves
            return {"type": "http.disconnect"}

        async def send(message):
            await asyncio.sleep(0.02)

        await response({"type": "http", "method": "GET", "path": "/v1/jobs/x/trajectory"}, receive, send)

    asyncio.run(scenario())
    assert released == [True]  # the slot is given back either way
    if dropped:  # after 0.3 s, at 500 kB/s against a floor of 1 MB/s: about 15 of the 100 pieces
        assert 5 < len(produced) < 40, len(produced)
    else:
        assert len(produced) == 100
