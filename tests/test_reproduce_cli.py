"""The reproduce command: runs on the reduced setting and writes non-empty PNGs and a report."""

from __future__ import annotations

import subprocess
import sys

import pytest

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    """`raydamp reproduce --quick` run once as a user runs it: (run, its output folder)."""
    out = tmp_path_factory.mktemp("repro")
    run = subprocess.run([sys.executable, "-m", "raydamp", "reproduce", "--out", str(out), "--quick"],
                         capture_output=True, text=True, timeout=600)
    return run, out


def test_reproduce_quick_writes_figures_and_report(reproduced):
    run, out = reproduced
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


def test_every_figure_passes_the_legibility_check(reproduced):
    # The report lists what raydamp.reproduce.legibility found in each of the 8 figures as it was saved
    # (figures.PROBLEMS); tests/test_reproduce_figures.py shows the check catches each kind of problem.
    run, out = reproduced
    report = (out / "REPORT.md").read_text()
    assert len(sorted(out.glob("*.png"))) == 8
    assert "every figure passes." in report, report[report.index("## Figures"):][:3000]


def test_cli_needs_a_command():
    run = subprocess.run([sys.executable, "-m", "raydamp"], capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and "reproduce" in run.stderr


def test_a_failed_claim_that_is_not_the_papers_makes_the_exit_status_1(tmp_path, monkeypatch, capsys):
    # It exited 0 whatever failed: a script or CI could not tell a claim the code no longer meets.
    import raydamp.reproduce
    from raydamp.cli.commands import main
    from raydamp.reproduce.claims import Claim

    papers = Claim("Sec. 6.2 (data)", "the data is an equilibrium", "k = 1: 0.3", "< 1e-12", False, paper_error=True)
    ours = Claim("Fig. 1", "dissipation hardly depends on h", "spread 0.2", "< 0.05", False)
    held = Claim("Fig. 2", "order 2", "2.0", "within 0.1", True)
    for claims, status in (([held, papers], 0), ([held, papers, ours], 1), ([held], 0)):
        monkeypatch.setattr(raydamp.reproduce, "run", lambda out, quick, progress, claims=claims: claims)
        assert main(["reproduce", "--out", str(tmp_path / "out"), "--no-progress"]) == status
        printed = capsys.readouterr().out
        assert f"{sum(c.passed for c in claims)} of {len(claims)} claims hold" in printed
        assert ("FAIL Fig. 1: dissipation hardly depends on h\n" in printed) == (ours in claims)
        assert ("FAIL Sec. 6.2 (data): the data is an equilibrium (the paper's" in printed) == (papers in claims)


def test_ctrl_c_ends_reproduce_with_one_line(tmp_path, monkeypatch, capsys):
    # A KeyboardInterrupt traceback before (CLI audit); the shell's convention for SIGINT is exit status 130.
    import raydamp.reproduce
    from raydamp.cli.commands import main

    def interrupted(out, quick, progress):
        raise KeyboardInterrupt

    monkeypatch.setattr(raydamp.reproduce, "run", interrupted)
    assert main(["reproduce", "--out", str(tmp_path / "out"), "--no-progress"]) == 130
    assert capsys.readouterr().err == (f"raydamp reproduce: interrupted; the figures made so far are in "
                                       f"{tmp_path / 'out'} (no REPORT.md)\n")
