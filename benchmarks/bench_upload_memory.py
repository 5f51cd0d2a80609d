#!/usr/bin/env python3
"""A 64 MiB record uploaded to a real `python -m raydamp_service` (issue 44, N1): how much the server process grows,
how /healthz answers meanwhile, and what the upload gets.

Issue 44's target: the server's RSS grows at most 100 MB above the bytes received, /healthz answers within 0.5 s
throughout, and the answer is 201 (within RAYDAMP_MAX_RECORD_SAMPLES) or a 422/413 naming the limit; for a
one-column CSV, an .AT2 and a .npy. (benchmarks/bench_record_memory.py measures the library's parser alone.)

For each case a fresh server is started and warmed up (a job, an upload, a plot), its peak resident size is reset
(/proc/PID/clear_refs) before the upload and read after it (VmHWM), while another thread polls /healthz every 20 ms.
The check processes that parse the upload are not the server: their memory is bounded by check_memory_bytes.

    .venv/bin/python benchmarks/bench_upload_memory.py
    .venv/bin/python benchmarks/bench_upload_memory.py --mib 16

Prints the figures and exits 0 whatever they are (a benchmark, not a test).
"""

from __future__ import annotations

import argparse
import io
import os
import tempfile
import time
from pathlib import Path

import httpx
import numpy as np
from bench_service_systems import HealthzPoller, start_server

ROOT = Path(__file__).resolve().parents[1]

MiB = 2**20
WARM = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.1, "n_steps": 200,
        "initial_state": {"q": [1.0], "p": [0.0]}}


def status_kib(pid: int, field: str) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise LookupError(field)


def contents(mib: int) -> dict[str, tuple[str, bytes, dict[str, str]]]:
    """label -> (file name, bytes of about mib MiB, the server's environment)."""
    size = mib * MiB
    npts = size // 14
    at2 = f"H\nE\nG\nNPTS= {npts}, DT= .01 SEC\n".encode() + b"  .1234567E-01" * npts + b"\n"
    array = io.BytesIO()
    np.save(array, np.full(size // 8 - 16, 0.01))
    return {
        "one-column CSV, default limit (10^7 samples)": ("col1.csv", b"0\n" * (size // 2), {}),
        "one-column CSV, limit raised to its samples": ("col1.csv", b"0\n" * (size // 2),
                                                        {"RAYDAMP_MAX_RECORD_SAMPLES": str(size // 2)}),
        ".AT2 with a true NPTS": ("a.AT2", at2, {}),
        ".npy of float64 values": ("a.npy", array.getvalue(), {}),
    }


def one(label: str, name: str, content: bytes, env: dict[str, str]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        process, base = start_server(ROOT, Path(tmp) / "raydamp.sqlite3", Path(tmp) / "server.log",
                                     RAYDAMP_MAX_FILE_BYTES=str(max(len(content), 64 * MiB)), **env)
        try:
            measure(label, name, content, process.pid, base)
        finally:
            process.terminate()
            process.wait(timeout=60)


def measure(label: str, name: str, content: bytes, pid: int, base: str) -> None:
    with httpx.Client(base_url=base, timeout=600) as client:
        job = client.post("/v1/jobs", json=WARM).json()["id"]
        while client.get(f"/v1/jobs/{job}").json()["status"] not in ("completed", "failed"):
            time.sleep(0.05)
        client.get(f"/v1/jobs/{job}/plots/energy.png")
        client.post("/v1/files", files={"file": ("w.csv", b"0\n1\n2\n")})
        time.sleep(1.0)
        before = status_kib(pid, "VmRSS")
        Path(f"/proc/{pid}/clear_refs").write_text("5")  # VmHWM := VmRSS
        with HealthzPoller(base) as poller:
            poller.phase = "upload"
            began = time.perf_counter()
            response = client.post("/v1/files", files={"file": (name, content)})
            elapsed = time.perf_counter() - began
            time.sleep(0.2)
        peak, after = status_kib(pid, "VmHWM"), status_kib(pid, "VmRSS")
        slowest, probes = poller.slowest("upload")
    body = response.json()
    if response.status_code == 201:
        outcome = f"201, {body['samples']} samples ({body['format']})"
    else:
        outcome = f"{response.status_code}: {str(body.get('detail'))[:160]}"
    grown = (peak - before) / 1024
    print(f"{label}: {len(content) / MiB:.1f} MiB received in {elapsed:.1f} s -> {outcome}")
    print(f"  server RSS {before / 1024:.0f} MiB before, peak +{grown:.0f} MiB (+{grown - len(content) / MiB:.0f} MiB "
          f"above the bytes received; target <= 95 MiB = 100 MB), {after / 1024:.0f} MiB after")
    print(f"  /healthz meanwhile: {probes} probes, max {1000 * slowest:.0f} ms (target < 500)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mib", type=int, default=64, help="the files' size (the issue's is 64 MiB)")
    args = parser.parse_args()
    load = os.getloadavg()
    print(f"load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}, {os.cpu_count()} CPUs")
    for label, (name, content, env) in contents(args.mib).items():
        one(label, name, content, env)


if __name__ == "__main__":
    main()
