"""``--temperature``, ``--seed`` and ``--stream`` of ``raydamp run`` and ``raydamp sweep``: the job
JSON's ``temperature``, ``seed`` and ``stream`` given on the command line, over the file's own.

A bad value is argparse's error (exit code 2, the flag named) before any file is read; a seed or
stream with no temperature, in the flags or the file, is refused by :func:`with_thermal_options`
(it would change nothing, which is more likely a mistake than a wish)."""

from __future__ import annotations

import argparse
import math
from typing import Any

from .._validation import MAX_SEED

__all__ = ["add_thermal_options", "with_thermal_options", "THERMAL_KEYS"]

THERMAL_KEYS = ("temperature", "seed", "stream")


def _temperature(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number (kT, energy units), got {text!r}") from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0 (kT), got {text!r}")
    return value


def _counter(text: str) -> int:
    """An integer in [0, 2^64), written in decimal (a seed or a stream)."""
    try:
        value = int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer in [0, 2^64), got {text!r}") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"expected an integer in [0, 2^64), got {text!r}")
    return value


def add_thermal_options(parser: argparse.ArgumentParser, members: str) -> None:
    """The three flags on a command's parser; ``members`` says how the command's runs draw streams."""
    parser.add_argument("--temperature", type=_temperature, metavar="KT",
                        help="kT of thermal noise, over the file's \"temperature\" (0: none); the damping flows "
                             "of 3s, 2s and baoab become their exact Ornstein-Uhlenbeck flows")
    parser.add_argument("--seed", type=_counter, metavar="S",
                        help="the noise's seed, an integer in [0, 2^64), over the file's \"seed\" (neither: a "
                             "fresh one, printed and kept in the result's provenance); the same seed gives the "
                             "same run bit for bit")
    parser.add_argument("--stream", type=_counter, metavar="K", help=f"which stream of the seed, over the file's "
                                                                     f"\"stream\" (default 0); {members}")


def with_thermal_options(spec: Any, temperature: float | None, seed: int | None, stream: int | None) -> Any:
    """The spec with the flags given (not None) in place of its own keys; ValueError naming the flag, or
    the file's key, for a seed or stream that would have no temperature to act on."""
    if not isinstance(spec, dict):  # a spec that is no JSON object: the job's own check says so
        return spec
    given = {key: value for key, value in zip(THERMAL_KEYS, (temperature, seed, stream)) if value is not None}
    spec = {**spec, **given}
    if not spec.get("temperature"):
        for key in ("seed", "stream"):
            if key in given:
                raise ValueError(f"--{key}: there is no temperature to draw noise at (give --temperature > 0 or "
                                 "the file's \"temperature\")")
            if spec.get(key) is not None:
                raise ValueError(f"{key}: the file gives a {key} but no temperature to draw noise at (give "
                                 "--temperature > 0 or the file's \"temperature\", or remove its \"" + key + "\")")
    return spec
