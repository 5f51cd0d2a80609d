// Dashpots on a constraint's tangent space: the exact flow of P eps D(q) M^{-1} at frozen q, P the
// M-orthogonal projector onto {p : G M^{-1} p = 0}.
//
// In y = L^{-1} p (M = L L^T) the M^{-1} inner product of momenta is the Euclidean one, the tangent space is
// the orthogonal complement of the columns of B = L^{-1} G^T, and P becomes the orthogonal projector
// Pi = I - B (B^T B)^{-1} B^T (B^T B = G M^{-1} G^T). The dashpots' operator is S = eps L^{-1} D L^{-T}
// (symmetric, PSD), and on the tangent space p' = -P eps D M^{-1} p is y' = -K y with K = Pi S Pi, symmetric:
// its eigendecomposition K = V diag(lambda) V^T gives the flow exactly,
//   damp:       y(t) = V e^{-t lambda} V^T y,
//   kick+damp:  y(t) = V (e^{-t lambda} V^T y - t phi1(-t lambda) V^T L^{-1} grad V),
// followed by the projection (K commutes with Pi, so projecting after the flow of K is the flow of the
// projected field: the normal part of L^{-1} grad V, which K leaves alone, is what the projection removes).
// At a temperature the OU noise is L V diag(sqrt(1 - e^{-2 t lambda})) V^T xi: its covariance kT L (Pi - e^{-2tK})
// L^T on the tangent space, so the stationary law of p is kT P M there, the constrained Boltzmann one (the
// directions no dashpot reaches, lambda = 0, get neither damping nor noise, as without constraints).
// For one dashpot, P D M^{-1} = (P grad g) c (P grad g)^T M^{-1} on the tangent space: the dashpot with its
// direction projected. n <= kMaxDenseDim (the dashpots' own limit): the matrices live on the stack.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdint>

#include "raydamp/constraints/constraint_set.hpp"
#include "raydamp/constraints/dashpots.hpp"
#include "raydamp/constraints/rattle.hpp"
#include "raydamp/flows/exact.hpp"
#include "raydamp/phi.hpp"
#include "raydamp/system/small_dense.hpp"

namespace raydamp::constraints {

// K's eigendecomposition at the last q a dashpot flow of this thread saw (3s's damp that ends a step and
// the one that starts the next act at the same q).
struct ProjectedDamperModes {
  std::uint64_t owner = 0;  // the ConstraintSet's id
  bool valid = false;
  SmallVector at_q, rates, y, c, d;
  SmallMatrix vectors, s, basis, pi;
};

inline ProjectedDamperModes& projected_damper_modes() {
  thread_local ProjectedDamperModes modes;
  return modes;
}

// K = Pi S Pi at q, and its modes; false where B^T B is not positive definite (G lost rank).
template <class Model, class Q>
bool projected_modes(const Model& model, const Q& q, ConstraintWork& w, ProjectedDamperModes& m) {
  const ConstraintSet& set = model.constraints;
  const int n = set.n, k = set.k;
  if (m.valid && m.owner == set.id && m.at_q.size() == n && m.at_q == q) return true;
  m.valid = false;
  if (!factored_at(model, q, w)) return false;
  const Dashpots& damping = model.dashpots;
  m.basis.setZero(n, k);  // G^T, then L^{-1} G^T
  for (int a = 0; a < k; ++a)
    for (int e = set.row_start[a]; e < set.row_start[a + 1]; ++e) m.basis(set.cols[e], a) = w.G[e];
  m.basis = damping.lower_inverse * m.basis;
  Eigen::LLT<SmallMatrix> normal(m.basis.transpose() * m.basis);
  if (normal.info() != Eigen::Success) return false;
  m.s = normal.solve(SmallMatrix(m.basis.transpose()));  // (B^T B)^{-1} B^T, k x n
  m.pi = -m.basis * m.s;
  m.pi.diagonal().array() += 1.0;
  damping.mass_weighted(q, m.s);
  m.s = m.pi * m.s * m.pi;
  Eigen::SelfAdjointEigenSolver<SmallMatrix> eig(m.s);
  if (eig.info() != Eigen::Success) return false;
  m.rates = eig.eigenvalues().cwiseMax(0.0);  // PSD by construction: rounding below 0 is 0
  m.vectors = eig.eigenvectors();
  m.at_q = q;
  m.owner = set.id;
  m.valid = true;
  return true;
}

// p <- the dashpots' flow over t on the tangent space (with grad V: the kick+damp flow), then the noise at a
// temperature, then the projection.
template <class Model, int Dim, class WS>
void projected_damper_flow(const Model& model, State<Dim>& z, double t, WS& ws, bool with_kick) {
  ConstraintWork& w = constraint_work(model.constraints);
  if (!z.all_finite()) return;  // blown up elsewhere: the step loop reports it as it is
  ProjectedDamperModes& m = projected_damper_modes();
  if (!projected_modes(model, z.q, w, m)) return fail(z, w, 0, 0.0, 0.0, 0, true);
  const Dashpots& damping = model.dashpots;
  const int n = model.constraints.n;
  m.y = damping.lower_inverse * z.p;
  m.c = m.vectors.transpose() * m.y;
  for (int i = 0; i < n; ++i) m.c[i] *= std::exp(-t * m.rates[i]);
  if (with_kick) {
    flows::loaded_gradient(model, z.q, ws.time, ws);
    m.y = damping.lower_inverse * ws.g;
    m.d = m.vectors.transpose() * m.y;
    for (int i = 0; i < n; ++i) m.c[i] -= t * phi1(-t * m.rates[i]) * m.d[i];
  }
  if (noisy(ws)) {
    ws.draw_noise(n);
    m.d = m.vectors.transpose() * ws.xi;
    for (int i = 0; i < n; ++i) m.c[i] += ws.sigma * std::sqrt(-std::expm1(-2.0 * t * m.rates[i])) * m.d[i];
  }
  m.y = m.vectors * m.c;
  z.p = damping.lower * m.y;
  project(model, z, w);
}

}  // namespace raydamp::constraints
