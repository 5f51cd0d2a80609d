"""Commands other packages add to `raydamp` through entry points: `raydamp serve` reaches the service
that way, never by an import in the library, and says in one line when the service is missing."""

from __future__ import annotations

import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest
import tomllib

import raydamp.cli.external as external
from raydamp.cli import main

ROOT = Path(__file__).resolve().parents[1]
SERVE = "raydamp_service.__main__:serve_command"


def only(monkeypatch, *points: EntryPoint) -> None:
    """Make ``points`` the only entry points installed in the group (whatever this environment has)."""
    monkeypatch.setattr(external, "entry_points", lambda group: [p for p in points if p.group == group])


def test_pyproject_declares_serve_in_the_group():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert pyproject["project"]["entry-points"][external.GROUP] == {"serve": SERVE}
    assert "raydamp-service" in pyproject["project"]["scripts"]


def test_an_installed_command_is_listed_and_loaded_only_when_run(tmp_path, monkeypatch, capsys):
    (tmp_path / "hello_command.py").write_text("def hello(argv):\n    print('hello', argv)\n    return 3\n")
    info = tmp_path / "hello_command-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: hello-command\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[{external.GROUP}]\nhello = hello_command:hello\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert main(["models"]) == 0
    assert "hello_command" not in sys.modules
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "hello" in capsys.readouterr().out
    assert main(["hello", "--loud", "x"]) == 3
    assert capsys.readouterr().out == "hello ['--loud', 'x']\n"
    monkeypatch.delitem(sys.modules, "hello_command")


def test_serve_reaches_the_service_through_its_entry_point(monkeypatch, capsys):
    service = pytest.importorskip("raydamp_service.__main__")
    only(monkeypatch, EntryPoint("serve", SERVE, external.GROUP))
    forwarded = []
    monkeypatch.setattr(service, "main", forwarded.append)
    assert main(["serve", "--host", "0.0.0.0", "--port", "8001"]) == 0
    assert forwarded == [["--host", "0.0.0.0", "--port", "8001"]]
    with pytest.raises(SystemExit) as done:
        main(["serve", "--help"])
    assert done.value.code == 0
    assert "usage: raydamp serve [-h] [--host HOST] [--port PORT]" in capsys.readouterr().out


@pytest.mark.parametrize("points", [(), (EntryPoint("serve", "raydamp_service_absent.__main__:serve_command",
                                                    external.GROUP),)], ids=["not installed", "cannot import"])
def test_serve_without_the_service_says_so_in_one_line(points, monkeypatch, capsys):
    only(monkeypatch, *points)
    assert main(["serve", "--port", "8001"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "raydamp serve needs the service extra (pip install 'raydamp[service]')" in err


def test_unknown_arguments_of_a_raydamp_command_are_still_refused(capsys):
    with pytest.raises(SystemExit) as done:
        main(["models", "--bogus"])
    assert done.value.code == 2
    assert "unrecognized arguments: --bogus" in capsys.readouterr().err
