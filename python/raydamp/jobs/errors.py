"""A job's errors name the JSON path of the field they are about, in the client's words."""

from __future__ import annotations

__all__ = ["JobError", "path_error", "head_path"]


def head_path(message: str) -> tuple[str | int, ...]:
    """The path a message starts with: "save_dofs[0]: ..." -> ("save_dofs", 0), "h must ..." -> ("h",)."""
    path = message.split(" ", 1)[0].rstrip(":").replace("]", "").replace("[", ".").split(".")
    return tuple(int(part) if part.isdigit() else part for part in path if part)


class JobError(ValueError):
    """A job that cannot run. ``loc`` is the JSON path of the offending field (("initial_state", "q"),
    ("system", "dampers", "bonds", 3)); the message starts with that path."""

    def __init__(self, loc: tuple[str | int, ...], message: str):
        super().__init__(message)
        self.loc = tuple(loc)
        self.message = message

    def within(self, *prefix: str | int) -> JobError:
        """The same error one level down: a sweep's job is at ("job", ...)."""
        return JobError((*prefix, *self.loc), ".".join(map(str, prefix)) + "." + self.message)


def path_error(error: ValueError, schema: type) -> JobError:
    """A Chain or LinearStructure message starts with the path inside "system" ("dampers.bonds[3]: ...",
    "K.coo.rows[2]: ...", "n must be ..."): the loc is that path when its head is a field of schema."""
    message = str(error)
    loc = head_path(message)
    if not loc or loc[0] not in schema.model_fields:
        loc = ()
    return JobError(("system", *loc), f"system.{message}")
