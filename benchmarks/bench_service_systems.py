#!/usr/bin/env python3
"""User-defined systems through a real `python -m raydamp_service`: does compiling them stall the server?

1. Responsiveness: a client polls /healthz every 20 ms while one job of the quartic
   (q0^2 + ... + q_{n-1}^2)^2 (80 coordinates by default: the largest the operation bound lets through)
   is submitted and run to completion; prints the slowest /healthz answer during the submission and during
   the run, and how long each took.
2. Server CPU per system job: `--small` jobs of a small system (two coordinates, a quartic and a dashpot),
   each with a different constant (so no cache can serve one job from another's compile), submitted one
   after another, then awaited; prints the server process's CPU time per job (its own threads only: the
   check processes are separate processes), and the same again for one system repeated.

It prints figures and exits 0 whatever they are (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_service_systems.py
    .venv/bin/python benchmarks/bench_service_systems.py --root /path/to/another/checkout   # compare
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx


def quartic(n: int, steps: int = 100) -> dict:
    return {"system": {"coordinates": n, "potential": "(" + "+".join(f"q{i}^2" for i in range(n)) + ")^2"},
            "method": "3s", "h": 0.001, "n_steps": steps, "initial_state": {"q": [0.1] * n, "p": [0.0] * n}}


def small(k: float) -> dict:
    return {"system": {"coordinates": ["x", "y"], "potential": f"x^2/2 + y^2/2 + {k!r}*(x - y)^4",
                       "damping": {"dampers": [{"on": "x - y"}]}, "eps": 0.1},
            "method": "3s", "h": 0.01, "n_steps": 100, "initial_state": {"q": [0.5, -0.2], "p": [0.0, 0.1]}}


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def start_server(root: Path, db: Path, log: Path, **settings: str) -> tuple[subprocess.Popen, str]:
    """The service of checkout `root` on a free port (settings: more RAYDAMP_* variables); (process, base URL)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    # The checkout's service; its raydamp too where the module is built in place (a developer's tree), else the
    # installed one (a fresh clone after `make setup`: python/raydamp holds no _core there).
    paths = [root / "service", *([root / "python"] if any((root / "python" / "raydamp").glob("_core*.so")) else [])]
    env = {**os.environ, **settings, "RAYDAMP_DB": str(db), "PYTHONPATH": os.pathsep.join(map(str, paths))}
    with log.open("wb") as out:
        process = subprocess.Popen([sys.executable, "-m", "raydamp_service", "--port", str(port)], env=env,
                                   stdout=out, stderr=subprocess.STDOUT, cwd=root)
    base = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 180  # a loaded machine takes a minute to import and warm up
    while time.monotonic() < deadline:
        try:
            if httpx.get(base + "/healthz").status_code == 200:
                return process, base
        except httpx.TransportError:
            time.sleep(0.1)
    process.kill()
    raise SystemExit(f"the service did not start:\n{log.read_text()[-2000:]}")


def wait_finished(client: httpx.Client, job_id: str, poll: float = 0.01) -> dict:
    while True:
        job = client.get(f"/v1/jobs/{job_id}").json()
        if job["status"] in ("completed", "failed", "cancelled"):
            return job
        time.sleep(poll)


class HealthzPoller:
    """/healthz every 20 ms on its own connection; latencies recorded with the phase they fell in."""

    def __init__(self, base: str):
        self.base, self.phase, self.samples = base, "idle", []
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)

    def _poll(self) -> None:
        with httpx.Client(base_url=self.base, timeout=60) as client:
            while not self._done.is_set():
                phase, began = self.phase, time.perf_counter()
                client.get("/healthz")
                self.samples.append((phase, time.perf_counter() - began))
                time.sleep(0.02)

    def __enter__(self) -> HealthzPoller:
        self._thread.start()
        return self

    def __exit__(self, *_) -> None:
        self._done.set()
        self._thread.join()

    def slowest(self, phase: str) -> tuple[float, int]:
        values = [latency for p, latency in self.samples if p == phase]
        return (max(values) if values else float("nan")), len(values)


def responsiveness(client: httpx.Client, base: str, n: int) -> None:
    assert client.post("/v1/jobs", json=quartic(2)).status_code == 202  # the check processes are up
    time.sleep(1.0)
    with HealthzPoller(base) as poller:
        time.sleep(0.3)
        poller.phase = "submit"
        began = time.perf_counter()
        response = client.post("/v1/jobs", json=quartic(n))
        submitted = time.perf_counter() - began
        if response.status_code != 202:
            print(f"  the {n}-coordinate job was refused: {response.status_code} {response.text[:300]}")
            return
        poller.phase = "run"
        job = wait_finished(client, response.json()["id"])
        ran = time.perf_counter() - began - submitted
        poller.phase = "after"
        time.sleep(0.3)
    for phase, took in (("submit", submitted), ("run", ran)):
        slowest, count = poller.slowest(phase)
        print(f"  {phase:6s}: {took:5.2f} s; /healthz slowest {1000 * slowest:7.1f} ms over {count} polls")
    print(f"  job status {job['status']}")


def cpu_per_job(client: httpx.Client, pid: int, specs: list[dict], label: str) -> None:
    """Submitted one after another (each answer waits for its check), then awaited: few polls."""
    before = cpu_seconds(pid)
    began = time.perf_counter()
    ids = []
    for spec in specs:
        response = client.post("/v1/jobs", json=spec)
        assert response.status_code == 202, response.text
        ids.append(response.json()["id"])
    assert all(wait_finished(client, job_id, poll=0.05)["status"] == "completed" for job_id in ids)
    wall = time.perf_counter() - began
    used = cpu_seconds(pid) - before
    print(f"  {label}: {len(specs)} jobs, server CPU {1000 * used / len(specs):6.2f} ms/job "
          f"(wall {1000 * wall / len(specs):.0f} ms/job)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[1],
                        help="the checkout whose service and python/raydamp are run (default: this one)")
    parser.add_argument("--n", type=int, default=80, help="coordinates of the quartic (default 80)")
    parser.add_argument("--small", type=int, default=40, help="small system jobs for the CPU figure")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        process, base = start_server(args.root.resolve(), Path(tmp) / "db.sqlite3", Path(tmp) / "server.log")
        try:
            with httpx.Client(base_url=base, timeout=120) as client:
                print(f"service from {args.root}")
                print(f"1. /healthz polled every 20 ms while a {args.n}-coordinate quartic job is submitted and run:")
                responsiveness(client, base, args.n)
                print("2. server CPU per small system job (submitted and run one after another):")
                cpu_per_job(client, process.pid, [small(0.25 + i / 1000) for i in range(args.small)],
                            "distinct systems")
                cpu_per_job(client, process.pid, [small(0.125)] * args.small, "one system repeated")
        finally:
            process.terminate()
            process.wait(timeout=30)


if __name__ == "__main__":
    main()
