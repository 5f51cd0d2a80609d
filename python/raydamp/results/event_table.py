"""A run's events table (raydamp.run.events locates the crossings; this is what a Solution carries, saves and
reads back)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["EventTable"]


class EventTable:
    """Every crossing a run found, in time order: ``name`` (n,), ``event`` (index into the list given),
    ``direction`` (+1 rising, -1 falling), ``t`` (n,), and ``q``, ``p`` (n, dim) on the interpolant there.
    ``table["vertical"]`` is the sub-table of one event; ``len(table)`` the crossings."""

    def __init__(self, names: Sequence[str], event: np.ndarray, direction: np.ndarray, t: np.ndarray,
                 q: np.ndarray, p: np.ndarray, member: np.ndarray | None = None):
        self.member = None if member is None else np.asarray(member, dtype=np.int64)  # an ensemble's table
        self.names = tuple(names)
        self.event = np.asarray(event, dtype=np.int64)
        self.direction = np.asarray(direction, dtype=np.int64)
        self.t, self.q, self.p = t, q, p

    @property
    def name(self) -> np.ndarray:
        return np.array([self.names[i] for i in self.event], dtype=object)

    def __len__(self) -> int:
        return len(self.t)

    def __getitem__(self, name: str) -> EventTable:
        if name not in self.names:
            raise KeyError(f"no event named {name!r} (events: {', '.join(self.names)})")
        return self._rows(self.event == self.names.index(name))

    def of_member(self, i: int) -> EventTable:
        """An ensemble member's crossings (its single run's table)."""
        rows = self._rows(self.member == i)
        rows.member = None
        return rows

    def _rows(self, rows: np.ndarray) -> EventTable:
        return EventTable(self.names, self.event[rows], self.direction[rows], self.t[rows], self.q[rows],
                          self.p[rows], None if self.member is None else self.member[rows])

    def to_dict(self) -> dict[str, list]:
        """Plain lists (JSON): name, t, direction, q, p per crossing."""
        return {"name": [str(n) for n in self.name], "t": self.t.tolist(), "direction": self.direction.tolist(),
                "q": self.q.tolist(), "p": self.p.tolist()}

    def summary(self, limit: int = 1000, max_dim: int = 8) -> dict[str, Any]:
        """The summary's form (raydamp.jobs.summary.EventsSummary): count, and name, t, direction of the
        first ``limit`` crossings, with q and p there when a state has at most ``max_dim`` coordinates."""
        out = {"count": len(self), "name": [str(n) for n in self.name[:limit]], "t": self.t[:limit].tolist(),
               "direction": self.direction[:limit].tolist()}
        dim = np.shape(self.q)[1] if np.ndim(self.q) == 2 else 0
        if len(self) and dim <= max_dim:
            out["q"], out["p"] = np.asarray(self.q)[:limit].tolist(), np.asarray(self.p)[:limit].tolist()
        return out

    @classmethod
    def from_summary(cls, names: Sequence[str], summary: dict[str, Any], dim: int) -> EventTable:
        """The table a summary lists (its first crossings; q and p NaN where it lists none)."""
        rows = len(summary.get("t") or ())
        missing = np.full((rows, dim), np.nan)
        q = np.asarray(summary["q"], dtype=float).reshape(rows, dim) if summary.get("q") is not None else missing
        p = np.asarray(summary["p"], dtype=float).reshape(rows, dim) if summary.get("p") is not None else missing
        names = list(names)
        return cls(names, np.array([names.index(n) for n in summary.get("name") or ()], dtype=np.int64),
                   np.asarray(summary.get("direction") or (), dtype=np.int64),
                   np.asarray(summary.get("t") or (), dtype=float), q, p)

    def __repr__(self) -> str:
        return f"EventTable({len(self)} crossings of {', '.join(self.names)})"
