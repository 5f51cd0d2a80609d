"""A job's trajectory as the store keeps it: the arrays a run saves per point (SAVED), each a column of float64
blobs in the trajectories table, read in slices (stream.py) and turned back into a Solution (downloads.py)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["SAVED", "Saved", "StoredTrajectory", "TrajectoryArrays"]


@dataclass(frozen=True)
class Saved:
    """An array a run saves per point: its name (blob column, Solution attribute, Trajectory field), its row's width
    ("": one value, else a StoredTrajectory field: dim, momenta, springs), optional: NULL if not run."""

    name: str
    width: str = ""
    optional: bool = False


# In the order of the table and the JSON: adding one is a line here and a field of TrajectoryArrays and Trajectory.
SAVED = (Saved("t"), Saved("q", "dim"), Saved("p", "dim"), Saved("energy"),
         Saved("spring_forces", "springs", optional=True), Saved("spring_deformations", "springs", optional=True),
         Saved("hysteretic_work", "springs", optional=True),
         Saved("momentum", "momenta"),
         Saved("work", optional=True),  # the damping work W(t)
         Saved("load_work", optional=True))  # the load's work W_f(t): a job with a load
# The springs' width has no column of its own: it is the forces' blob's length per point.
SPRINGS_SQL = "COALESCE(length(spring_forces) / (8 * points), 0)"
WIDTH_SQL = {"dim": "dim", "momenta": "momenta", "springs": SPRINGS_SQL}


@dataclass(frozen=True)
class TrajectoryArrays:
    """The saved points (SAVED): t (N,), q and p (N, n), energy (N,), spring_forces, spring_deformations and
    hysteretic_work (N, springs), momentum (N, m), work and load_work (N,)."""

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    energy: np.ndarray
    spring_forces: np.ndarray | None = field(default=None, kw_only=True)
    spring_deformations: np.ndarray | None = field(default=None, kw_only=True)
    hysteretic_work: np.ndarray | None = field(default=None, kw_only=True)
    momentum: np.ndarray
    work: np.ndarray | None = None
    load_work: np.ndarray | None = None

    @classmethod
    def of(cls, source: Any) -> TrajectoryArrays:
        """The arrays of a raydamp.Solution (or anything with them as attributes)."""
        return cls(**{a.name: getattr(source, a.name) for a in SAVED})


@dataclass(frozen=True)
class StoredTrajectory:
    """Where a trajectory's blobs are (the row), their shapes, and the optional arrays present."""

    rowid: int
    points: int
    dim: int
    momenta: int
    present: frozenset[str] = frozenset()
    springs: int = 0

    @classmethod
    def of(cls, arrays: Any, rowid: int = 0) -> StoredTrajectory:
        """What the store keeps of a run's arrays (TrajectoryArrays, or a raydamp.Solution)."""
        return cls(rowid, arrays.t.size, arrays.q.shape[1], arrays.momentum.shape[1],
                   frozenset(a.name for a in SAVED if a.optional and getattr(arrays, a.name) is not None),
                   0 if arrays.spring_forces is None else arrays.spring_forces.shape[1])

    def has(self, array: Saved) -> bool:
        return not array.optional or array.name in self.present

    def width(self, array: Saved) -> int:
        """Values per point of the array."""
        return getattr(self, array.width) if array.width else 1

    @property
    def row_bytes(self) -> int:
        """Stored bytes per saved point: every array kept (float64)."""
        return 8 * sum(self.width(a) for a in SAVED if self.has(a))
