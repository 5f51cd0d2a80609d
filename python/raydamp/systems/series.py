"""The refusal of a damping flow whose Chebyshev series is too long (cpp/include/raydamp/damping/chebyshev.hpp)."""

from .._core import ChebyshevDegreeError

__all__ = ["ChebyshevDegreeError"]

ChebyshevDegreeError.__module__ = "raydamp"
ChebyshevDegreeError.__doc__ = """\
A LinearStructure's damping flow over one sub-step needs a Chebyshev series above degree 8192
(t beta lambda_max above about 1e7): 3s, 2s and baoab cannot take this h on this structure.
A ValueError; take a smaller h, or method="rks" with tableau="midpoint" (one sparse solve a step),
which integrate chooses itself when no method is named."""
