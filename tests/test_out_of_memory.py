"""A run whose saved points outgrow memory stops with status out_of_memory and keeps the rows that fit
(it used to reserve every row up front and die with std::bad_alloc before its first step)."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

# In a child process whose address space is capped 700 MB above what it uses after importing raydamp:
# 5e7 saved rows of the pendulum need about 2 GB (t, q, p, energy: 32 bytes a row, and a growing
# vector briefly holds its old and new buffers), far past the cap.
CHILD = textwrap.dedent("""
    import json, resource
    import numpy as np
    import raydamp
    from raydamp.models import DampedPendulum

    def address_space():
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmSize:"))

    cap = address_space() + 700 * 2**20
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    sol = raydamp.integrate(DampedPendulum(eps=0.0), [1.0], [0.0], method="heun", h=1e-3, n_steps=50_000_000)
    rows = sol.t.size
    direct = raydamp.integrate(DampedPendulum(eps=0.0), [1.0], [0.0], method="heun", h=1e-3, n_steps=1_000_000)
    print(json.dumps({"status": sol.status, "message": sol.message, "rows": rows, "steps": sol.steps,
                      "shapes": [sol.q.shape[0], sol.p.shape[0], sol.energy.shape[0], sol.momentum.shape[0]],
                      "t_last": float(sol.t[-1]), "finite": bool(np.isfinite(sol.q).all()),
                      "distance_to_shorter_run": float(np.abs(sol.q[1_000_000] - direct.q[-1]).max())}))
""")


def test_saved_points_past_memory_stop_the_run_and_keep_what_fits():
    done = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["status"] == "out_of_memory", result
    assert "out of memory after saving" in result["message"] and "raise save_every" in result["message"]
    rows = result["rows"]
    assert 1_000_000 < rows < 50_000_000  # a good part was saved, not all of it
    assert result["shapes"] == [rows] * 4  # every array keeps the same rows
    assert result["steps"] == rows - 1 and abs(result["t_last"] - 1e-3 * (rows - 1)) < 1e-6
    # Row 10^6 is exactly the state of a run of 10^6 steps (heun, undamped: still swinging, so a row one
    # step off would differ by about h |p| ~ 1e-4).
    assert result["finite"] and result["distance_to_shorter_run"] == 0.0
