"""raydamp.GroundMotion: uniform base excitation, as OpenSees' UniformExcitation.

With the ground accelerating by a_g(t) along the influence vector r (r_i = 1 for the
coordinates that move with the ground in that direction), the motion relative to the ground
obeys the free equations plus the load f(t) = -M r a_g(t). The solution is that relative
motion; :meth:`raydamp.Solution.absolute_acceleration` adds r a_g(t) back.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._validation import real
from . import terms as T
from .forms import ground_motion_input
from .load import Load

__all__ = ["GroundMotion"]


class GroundMotion(Load):
    """Ground acceleration ``acceleration`` along ``direction`` (r, a vector over the coordinates).

    ``acceleration``: a :class:`raydamp.Load` made without a direction (``Load.series(t, a_g)``,
    ``Load.from_file(path, factor=9.81)``, ``Load.harmonic(1.0, w)`` with a scalar amplitude,
    ``Load.expression(...)``), a file path (read as :meth:`Load.from_file`), or a pair (t, a_g).
    It adds to other loads like any load.
    """

    __slots__ = ("r", "acceleration")

    def __init__(self, acceleration, direction, *, factor: float = 1.0):
        factor = real("factor", factor)  # "x", None or True made acceleration * factor a TypeError
        if isinstance(acceleration, (str, Path)):
            acceleration = Load.from_file(acceleration, factor=factor)
        elif isinstance(acceleration, tuple) and len(acceleration) == 2:
            acceleration = Load.series(*acceleration) * factor
        elif isinstance(acceleration, Load):
            acceleration = acceleration * factor
        else:
            raise ValueError("acceleration: give a raydamp.Load without direction, a file path or a pair (t, a_g)")
        r = T.direction("direction", direction)
        if r is None or isinstance(r, T.Ground):
            raise ValueError("direction: the influence vector r, a vector over the coordinates")
        terms = []
        for term in acceleration._scaled_terms():
            if isinstance(term, T.Harmonic):
                if isinstance(term.direction, T.Ground):  # {"ground": ...} inside a ground motion: no number
                    raise ValueError("acceleration: a harmonic ground acceleration has a scalar amplitude")
                amplitude = np.asarray(term.direction, dtype=float)
                if amplitude.size != 1:
                    raise ValueError("acceleration: a harmonic ground acceleration has a scalar amplitude")
                terms.append(T.scaled(T.Harmonic(T.Ground(r), term.omega, term.phase, term.scale, term.t_end),
                                      float(amplitude[0])))
            elif term.direction is not None or (isinstance(term, T.Series) and term.values.ndim == 2):
                raise ValueError("acceleration: a scalar history a_g(t), made without a direction")
            else:
                terms.append(_with_direction(term, T.Ground(r)))
        super().__init__(terms)
        object.__setattr__(self, "r", r)
        object.__setattr__(self, "acceleration", Load([_with_direction(t, None) if not isinstance(t, T.Harmonic)
                                                       else t for t in acceleration._scaled_terms()]))

    @classmethod
    def from_dict(cls, plain, *, name: str = "ground_motion", files=None) -> GroundMotion:
        """The ground motion of a JSON form (raydamp.loads.forms.GroundMotionInput): ``{"acceleration": a load
        without direction, "direction": r, "factor": 1}``; a ValueError names the path of the bad field."""
        return cls.from_form(ground_motion_input(plain, name), files, name)

    @classmethod
    def from_form(cls, form, files=None, name: str = "ground_motion") -> GroundMotion:
        """The ground motion of a validated form (a GroundMotionInput), built through this class's constructors."""
        return form.build(cls, Load, files, name)


def _with_direction(term, direction):
    from dataclasses import replace

    return replace(term, direction=direction)
