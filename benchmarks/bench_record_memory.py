#!/usr/bin/env python3
"""Peak memory of parsing an uploaded record (raydamp.loads.records.parse_record), per source tree.

Issue 44, N1: a record was parsed into a Python float (or list) per value, about 86 bytes per byte uploaded
(a 64 MiB one-column CSV: a MemoryError at 5.3 GB). Read in pieces with NumPy, it should cost a few times
samples x 8 bytes. Each case runs in a fresh process: the file's bytes are made first, then the growth of
the peak resident size (ru_maxrss) while parse_record runs is printed, with its time and outcome.

    .venv/bin/python benchmarks/bench_record_memory.py
    .venv/bin/python benchmarks/bench_record_memory.py --tree /tmp/old-checkout --tree .   # before and after

A tree needs its compiled module in python/raydamp (a copy of the installed _core*.so). Prints the figures
and exits 0 whatever they are (a benchmark, not a test).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

MiB = 2**20
def cases(mib: int) -> dict[str, tuple[str, str, dict[str, str]]]:
    """name -> (file name, code making about mib MiB of bytes, environment)."""
    rows = mib * MiB // 33
    return {
        f"{mib} MiB one column '0' (limit raised)": ("col1.csv", f"b'0\\n' * ({mib} * MiB // 2)",
                                                     {"RAYDAMP_MAX_RECORD_SAMPLES": str(mib * MiB)}),
        f"{mib} MiB one column '0', default limit": ("col1.csv", f"b'0\\n' * ({mib} * MiB // 2)", {}),
        f"{mib} MiB two columns t, a": ("ta.csv",
                                        f"b''.join(b'%.6f,%.12e\\n' % (k * 0.01, 0.5) for k in range({rows}))",
                                        {}),
        f"{mib} MiB .AT2": ("a.AT2", f"b'H\\nE\\nG\\nNPTS= {mib * MiB // 14}, DT= .01 SEC\\n' + b'  .1234567E-01' * "
                                     f"({mib * MiB // 14}) + b'\\n'", {}),
    }
CHILD = """
import json, resource, sys, time, tracemalloc
MiB = 2**20
content = {make}
from raydamp.loads.records import parse_record
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
start = time.perf_counter()
try:
    record, fmt = parse_record(content, name={name!r})
    outcome = f"{{fmt}}, {{record.values.size}} samples"
except ValueError as error:
    outcome = "refused: " + str(error)[:70]
elapsed = time.perf_counter() - start
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps([len(content), after - before, elapsed, outcome]))
"""


def run(tree: Path, name: str, make: str, env: dict[str, str]) -> list:
    path = os.pathsep.join([str(tree / "python"), str(tree / "service")])
    done = subprocess.run([sys.executable, "-c", CHILD.format(make=make, name=name)], capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": path, **env}, timeout=1800)
    if done.returncode != 0:
        return [0, 0, 0.0, "failed: " + done.stderr.strip().splitlines()[-1][:70]]
    return json.loads(done.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tree", action="append", type=Path, help="a source tree (default: this checkout)")
    parser.add_argument("--mib", type=int, default=64, help="the files' size (the issue's is 64 MiB)")
    args = parser.parse_args()
    trees = [tree.resolve() for tree in (args.tree or [Path(__file__).resolve().parents[1]])]
    for label, (name, make, env) in cases(args.mib).items():
        print(label)
        for tree in trees:
            size, grown, elapsed, outcome = run(tree, name, make, env)
            print(f"  {str(tree)[-30:]:>30}: {size / MiB:6.1f} MiB file, peak RSS +{grown / MiB:8.1f} MiB, "
                  f"{elapsed:6.2f} s, {outcome}")


if __name__ == "__main__":
    main()
