#!/usr/bin/env python3
"""Plots through a real `python -m raydamp_service`: does drawing them stall the server, and does the server
keep their memory?

A job of 990,001 saved points is run; then `--concurrent` requests at once for its 3000 x 3000 phase plot (20,000
points drawn, the most a plot draws), while a client polls /healthz every 20 ms. Prints, per checkout (give
--root twice to compare two side by side in one run): the plots' wall time and statuses, the slowest /healthz
answer while they were drawn, and the server process's resident memory before, at its peak (VmHWM, reset before
the plots) and after. Issue 44's target for 40 at once: a refused plot (429) costs the server at most 10 MB, and
/healthz answers within 0.5 s.

It prints figures and exits 0 whatever they are (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_service_plots.py
    .venv/bin/python benchmarks/bench_service_plots.py --root /tmp/old --root .   # before and after
    .venv/bin/python benchmarks/bench_service_plots.py --concurrent 40            # issue 44's 40 at once
"""

from __future__ import annotations

import argparse
import concurrent.futures
import re
import tempfile
import time
from collections import Counter
from pathlib import Path

import httpx
from bench_service_systems import HealthzPoller, start_server, wait_finished

JOB = {"model": "elastic_pendulum", "parameters": {"eps": 0.1}, "method": "3s", "h": 0.01, "n_steps": 990_000,
       "initial_state": {"q": [0.0, 1.55884573, -0.6], "p": [1.34164079, 0.0, 0.0]}}


def rss_mb(pid: int, field: str = "VmRSS") -> float:
    return int(re.search(field + r":\s+(\d+)", Path(f"/proc/{pid}/status").read_text()).group(1)) / 1024


def one(root: Path, concurrent_plots: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        process, base = start_server(root, Path(tmp) / "db.sqlite3", Path(tmp) / "server.log",
                                     RAYDAMP_MAX_STEPS=str(10**7))
        try:
            with httpx.Client(base_url=base, timeout=600) as client:
                job_id = client.post("/v1/jobs", json=JOB).json()["id"]
                assert wait_finished(client, job_id, poll=0.2)["status"] == "completed"
                url = f"/v1/jobs/{job_id}/plots/phase.png?width=3000&height=3000"
                client.get(f"/v1/jobs/{job_id}/plots/energy.png")  # matplotlib imported, wherever it draws
                time.sleep(1.0)
                before = rss_mb(process.pid)
                Path(f"/proc/{process.pid}/clear_refs").write_text("5")  # the peak (VmHWM) from here
                with HealthzPoller(base) as poller, concurrent.futures.ThreadPoolExecutor(concurrent_plots) as pool:
                    time.sleep(0.3)
                    poller.phase = "plots"
                    began = time.perf_counter()
                    statuses = list(pool.map(lambda _: httpx.get(base + url, timeout=600).status_code,
                                             range(concurrent_plots)))
                    took = time.perf_counter() - began
                    poller.phase = "after"
                slowest, polls = poller.slowest("plots")
                peak = rss_mb(process.pid, "VmHWM")
                time.sleep(1.0)
                counts = Counter(statuses)
                print(f"  {concurrent_plots} plots at once: {took:5.2f} s, statuses {dict(sorted(counts.items()))}; "
                      f"/healthz slowest {1000 * slowest:7.1f} ms over {polls} polls; server RSS {before:6.0f} -> peak "
                      f"{peak:6.0f} -> {rss_mb(process.pid):6.0f} MB (peak growth per refused plot: "
                      f"{(peak - before) / max(1, concurrent_plots - counts[200]):.1f} MB)")
        finally:
            process.terminate()
            process.wait(timeout=30)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--root", type=Path, action="append",
                        help="a checkout whose service and python/raydamp are run (repeat to compare; default: this)")
    parser.add_argument("--concurrent", type=int, action="append", help="plots requested at once (default 1 and 4)")
    args = parser.parse_args()
    for root in args.root or [Path(__file__).resolve().parents[1]]:
        print(f"service from {root}")
        for count in args.concurrent or [1, 4]:
            one(root.resolve(), count)


if __name__ == "__main__":
    main()
