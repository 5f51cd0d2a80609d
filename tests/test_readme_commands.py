"""The README's `raydamp ...` command lines: every one parses as written and reaches the command it names.

tests/test_readme_examples.py runs the ```python blocks; the command lines in the README's indented blocks were
read by no test, so a flag renamed or dropped would leave them wrong unseen. Here each is handed to the CLI's own
parser with the command's work replaced by a recorder (nothing is run, no service is needed): placeholders the
README leaves to the reader (<id>, an optional [--flag VALUE]) are filled in, and `serve` is not started.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from raydamp.cli import advise_command, run_command, service_client
from raydamp.cli.commands import main

README = Path(__file__).resolve().parents[1] / "README.md"
_LINE = re.compile(r"^(?:    )?(?:\.venv/bin/)?raydamp (?P<rest>[a-z].*)$")


def readme_commands() -> list[tuple[int, list[str]]]:
    """(line, argv) of every `raydamp ...` command the README shows on a line of its own (or several after `;`)."""
    out, fenced = [], False
    for number, line in enumerate(README.read_text(encoding="utf-8").splitlines(), start=1):
        if line.startswith("```"):
            fenced = not fenced
            continue
        match = _LINE.match(line)
        if not match or not (fenced or line.startswith("    ")):  # code, not prose ("raydamp integrates")
            continue
        text = match.group("rest").split("  #", 1)[0]
        for part in text.split(";"):
            part = re.sub(r"^\s*(?:\.venv/bin/)?raydamp ", "", part.strip())
            part = part.replace("<id>", "0f1e2d").replace("[", "").replace("]", "").replace("--omega W", "--omega 2")
            out.append((number, shlex.split(part)))
    return out


def test_the_readme_shows_commands():
    commands = {argv[0] for _, argv in readme_commands()}
    assert {"run", "sweep", "advise", "jobs", "sweeps", "methods", "models", "serve"} <= commands, commands


@pytest.mark.parametrize("line, argv", readme_commands(), ids=lambda x: str(x) if isinstance(x, int) else " ".join(x))
def test_a_readme_command_parses(line, argv, monkeypatch, capsys):
    called = []

    def record(name):
        def recorder(*args, **kwargs):
            called.append((name, args, kwargs))
            return 0
        return recorder

    monkeypatch.setattr(run_command, "run_file", record("run"))
    monkeypatch.setattr(advise_command, "advise_file", record("advise"))
    monkeypatch.setattr(service_client, "client_command", record("client"))
    if argv[0] == "sweep":
        sweep_command = pytest.importorskip("raydamp.cli.sweep_command")
        monkeypatch.setattr(sweep_command, "sweep_file", record("sweep"))
    if argv[0] == "serve":  # an external command: it must be known to the parser; it is not started here
        import raydamp.cli.commands as commands

        monkeypatch.setattr(commands, "run_external", record("serve"))
    try:
        code = main(argv)
    except SystemExit as exit_:  # argparse refused the line
        pytest.fail(f"README.md:{line}: raydamp {' '.join(argv)}: {capsys.readouterr().err.strip()} ({exit_})")
    assert code == 0, f"README.md:{line}: raydamp {' '.join(argv)} exited {code}"
    if argv[0] in ("methods", "models"):
        assert capsys.readouterr().out.strip()  # these ran for real: they list something
    else:
        assert len(called) == 1, (line, argv)
