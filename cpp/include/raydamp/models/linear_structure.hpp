// A linear structure: H = 1/2 p^T M^{-1} p + V(q), V = 1/2 q^T K q - f^T q, with
// Rayleigh damping C = alpha M + beta K (eps = 1, D = C: paper section 2 with a
// constant mass and a constant dissipation tensor). M and K are sparse; Mass is
// LumpedMass or ConsistentMass (mass/sparse_mass.hpp). One struct per mass kind,
// bound once: a user's structure is data (its matrices), never new C++.
#pragma once

#include <Eigen/SparseCore>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "raydamp/damping/sparse_rayleigh_damping.hpp"
#include "raydamp/damping/spectral_bound.hpp"
#include "raydamp/mass/sparse_mass.hpp"
#include "raydamp/state.hpp"
#include "raydamp/thread_scratch.hpp"

namespace raydamp {

namespace detail {

// Refuses (naming K) a stiffness that is not square n x n, finite and symmetric.
inline std::shared_ptr<const SparseRowMajor> checked_stiffness(const SparseColMajor& k, Eigen::Index n) {
  if (k.rows() != n || k.cols() != n)
    throw std::invalid_argument("K: expected a " + std::to_string(n) + " x " + std::to_string(n) +
                                " matrix (the size of M), got " + std::to_string(k.rows()) + " x " +
                                std::to_string(k.cols()));
  double largest = 0.0;
  for (Eigen::Index j = 0; j < k.outerSize(); ++j)
    for (SparseColMajor::InnerIterator it(k, j); it; ++it) {
      if (!std::isfinite(it.value())) throw std::invalid_argument("K: has a non-finite entry");
      largest = std::max(largest, std::abs(it.value()));
    }
  const SparseColMajor asymmetry = k - SparseColMajor(k.transpose());
  double worst = 0.0;
  for (Eigen::Index j = 0; j < asymmetry.outerSize(); ++j)
    for (SparseColMajor::InnerIterator it(asymmetry, j); it; ++it) worst = std::max(worst, std::abs(it.value()));
  if (worst > 1e-12 * largest)
    throw std::invalid_argument("K: must be symmetric (max |K - K^T| = " + std::to_string(worst) + ")");
  auto out = std::make_shared<SparseRowMajor>(k);
  out->makeCompressed();
  return out;
}

template <class Mass>
double structure_spectral_bound(const SparseRowMajor& k, const Mass& mass) {
  const double lanczos = lanczos_upper_bound(k, mass);
  if constexpr (std::is_same_v<Mass, LumpedMass>) return std::min(lanczos, gershgorin_bound(k, mass.m));
  else return lanczos;
}

}  // namespace detail

template <class Mass>
struct LinearStructure {
  static constexpr int dim = Eigen::Dynamic;
  static constexpr int n_momenta = 0;
  using Vec = Vector<dim>;

  double eps;  // 1 when damped (D = alpha M + beta K), 0 when alpha = beta = 0
  Mass mass;
  std::shared_ptr<const SparseRowMajor> stiffness;
  Eigen::VectorXd force;  // f
  SparseRayleighDamping<Mass> damping;
  int n;

  LinearStructure(Mass mass_, const SparseColMajor& k, const Eigen::VectorXd& f, double alpha, double beta)
      : eps(alpha > 0.0 || beta > 0.0 ? 1.0 : 0.0),
        mass(std::move(mass_)),
        stiffness(detail::checked_stiffness(k, mass.size())),
        force(f.size() ? Eigen::VectorXd(f) : Eigen::VectorXd(Eigen::VectorXd::Zero(mass.size()))),
        damping(alpha, beta, stiffness, mass, detail::structure_spectral_bound(*stiffness, mass)),
        n(static_cast<int>(mass.size())) {
    if (force.size() != n) throw std::invalid_argument("f: expected " + std::to_string(n) + " entries");
    if (!force.allFinite()) throw std::invalid_argument("f: must be finite");
  }

  int size() const { return n; }

  double potential(const Vec& q) const {
    Eigen::VectorXd& kq = thread_scratch(kScratchProduct, n);
    kq.noalias() = *stiffness * q;
    return 0.5 * q.dot(kq) - force.dot(q);
  }

  void gradient(const Vec& q, Vec& g) const {
    g.noalias() = *stiffness * q;
    g -= force;
  }

  void hessian_product(const Vec&, const Vec& v, Vec& out) const { out.noalias() = *stiffness * v; }

  void momenta(const Vec&, const Vec&, double*) const {}
};

}  // namespace raydamp
