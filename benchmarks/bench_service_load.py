#!/usr/bin/env python3
"""The job service under a bounded loopback load, against a real `python -m raydamp_service`.

1. Submission: after a warm-up of 200 jobs, 2000 small jobs (the damped pendulum, 100 steps) posted
   by 16 concurrent clients in a closed loop; prints the submit throughput and the POST latency
   p50 / p99 / max beside the issue's targets (p99 <= 50 ms at >= 200 jobs/s), how long the queue
   takes to drain, and the server's CPU time per job (less sensitive than wall-time latency to what
   else the 2 cores run). Two load generators, one after the other: 16 keep-alive connections on
   one asyncio loop (cheap per request, like wrk: the latency is the server's), and 16 threads with
   an httpx.Client each (how a Python script submits; its threads share one GIL with each other,
   which adds client-side delay to the figures). The client shares the 2 cores with the server.
2. Large fetches: 8 clients fetch a 10^6-point trajectory over and over (a 429 from the large-fetch
   cap is retried after its Retry-After) while /healthz is polled every 50 ms; prints the /healthz
   latency p50 / p99 / max (target: within 100 ms), the fetches served and refused, and the server's
   RSS before and at its peak (target: growth < 100 MB per large fetch served at once).
Between the two, the floor: the server's CPU per GET /healthz under the same closed loop (uvicorn, FastAPI,
the middleware and a SQLite read; no job's CPU can be below it).

It prints figures and exits 0 whatever they are (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_service_load.py           # about a minute
    .venv/bin/python benchmarks/bench_service_load.py --jobs 500 --fetch-seconds 10
    .venv/bin/python benchmarks/bench_service_load.py --fetch-seconds 0   # submission only
    .venv/bin/python benchmarks/bench_service_load.py --fetch-seconds 0 --client asyncio
    RAYDAMP_ACCESS_LOG=false .venv/bin/python benchmarks/bench_service_load.py ...  # without the access log
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import io
import json
import math
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx

SERVICE_DIR = Path(__file__).resolve().parents[1] / "service"
SMALL = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.01,
         "n_steps": 100, "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}
MILLION = {**SMALL, "n_steps": 999_998}  # 999,999 saved points


def percentile(values: list[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(fraction * len(ordered)))]


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far (/proc/PID/stat, clock ticks)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def start_server(db: Path, log: Path) -> tuple[subprocess.Popen, str]:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    env = {**os.environ, "RAYDAMP_DB": str(db), "RAYDAMP_MAX_QUEUED": "100000",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(SERVICE_DIR), os.environ.get("PYTHONPATH")]))}
    with log.open("wb") as out:
        process = subprocess.Popen([sys.executable, "-m", "raydamp_service", "--port", str(port)], env=env,
                                   stdout=out, stderr=subprocess.STDOUT)
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


def _report(jobs: int, wall: float, latencies: list[float], accepted: int, refused: int, errors: int,
            concurrency: int, client: str) -> None:
    ms = [1000 * x for x in latencies]
    print(f"submit ({client} client): {jobs} jobs at concurrency {concurrency} in {wall:.2f} s = "
          f"{jobs / wall:.0f} jobs/s (target >= 200); accepted {accepted}, 429 {refused}, other errors {errors}")
    print(f"POST latency: p50 {percentile(ms, 0.5):.1f} ms, p99 {percentile(ms, 0.99):.1f} ms (target <= 50), "
          f"max {max(ms):.1f} ms")


async def _raw_posts(host: str, port: int, jobs: int, concurrency: int, ids: list[str],
                     latencies: list[float], probe: bool = False) -> tuple[int, int]:
    """`concurrency` keep-alive HTTP/1.1 connections on one event loop, each posting its next job as soon
    as the last is answered (a closed loop, like wrk): the client's own cost per request is tens of
    microseconds, so the latency measured is the server's. probe: GET /healthz instead (the floor)."""
    body = json.dumps(SMALL).encode()
    request = (f"POST /v1/jobs HTTP/1.1\r\nHost: {host}:{port}\r\nContent-Type: application/json\r\n"
               f"Content-Length: {len(body)}\r\n\r\n").encode() + body
    if probe:
        request = f"GET /healthz HTTP/1.1\r\nHost: {host}:{port}\r\n\r\n".encode()
    left, refused, errors = [jobs], [0], [0]

    async def read_body(reader: asyncio.StreamReader, head: bytes) -> bytes:
        headers = {name.strip().lower(): value.strip() for name, _, value in
                   (line.partition(b":") for line in head.split(b"\r\n")[1:] if line)}
        if b"content-length" in headers:
            return await reader.readexactly(int(headers[b"content-length"]))
        body = b""  # Transfer-Encoding: chunked
        while size := int((await reader.readuntil(b"\r\n")).strip().split(b";")[0], 16):
            body += (await reader.readexactly(size + 2))[:-2]
        await reader.readuntil(b"\r\n")
        return body

    async def connection() -> None:
        reader = writer = None
        while left[0] > 0:
            left[0] -= 1
            try:
                if writer is None:
                    reader, writer = await asyncio.open_connection(host, port)
                start = time.perf_counter()
                writer.write(request)
                head = await reader.readuntil(b"\r\n\r\n")
                answer = await read_body(reader, head)
                latencies.append(time.perf_counter() - start)
            except (OSError, asyncio.IncompleteReadError, asyncio.LimitOverrunError, ValueError):
                errors[0] += 1  # counted, and the next job goes on a new connection
                if writer is not None:
                    writer.close()
                reader = writer = None
                continue
            status = int(head.split(b" ", 2)[1])
            if probe and status == 200:
                ids.append("")
            elif status == 202:
                ids.append(json.loads(answer)["id"])
            elif status == 429:
                refused[0] += 1
            else:
                errors[0] += 1
            if b"connection: close" in head.lower():
                writer.close()
                reader = writer = None
        if writer is not None:
            writer.close()
            await writer.wait_closed()

    await asyncio.gather(*(connection() for _ in range(concurrency)))
    return refused[0], errors[0]


def submission_raw(base: str, jobs: int, concurrency: int) -> list[str]:
    host, port = base.removeprefix("http://").rsplit(":", 1)
    ids: list[str] = []
    latencies: list[float] = []
    began = time.perf_counter()
    refused, errors = asyncio.run(_raw_posts(host, int(port), jobs, concurrency, ids, latencies))
    _report(jobs, time.perf_counter() - began, latencies, len(ids), refused, errors, concurrency, "asyncio")
    return ids


def http_floor(base: str, pid: int, requests: int, concurrency: int) -> None:
    """The server's CPU per GET /healthz under the same closed loop: what uvicorn, FastAPI, the middleware and
    one SQLite read cost per request, whatever the route does. A job's CPU cannot go below it."""
    host, port = base.removeprefix("http://").rsplit(":", 1)
    answered: list[str] = []
    cpu = cpu_seconds(pid)
    asyncio.run(_raw_posts(host, int(port), requests, concurrency, answered, [], probe=True))
    print(f"HTTP floor: {1000 * (cpu_seconds(pid) - cpu) / max(1, len(answered)):.2f} ms of server CPU per "
          f"GET /healthz ({len(answered)} answered at concurrency {concurrency})")


def submission_httpx(base: str, jobs: int, concurrency: int) -> list[str]:
    """The same load from a pool of threads each with an httpx.Client: the way a Python script would
    submit, but the 16 client threads contend for the client's own GIL, which adds to the latency
    measured (compare with the asyncio client in one run)."""
    latencies: list[float] = []
    ids: list[str] = []
    refused = errors = 0
    lock = threading.Lock()
    local = threading.local()

    def post(_: int) -> None:
        nonlocal refused, errors
        client = getattr(local, "client", None) or httpx.Client(base_url=base, timeout=60)
        local.client = client
        start = time.perf_counter()
        response = client.post("/v1/jobs", json=SMALL)
        elapsed = time.perf_counter() - start
        with lock:
            latencies.append(elapsed)
            if response.status_code == 202:
                ids.append(response.json()["id"])
            elif response.status_code == 429:
                refused += 1
            else:
                errors += 1

    began = time.perf_counter()
    with ThreadPoolExecutor(concurrency) as pool:
        list(pool.map(post, range(jobs)))
    _report(jobs, time.perf_counter() - began, latencies, len(ids), refused, errors, concurrency, "httpx threads")
    return ids


def drain(base: str, ids: list[str]) -> None:
    began = time.perf_counter()
    with httpx.Client(base_url=base, timeout=60) as client:
        while client.get("/v1/jobs", params={"status": "queued", "limit": 1}).json()["jobs"] or \
                client.get("/v1/jobs", params={"status": "running", "limit": 1}).json()["jobs"]:
            time.sleep(0.1)
        completed = len(client.get("/v1/jobs", params={"status": "completed", "limit": 1000}).json()["jobs"])
    print(f"drain: the queue emptied {time.perf_counter() - began:.1f} s after the last submission "
          f"({completed}+ completed listed)")


def large_fetches(base: str, pid: int, clients: int, seconds: float) -> None:
    with httpx.Client(base_url=base, timeout=120) as client:
        job_id = client.post("/v1/jobs", json=MILLION).json()["id"]
        while client.get(f"/v1/jobs/{job_id}").json()["status"] not in {"completed", "failed", "cancelled"}:
            time.sleep(0.1)
    url = f"/v1/jobs/{job_id}/trajectory"
    stop = threading.Event()
    served, refused, body_mb = [0], [0], [0.0]
    lock = threading.Lock()

    def fetch_loop() -> None:
        with httpx.Client(base_url=base, timeout=300) as client:
            while not stop.is_set():
                with client.stream("GET", url) as response:
                    if response.status_code == 429:
                        with lock:
                            refused[0] += 1
                        stop.wait(float(response.headers.get("retry-after", "1")))
                        continue
                    size = sum(len(piece) for piece in response.iter_bytes())
                with lock:
                    served[0] += 1
                    body_mb[0] = size / 1e6

    baseline = rss_mb(pid)
    peak = baseline
    health: list[float] = []
    threads = [threading.Thread(target=fetch_loop) for _ in range(clients)]
    for thread in threads:
        thread.start()
    with httpx.Client(base_url=base, timeout=120) as client:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            start = time.perf_counter()
            client.get("/healthz").raise_for_status()
            health.append(1000 * (time.perf_counter() - start))
            peak = max(peak, rss_mb(pid))
            time.sleep(0.05)
    stop.set()
    for thread in threads:
        thread.join()
    print(f"large fetches: {clients} clients for {seconds:.0f} s: {served[0]} bodies of {body_mb[0]:.0f} MB served, "
          f"{refused[0]} refused with 429 (max_large_fetches)")
    print(f"/healthz meanwhile: {len(health)} probes, p50 {statistics.median(health):.1f} ms, "
          f"p99 {percentile(health, 0.99):.1f} ms, max {max(health):.1f} ms (target <= 100)")
    print(f"server RSS: {baseline:.0f} MB before, {peak:.0f} MB at peak (+{peak - baseline:.0f} MB; "
          f"target < 100 MB per large fetch at once)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2000)
    parser.add_argument("--concurrency", type=int, default=16)
    parser.add_argument("--fetch-clients", type=int, default=8)
    parser.add_argument("--fetch-seconds", type=float, default=30.0)
    parser.add_argument("--warmup", type=int, default=200,
                        help="jobs posted first and not counted (a long-running service is warm)")
    parser.add_argument("--client", choices=("asyncio", "httpx", "both"), default="both",
                        help="the load generator(s) for the submission run")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        process, base = start_server(Path(tmp) / "raydamp.sqlite3", Path(tmp) / "server.log")
        try:
            if args.warmup:
                with contextlib.redirect_stdout(io.StringIO()):
                    drain(base, submission_raw(base, args.warmup, args.concurrency))
            cpu = cpu_seconds(process.pid)
            ids = []
            if args.client in ("asyncio", "both"):
                ids += submission_raw(base, args.jobs, args.concurrency)
                drain(base, ids)
            if args.client in ("httpx", "both"):
                ids += submission_httpx(base, args.jobs, args.concurrency)
                drain(base, ids)
            # Wall-time latency depends on what else the 2 cores run; the server's CPU per job does not
            # (much): it bounds the throughput one GIL can give, and so the latency at concurrency 16.
            access_log = os.environ.get("RAYDAMP_ACCESS_LOG", "true").lower() not in ("0", "false", "no", "off")
            print(f"server CPU: {1000 * (cpu_seconds(process.pid) - cpu) / max(1, len(ids)):.2f} ms per job "
                  f"(submission and run, all threads; access log {'on' if access_log else 'off'}: "
                  "RAYDAMP_ACCESS_LOG)")
            http_floor(base, process.pid, args.jobs, args.concurrency)
            if args.fetch_seconds > 0:
                large_fetches(base, process.pid, args.fetch_clients, args.fetch_seconds)
        finally:
            process.terminate()
            process.wait(timeout=30)


if __name__ == "__main__":
    main()
