"""Systems the tests (and benchmarks) share, written as raydamp.System."""

from __future__ import annotations

import numpy as np

import raydamp

ELASTIC = dict(
    coordinates=["x", "y", "z"],
    potential="k/2*(sqrt(x^2+y^2+z^2) - l)^2 - m*g*z",
    parameters={"k": 1.0, "l": 1.0, "m": 1.0, "g": -1.0},
    mass=1.0,
    damping={"dampers": [{"on": "sqrt(x^2+y^2+z^2)", "c": 1.0}]},
    momenta={"J3": "x*p_y - y*p_x"},
)


def elastic_pendulum(eps: float = 0.1) -> raydamp.System:
    """The paper's elastic pendulum (section 6.2): one dashpot on the spring's length."""
    return raydamp.System(**ELASTIC, eps=eps)


def damped_pendulum(eps: float = 0.01) -> raydamp.System:
    """The paper's damped pendulum (section 4.3) as a one-coordinate System."""
    return raydamp.System(["q"], "1 - cos(q)", damping={"scalar": 1.0}, eps=eps)


TWO_DOF_M = np.diag([1.0, 2.0])
TWO_DOF_K = np.array([[2.0, -1.0], [-1.0, 1.0]])


def two_dof() -> raydamp.System:
    """Two masses and springs, V = q^T K q / 2, Rayleigh damping D = 0.01 M + 0.001 K."""
    d = 0.01 * TWO_DOF_M + 0.001 * TWO_DOF_K
    return raydamp.System(["a", "b"], "(2*a^2 - 2*a*b + b^2)/2", mass=[1.0, 2.0], damping={"matrix": d.tolist()},
                          eps=1.0)


def kepler(eps: float = 0.01) -> raydamp.System:
    """A Kepler orbit with a dashpot on the radius (drag on radial motion only)."""
    return raydamp.System(["x", "y"], "-1/sqrt(x^2+y^2)", damping={"dampers": [{"on": "sqrt(x^2+y^2)", "c": 1.0}]},
                          eps=eps, momenta={"L": "x*p_y - y*p_x"})


CHAIN_MASS = [1.0, 1.5, 2.0]


def chain(eps: float = 0.2) -> raydamp.System:
    """Three masses on springs (the first tied to a wall), dashpots on the two springs
    between neighbours: D = c1 e1 e1^T + c2 e2 e2^T with e1 = (-1, 1, 0), e2 = (0, -1, 1),
    which do not commute."""
    return raydamp.System(["x1", "x2", "x3"], "k/2*(x1^2 + (x2-x1)^2 + (x3-x2)^2) + x1^4/4",
                          parameters={"k": 1.0}, mass=CHAIN_MASS,
                          damping={"dampers": [{"on": "x2 - x1", "c": 1.0}, {"on": "x3 - x2", "c": 0.5}]}, eps=eps)
