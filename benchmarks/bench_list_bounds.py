#!/usr/bin/env python3
"""A 2 MB list of bad items in a job: how long its 422 takes, and /healthz meanwhile (issue 44, N2 and item 2).

Issue 44's target: the 422 in < 0.5 s, and /healthz < 0.5 s while it is being refused (500,000 bad save_dofs
took 5.4-9.6 s and held /healthz as long). A real service is started from each source tree given (default:
this checkout), each field's body is posted a few times while another thread polls /healthz, and the medians
and worst cases are printed side by side.

    .venv/bin/python benchmarks/bench_list_bounds.py
    .venv/bin/python benchmarks/bench_list_bounds.py --tree /tmp/old-checkout --tree .   # before and after

A tree needs its compiled module in python/raydamp (a copy of the installed _core*.so). Prints the figures
and exits 0 whatever they are (a benchmark, not a test).
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import httpx
from bench_service_systems import HealthzPoller, start_server

JOB = {"model": "damped_pendulum", "method": "3s", "h": 0.1, "n_steps": 10, "initial_state": {"q": [0.1], "p": [0.0]}}
STRUCTURE = {**JOB, "model": None, "initial_state": {"rest": True},
             "system": {"kind": "linear_structure", "M": {"diagonal": [1.0]},
                        "K": {"coo": {"shape": [1, 1], "rows": [0], "cols": [0], "values": [1.0]}}}}
BODY_BYTES = 2_000_000


def bodies() -> dict[str, tuple[str, bytes]]:
    """A field's name -> (route, a body of about 2 MB whose list holds -1s, or {}s where -1 may be an item)."""
    def fill(body: dict, path: tuple, item: str) -> bytes:
        marker = json.dumps("LIST")
        inner = body
        for part in path[:-1]:
            inner = inner[part]
        inner[path[-1]] = "LIST"
        text = json.dumps(body, separators=(",", ":"))
        count = (BODY_BYTES - len(text)) // (len(item) + 1)
        return text.replace(marker, "[" + ",".join([item] * count) + "]").encode()

    return {
        "save_dofs (-1)": ("/v1/jobs", fill(dict(JOB), ("save_dofs",), "-1")),
        "initial_state.q ({})": ("/v1/jobs", fill({**JOB, "initial_state": {"q": [], "p": [0.0]}},
                                                  ("initial_state", "q"), "{}")),
        "system.K.coo.rows (-1)": ("/v1/jobs", fill(json.loads(json.dumps(STRUCTURE)),
                                                   ("system", "K", "coo", "rows"), "-1")),
        "load.series.t ({})": ("/v1/jobs", fill({**JOB, "load": {"series": {"t": [], "values": [0.0],
                                                                            "direction": [1.0]}}},
                                                ("load", "series", "t"), "{}")),
        "grid.eps ({})": ("/v1/sweeps", fill({"job": {**JOB, "work": False}, "grid": {"eps": []}},
                                             ("grid", "eps"), "{}")),
    }


def measure(tree: Path, repeats: int) -> dict[str, tuple[float, float, float, int]]:
    """field -> (median 422 seconds, worst 422 seconds, worst /healthz seconds meanwhile, status)."""
    with tempfile.TemporaryDirectory() as tmp:
        server, base = start_server(tree, Path(tmp) / "db.sqlite3", Path(tmp) / "server.log")
        try:
            out = {}
            with httpx.Client(base_url=base, timeout=120) as client:
                for name, (route, body) in bodies().items():
                    answers, status = [], 0
                    with HealthzPoller(base) as poller:
                        poller.phase = "refuse"
                        for _ in range(repeats):
                            start = time.perf_counter()
                            status = client.post(route, content=body,
                                                 headers={"content-type": "application/json"}).status_code
                            answers.append(time.perf_counter() - start)
                    out[name] = (statistics.median(answers), max(answers), poller.slowest("refuse")[0], status)
            return out
        finally:
            server.terminate()
            server.wait(timeout=30)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tree", action="append", type=Path, help="a source tree (default: this checkout)")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    trees = args.tree or [Path(__file__).resolve().parents[1]]
    results = {tree: measure(tree.resolve(), args.repeats) for tree in trees}
    print(f"{'field (items)':<26}" + "".join(f"{str(tree)[-28:]:>44}" for tree in trees))
    print(f"{'':<26}" + "".join(f"{'422 median / worst, /healthz worst (s)':>44}" for _ in trees))
    for name in bodies():
        row = f"{name:<26}"
        for tree in trees:
            median, worst, health, status = results[tree][name]
            row += f"{f'{status}: {median:.3f} / {worst:.3f}, {health:.3f}':>44}"
        print(row)
    print("target (issue 44): 422 < 0.5 s, /healthz < 0.5 s meanwhile")


if __name__ == "__main__":
    main()
