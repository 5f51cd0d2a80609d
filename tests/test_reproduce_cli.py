"""The reproduce command: runs on the reduced setting and writes non-empty PNGs and a report."""

from __future__ import annotations

import subprocess
import sys

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def test_reproduce_quick_writes_figures_and_report(tmp_path):
    out = tmp_path / "repro"
    run = subprocess.run([sys.executable, "-m", "raydamp", "reproduce", "--out", str(out), "--quick"],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "claims hold" in run.stdout
    assert "12/12" in run.stderr  # the progress bar reached the end
    pngs = sorted(out.glob("*.png"))
    assert len(pngs) == 8
    for png in pngs:
        data = png.read_bytes()
        assert data.startswith(PNG_SIGNATURE) and len(data) > 10_000, png.name
    report = (out / "REPORT.md").read_text()
    for png in pngs:
        assert f"]({png.name})" in report
    assert report.count("| PASS |") + report.count("| FAIL |") == 21
    # The reduced run still shows every claim but the one explained disagreement.
    assert "20 of 21 claims hold" in run.stdout
    assert report.count("| FAIL |") == 1


def test_cli_needs_a_command():
    run = subprocess.run([sys.executable, "-m", "raydamp"], capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and "reproduce" in run.stderr
