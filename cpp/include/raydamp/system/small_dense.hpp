// Vectors and matrices for the dense damping kinds of compiled systems, with their
// storage on the stack (Eigen's MaxRows/MaxCols), so that the exact damping flows
// allocate nothing per step. These kinds are for small n: systems written as
// expressions (a chain of a few masses, a molecule, an orbit); structures with
// thousands of coordinates need the sparse kinds, not an n x n eigendecomposition.
#pragma once

#include <Eigen/Core>

namespace raydamp {

inline constexpr int kMaxDenseDim = 32;  // n for a constant-matrix or multi-damper D(q)
inline constexpr int kMaxDampers = 32;   // dashpots in one system

using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxDenseDim, 1>;
using SmallMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDenseDim, kMaxDenseDim>;

}  // namespace raydamp
