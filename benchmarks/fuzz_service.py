#!/usr/bin/env python3
"""A long hostile run against a real `python -m raydamp_service`: Schemathesis for a time budget (default
10 minutes) with every check (`--checks all`) and all four phases: examples, coverage, fuzzing and the
stateful phase, which chains operations by the links Schemathesis infers from the schemas and from the
Location headers of the submissions (POST /v1/jobs -> GET/cancel/DELETE /v1/jobs/{job_id}, its trajectory
and plots; the same for sweeps; POST /v1/files -> /v1/files/{file_id}).

Before the run a few real jobs, a sweep and an uploaded file are created, so that the stateful phase and
the fuzzed ids find finished results to read. Alongside Schemathesis, for the same time, valid traffic
(valid_jobs.py): random valid jobs of every system kind and load form, sweeps and uploads of every format,
their results read back, which random generation from the schema rarely reaches. Prints Schemathesis'
summary, the valid traffic's counts, then the counts issue 44 asks for: requests answered, server errors
(5xx), schema violations (answers whose status, content type, headers or body the schema does not
declare), other check failures, and the tracebacks the server logged. Exits 1 if there was any server
error, schema violation, or valid job refused or failed, or if Schemathesis ran no test case.

    .venv/bin/python benchmarks/fuzz_service.py                # 10 minutes (make fuzz)
    .venv/bin/python benchmarks/fuzz_service.py --seconds 60   # FUZZ_SECONDS=60 make fuzz
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import httpx  # noqa: E402
from bench_service_load import start_server  # noqa: E402 - the benchmarks' own server starter
from valid_jobs import ValidTraffic  # noqa: E402

SMALL = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.1, "n_steps": 200,
         "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}
MATRIX = b"%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 2.0\n2 1 -1.0\n2 2 2.0\n"
# Fuzzed jobs are held small (a generated n_steps may be anything the schema allows) so that the workers
# keep up; the limits themselves are part of what is fuzzed (a larger job gets its 422).
SERVER_ENV = {"RAYDAMP_MAX_STEPS": str(10**6), "RAYDAMP_MAX_SWEEP_STEPS": str(10**6),
              "RAYDAMP_MAX_SAVED_POINTS": str(10**5), "RAYDAMP_MAX_QUEUED": "200"}
# Checks that judge the schema's conformance (a violation), as opposed to the server's robustness (a 5xx).
SCHEMA_CHECKS = {"status_code_conformance", "content_type_conformance", "response_headers_conformance",
                 "response_schema_conformance"}


def seed_resources(base: str) -> None:
    """Real jobs, a sweep and a file, so that reads of results are reached and not only their 404s."""
    with httpx.Client(base_url=base, timeout=60) as client:
        jobs = [client.post("/v1/jobs", json=SMALL).json()["id"] for _ in range(3)]
        client.post("/v1/sweeps", json={"job": SMALL, "grid": {"eps": [0.0, 0.1]}})
        client.post("/v1/files", files={"file": ("k.mtx", MATRIX, "text/plain")})
        for job_id in jobs:
            while client.get(f"/v1/jobs/{job_id}").json()["status"] in ("queued", "running"):
                time.sleep(0.1)
        # Built once and cached by the app: Schemathesis' own fetch of it has a 10 s timeout, which building it
        # on a loaded machine can pass (the run then had no test case at all).
        client.get("/openapi.json", timeout=300).raise_for_status()


def count(ndjson: Path) -> tuple[Counter, int]:
    """Failures by check (each distinct failure once, as Schemathesis reports them) and the number of
    test cases run, from the run's NDJSON event stream."""
    failures: Counter = Counter()
    cases = 0
    for line in ndjson.read_text().splitlines():
        event = json.loads(line)
        for kind, body in event.items():
            if kind != "ScenarioFinished":
                continue
            recorder = body.get("recorder", {})
            cases += len(recorder.get("cases", {}))
            for checks in recorder.get("checks", {}).values():
                for check in checks:
                    if str(check.get("status")).lower() == "failure":
                        failures[check["name"]] += 1
    return failures, cases


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=int, default=int(os.environ.get("FUZZ_SECONDS", "600")))
    parser.add_argument("--workers", default="2", help="Schemathesis workers (its --workers)")
    parser.add_argument("--seed", type=int, default=None, help="Schemathesis' --seed, to repeat a run")
    parser.add_argument("--out", type=Path, default=None, help="keep the reports and the server's log here")
    args = parser.parse_args()
    os.environ.update(SERVER_ENV)
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        log = out / "server.log"
        process, base = start_server(Path(tmp) / "raydamp.sqlite3", log)
        try:
            seed_resources(base)
            command = [str(Path(sys.executable).with_name("schemathesis")), "run", f"{base}/openapi.json",
                       "--checks", "all", "--phases", "examples,coverage,fuzzing,stateful",
                       "--max-time", str(args.seconds), "--workers", args.workers, "--continue-on-failure",
                       "--request-timeout", "60", "--report", "ndjson,junit", "--report-dir", str(out),
                       "--no-color", "--suppress-health-check", "all", "--generation-database", ":memory:"]
            if args.seed is not None:
                command += ["--seed", str(args.seed)]
            valid = ValidTraffic(base, seed=args.seed or 0)
            alongside = threading.Thread(target=valid.run, args=(args.seconds,))
            began = time.monotonic()
            alongside.start()
            fuzzed = subprocess.run(command, check=False)
            alongside.join()
            elapsed = time.monotonic() - began
        finally:
            process.terminate()
            process.wait(timeout=60)
        failures, cases = count(next(out.glob("*.ndjson")))
        server_log = log.read_text(errors="replace")
        answered = Counter(line.rsplit('" ', 1)[1].split()[0] for line in server_log.splitlines()
                           if '" ' in line and " HTTP/1.1" in line)
        server_errors = sum(n for status, n in answered.items() if status.startswith("5"))
        violations = sum(n for name, n in failures.items() if name in SCHEMA_CHECKS)
        print("\n" + valid.report())
        print(f"fuzz: {elapsed:.0f} s, {sum(answered.values())} requests answered, {cases} test cases")
        print("answers by status: " + ", ".join(f"{status} x{n}" for status, n in sorted(answered.items())))
        print(f"server errors (5xx answers): {server_errors}; not_a_server_error failures: "
              f"{failures['not_a_server_error']}")
        print(f"schema violations: {violations} ("
              + (", ".join(f"{name} {failures[name]}" for name in sorted(SCHEMA_CHECKS)) + ")"))
        others = {name: n for name, n in failures.items() if name not in SCHEMA_CHECKS | {"not_a_server_error"}}
        print("other check failures: " + (", ".join(f"{name} {n}" for name, n in sorted(others.items())) or "none"))
        print(f"tracebacks in the server's log: {server_log.count('Traceback (most recent call last)')}")
        if cases == 0:
            print(f"Schemathesis ran no test case (its exit status {fuzzed.returncode}): the run fuzzed nothing")
        return 1 if server_errors or violations or failures["not_a_server_error"] or valid.findings or not cases else 0


if __name__ == "__main__":
    sys.exit(main())
