"""Commands that other packages add to ``raydamp``: entry points in the group ``raydamp.commands``.

An entry point names a function ``command(argv) -> int | None`` that parses its own arguments
(``argv``: what follows the command's name) and returns the exit status. ``raydamp serve`` is
one: raydamp_service's ``serve_command``, declared in pyproject.toml. Commands are listed by name
without being imported (``raydamp methods`` never loads the service) and loaded only when run;
the library itself never imports them.
"""

from __future__ import annotations

import sys
from importlib.metadata import EntryPoint, entry_points
from typing import NamedTuple

__all__ = ["GROUP", "EXTRA_COMMANDS", "add_external_commands", "run_external"]

GROUP = "raydamp.commands"


class ExtraCommand(NamedTuple):
    extra: str
    help: str


# The commands raydamp's own extras bring: listed even where the extra is missing, so that the
# command then names the extra to install instead of being an unknown word.
EXTRA_COMMANDS = {"serve": ExtraCommand("service", "run the job service (same as python -m raydamp_service)")}


def add_external_commands(commands) -> dict[str, EntryPoint | None]:
    """Add a subparser for every command found in ``GROUP`` (raydamp's own commands keep their
    names) and every extra's command; return {name: its entry point, or None where the package
    providing it is not installed}."""
    found = {point.name: point for point in entry_points(group=GROUP) if point.name not in commands.choices}
    external: dict[str, EntryPoint | None] = {}
    for name in [*EXTRA_COMMANDS, *sorted(set(found) - set(EXTRA_COMMANDS))]:
        point = found.get(name)
        known = EXTRA_COMMANDS.get(name)
        text = known.help if known else f"a command of {point.module.split('.')[0]} (raydamp {name} --help)"
        commands.add_parser(name, help=text, add_help=False)
        external[name] = point
    return external


def run_external(name: str, point: EntryPoint | None, argv: list[str]) -> int:
    """Load the command's entry point and run it on ``argv``; one line on stderr and status 2 when
    the package providing it, or a package it needs, is not installed."""
    if point is None:  # an extra's command, its package absent
        return _cannot_run(name, f"no {GROUP!r} entry point {name!r} is installed")
    try:
        command = point.load()
    except ImportError as error:
        return _cannot_run(name, str(error))
    return command(argv) or 0


def _cannot_run(name: str, reason: str) -> int:
    known = EXTRA_COMMANDS.get(name)
    what = f"needs the {known.extra} extra (pip install 'raydamp[{known.extra}]')" if known else "cannot be loaded"
    print(f"raydamp {name} {what}: {reason}", file=sys.stderr)
    return 2
