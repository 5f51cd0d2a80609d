"""A small finite-element assembly for the structure tests and benchmark: a 2-D elastic plate
(plane stress, linear triangles) in scipy.sparse, clamped along x = 0.

The rectangle [0, length] x [0, width] is cut into nx x ny squares, each into two triangles.
Nodes carry (u_x, u_y); the clamped nodes' degrees of freedom are dropped, leaving
2 nx (ny + 1) of them. Young's modulus E, Poisson ratio nu, density rho, unit thickness.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sparse


@dataclass(frozen=True)
class Plate:
    K: sparse.csc_matrix          # stiffness
    M: sparse.csc_matrix          # consistent mass
    M_lumped: sparse.csc_matrix   # row-sum lumped mass (diagonal)
    coordinates: np.ndarray       # (n_dof / 2, 2) node positions of the free nodes, in dof order
    tip: np.ndarray               # dof indices of u_y at the free end (x = length)

    @property
    def n(self) -> int:
        return self.K.shape[0]


def plate(nx: int, ny: int, *, length: float = 2.0, width: float = 1.0, E: float = 1.0, nu: float = 0.3,
          rho: float = 1.0) -> Plate:
    xs = np.linspace(0.0, length, nx + 1)
    ys = np.linspace(0.0, width, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")            # node (i, j) has number i (ny + 1) + j
    nodes = np.column_stack([X.ravel(), Y.ravel()])
    number = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    a, b = number[:-1, :-1].ravel(), number[1:, :-1].ravel()
    c, d = number[1:, 1:].ravel(), number[:-1, 1:].ravel()
    triangles = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])

    p = nodes[triangles]                                   # (ne, 3, 2)
    x, y = p[..., 0], p[..., 1]
    bb = np.stack([y[:, 1] - y[:, 2], y[:, 2] - y[:, 0], y[:, 0] - y[:, 1]], axis=1)
    cc = np.stack([x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0]], axis=1)
    area = 0.5 * (bb[:, 0] * cc[:, 1] - bb[:, 1] * cc[:, 0])
    ne = len(triangles)
    B = np.zeros((ne, 3, 6))
    B[:, 0, 0::2] = bb
    B[:, 1, 1::2] = cc
    B[:, 2, 0::2] = cc
    B[:, 2, 1::2] = bb
    B /= (2.0 * area)[:, None, None]
    D = E / (1.0 - nu ** 2) * np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, (1.0 - nu) / 2.0]])
    Ke = area[:, None, None] * np.einsum("eki,kl,elj->eij", B, D, B)
    Me = (rho * area / 12.0)[:, None, None] * np.kron(np.array([[2.0, 1.0, 1.0], [1.0, 2.0, 1.0], [1.0, 1.0, 2.0]]),
                                                      np.eye(2))[None]

    dofs = np.empty((ne, 6), dtype=np.int64)
    dofs[:, 0::2] = 2 * triangles
    dofs[:, 1::2] = 2 * triangles + 1
    rows = np.repeat(dofs, 6, axis=1).ravel()
    cols = np.tile(dofs, (1, 6)).ravel()
    n_all = 2 * len(nodes)
    K = sparse.csc_matrix((Ke.ravel(), (rows, cols)), shape=(n_all, n_all))
    M = sparse.csc_matrix((Me.ravel(), (rows, cols)), shape=(n_all, n_all))

    free_nodes = np.flatnonzero(nodes[:, 0] > 0.0)
    free = np.column_stack([2 * free_nodes, 2 * free_nodes + 1]).ravel()
    K = K[free][:, free].tocsc()
    M = M[free][:, free].tocsc()
    K = (0.5 * (K + K.T)).tocsc()     # exactly symmetric (assembly sums in different orders)
    M = (0.5 * (M + M.T)).tocsc()
    lumped = sparse.diags(np.asarray(M.sum(axis=1)).ravel()).tocsc()
    position = {node: k for k, node in enumerate(free_nodes)}
    tip = np.array([2 * position[number[nx, j]] + 1 for j in range(ny + 1)])
    return Plate(K=K, M=M, M_lumped=lumped, coordinates=nodes[free_nodes], tip=tip)
