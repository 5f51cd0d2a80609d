"""SpecError: a ValueError that knows the path of the bad field in the system's dict.

The same dict is the Python keyword arguments, ``System.to_dict()`` and the JSON the
service takes, so one path ("damping.dampers[1].on") names the field everywhere: in
the message here, and as the 422's ``loc`` in the service.
"""

from __future__ import annotations

__all__ = ["SpecError", "path_text"]


def path_text(path: tuple[str | int, ...]) -> str:
    """("damping", "dampers", 1, "on") -> "damping.dampers[1].on"."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + part
    return out


class SpecError(ValueError):
    """A system description is wrong at ``path``; the message starts with that path."""

    def __init__(self, path: tuple[str | int, ...], message: str):
        self.path = tuple(path)
        self.detail = message
        super().__init__(f"{path_text(self.path)}: {message}" if self.path else message)
