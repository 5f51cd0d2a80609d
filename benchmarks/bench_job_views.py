#!/usr/bin/env python3
"""Viewing stored jobs through a real `python -m raydamp_service`: GET /v1/jobs (the list) and
GET /v1/jobs/{id}, for small jobs (a pendulum) and for jobs carrying a linear structure's matrices
inline (COO triplets, some 10^4 numbers each), whose spec is what a view used to validate again.

Prints the server's CPU time per request (less sensitive than wall time to what else the two cores run)
and the wall-time median, side by side for each request. Serve another checkout with --root (e.g. the
main branch, for a before/after figure):

    .venv/bin/python benchmarks/bench_job_views.py
    .venv/bin/python benchmarks/bench_job_views.py --root /path/to/other/checkout

It prints figures and exits 0 whatever they are (a benchmark, not a test).
"""

from __future__ import annotations

import argparse
import math
import statistics
import tempfile
import time
from pathlib import Path

import httpx
from bench_service_systems import cpu_seconds, start_server  # one way to start and time a server

SMALL = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.01, "n_steps": 100,
         "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}


def structure_job(n: int) -> dict:
    """A fixed-free bar of n springs: K tridiagonal (3n - 2 triplets), M lumped, f pulling the free end; ten steps
    from rest."""
    rows, cols, values = [], [], []
    for i in range(n):
        rows.append(i)
        cols.append(i)
        values.append(2.0 if i < n - 1 else 1.0)
        if i + 1 < n:
            rows += [i, i + 1]
            cols += [i + 1, i]
            values += [-1.0, -1.0]
    system = {"kind": "linear_structure", "M": {"diagonal": [1.0] * n},
              "K": {"coo": {"shape": [n, n], "rows": rows, "cols": cols, "values": values}}, "alpha": 0.1,
              "f": [0.0] * (n - 1) + [1.0]}
    return {"system": system, "method": "2s", "h": 0.01, "n_steps": 10, "save_every": 10,
            "initial_state": {"rest": True}}


def measure(client: httpx.Client, pid: int, label: str, path: str, repeats: int, params=None) -> None:
    client.get(path, params=params).raise_for_status()  # warm
    walls = []
    cpu = cpu_seconds(pid)
    for _ in range(repeats):
        start = time.perf_counter()
        answer = client.get(path, params=params)
        walls.append(time.perf_counter() - start)
        answer.raise_for_status()
    cpu = cpu_seconds(pid) - cpu
    print(f"{label:<44} server CPU {1000 * cpu / repeats:7.2f} ms/request   wall p50 "
          f"{1000 * statistics.median(walls):7.2f} ms   "
          f"({len(answer.content) / 1024:.0f} KiB body, {repeats} requests)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[1],
                        help="the checkout to serve (its python/ and service/)")
    parser.add_argument("--small", type=int, default=200, help="pendulum jobs stored")
    parser.add_argument("--structures", type=int, default=20, help="linear-structure jobs stored")
    parser.add_argument("--dim", type=int, default=3000, help="coordinates of each structure")
    parser.add_argument("--repeats", type=int, default=40)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        process, base = start_server(args.root, Path(scratch) / "jobs.sqlite3", Path(scratch) / "log",
                                     RAYDAMP_MAX_QUEUED="100000")
        try:
            with httpx.Client(base_url=base, timeout=120) as client:
                ids = [client.post("/v1/jobs", json=SMALL).json()["id"] for _ in range(args.small)]
                big = structure_job(args.dim)
                ids += [client.post("/v1/jobs", json=big).json()["id"] for _ in range(args.structures)]
                while any(client.get(f"/v1/jobs/{i}").json()["status"] in ("queued", "running") for i in ids[-3:]):
                    time.sleep(0.2)
                total = args.small + args.structures
                print(f"{args.root}: {args.small} pendulum jobs, {args.structures} structures of {args.dim} "
                      "coordinates (inline COO)")
                measure(client, process.pid, f"GET /v1/jobs?limit={total} (all)", "/v1/jobs", args.repeats,
                        {"limit": total})
                measure(client, process.pid, "GET /v1/jobs?limit=10 (newest)", "/v1/jobs", args.repeats,
                        {"limit": 10})
                measure(client, process.pid, "GET /v1/jobs/{id} (a pendulum job)", f"/v1/jobs/{ids[0]}",
                        args.repeats * 5)
                measure(client, process.pid, "GET /v1/jobs/{id} (a structure job)", f"/v1/jobs/{ids[-1]}",
                        args.repeats)
        finally:
            process.terminate()
            process.wait(timeout=30)


if __name__ == "__main__":
    main()
