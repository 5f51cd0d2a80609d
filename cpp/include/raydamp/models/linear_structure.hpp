// A linear structure: H = 1/2 p^T M^{-1} p + V(q), V = 1/2 q^T K q - f^T q, with
// Rayleigh damping C = alpha M + beta K (eps = 1, D = C: paper section 2 with a
// constant mass and a constant dissipation tensor). M and K are sparse; Mass is
// LumpedMass or ConsistentMass (mass/sparse_mass.hpp). One struct per mass kind,
// bound once: a user's structure is data (its matrices), never new C++. A small one
// (n <= kMaxDenseDim) keeps K dense as well and its damping flows by its modes
// (damping/sparse_rayleigh_damping.hpp): a few DOF then step like a System of the same size.
#pragma once

#include <Eigen/SparseCore>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "raydamp/damping/sparse_rayleigh_damping.hpp"
#include "raydamp/damping/spectral_bound.hpp"
#include "raydamp/linalg/sparse_ldlt.hpp"
#include "raydamp/mass/sparse_mass.hpp"
#include "raydamp/state.hpp"
#include "raydamp/system/small_dense.hpp"
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

// Whether L M - K is positive definite, i.e. every eigenvalue of M^{-1} K lies below L: its LDL^T
// (no pivoting) has only positive pivots (Sylvester's law of inertia); a zero pivot is not a certificate.
inline bool bounds_spectrum(const SparseColMajor& k, const SparseColMajor& m, double bound,
                            const std::shared_ptr<const SparsePattern>& pattern) {
  try {
    return SparseLDLT<double>(pattern, SparseColMajor(bound * m - k), "L M - K").positive_pivots();
  } catch (const std::invalid_argument&) {
    return false;
  }
}

// An upper bound L of the spectrum of M^{-1} K, certified. Lanczos' estimate (with Gershgorin's, for a
// lumped M) is checked by one sparse LDL^T of L M - K: on a widely spread spectrum Lanczos can stop far
// short of omega_max^2 (found: 0.8% of it for 48 modes from 0.05 to 3.8e5), and then the damping
// flows' Chebyshev series would be wrong for the top modes. An estimate that fails doubles until it
// holds, and is then bisected back to within 1/16 of the smallest certified value found.
template <class Mass>
double structure_spectral_bound(const SparseRowMajor& k, const Mass& mass) {
  double bound = lanczos_upper_bound(k, mass);
  if constexpr (std::is_same_v<Mass, LumpedMass>) bound = std::min(bound, gershgorin_bound(k, mass.m));
  const SparseColMajor kc(k), mc(mass.matrix());
  auto pattern = std::make_shared<const SparsePattern>(SparseColMajor(mc.cwiseAbs() + kc.cwiseAbs()));
  bound = std::max(bound, 1e-300);
  if (bounds_spectrum(kc, mc, bound, pattern)) return bound;
  double low = bound;
  int doublings = 0;
  do {
    low = bound;
    bound *= 2.0;
    if (++doublings > 1100) throw std::invalid_argument("K: no finite bound of M^{-1} K's spectrum");
  } while (!bounds_spectrum(kc, mc, bound, pattern));
  for (int i = 0; i < 4; ++i) {  // bisect within (low, bound]
    const double mid = 0.5 * (low + bound);
    if (bounds_spectrum(kc, mc, mid, pattern)) bound = mid;
    else low = mid;
  }
  return bound;
}

}  // namespace detail

template <class Mass>
struct LinearStructure {
  static constexpr int dim = Eigen::Dynamic;
  static constexpr int n_momenta = 0;
  static constexpr bool linear_system = true;  // runs the implicit methods (catalogue.hpp's with_method_for)
  using Vec = Vector<dim>;

  double eps;  // 1 when damped (D = alpha M + beta K), 0 when alpha = beta = 0
  Mass mass;
  std::shared_ptr<const SparseRowMajor> stiffness;
  Eigen::VectorXd force;  // f
  SparseRayleighDamping<Mass> damping;
  int n;
  std::shared_ptr<const Eigen::MatrixXd> dense_stiffness;  // K, where the damping is dense (else null)

  // dense_limit: the largest n run by dense products (a test sets 0 to compare against the sparse path).
  LinearStructure(Mass mass_, const SparseColMajor& k, const Eigen::VectorXd& f, double alpha, double beta,
                  int dense_limit = kMaxDenseDim)
      : eps(alpha > 0.0 || beta > 0.0 ? 1.0 : 0.0),
        mass(std::move(mass_)),
        stiffness(detail::checked_stiffness(k, mass.size())),
        force(f.size() ? Eigen::VectorXd(f) : Eigen::VectorXd(Eigen::VectorXd::Zero(mass.size()))),
        damping(alpha, beta, stiffness, mass, detail::structure_spectral_bound(*stiffness, mass), dense_limit),
        n(static_cast<int>(mass.size())) {
    finish();
  }

  // The same structure with K scaled by k_scale > 0 and damping alpha M + beta K: an ensemble's member
  // (one SDOF per period of a spectrum). M^{-1} (k_scale K) has k_scale times the spectrum, so the
  // certified bound scales with it and nothing is estimated again.
  LinearStructure with_parameters(double alpha, double beta, double k_scale) const {
    if (!(k_scale > 0.0) || !std::isfinite(k_scale)) throw std::invalid_argument("K_scale: must be finite and > 0");
    std::shared_ptr<const SparseRowMajor> k = stiffness;
    if (k_scale != 1.0) k = std::make_shared<const SparseRowMajor>(k_scale * *stiffness);
    return LinearStructure(mass, std::move(k), force, alpha, beta, k_scale * damping.spectral_bound(),
                           damping.dense() ? kMaxDenseDim : 0);
  }

  int size() const { return n; }

  double potential(const Vec& q) const {
    Eigen::VectorXd& kq = thread_scratch(kScratchProduct, n);
    if (dense_stiffness) kq.noalias() = dense_stiffness->lazyProduct(q);
    else kq.noalias() = *stiffness * q;
    return 0.5 * q.dot(kq) - force.dot(q);
  }

  void gradient(const Vec& q, Vec& g) const {
    if (dense_stiffness) g.noalias() = dense_stiffness->lazyProduct(q);  // inline loops, no gemv call: a few DOF
    else g.noalias() = *stiffness * q;
    g -= force;
  }

  void hessian_product(const Vec&, const Vec& v, Vec& out) const {
    if (dense_stiffness) out.noalias() = *dense_stiffness * v;
    else out.noalias() = *stiffness * v;
  }

  void momenta(const Vec&, const Vec&, double*) const {}

 private:
  // A checked K with its certified bound (with_parameters).
  LinearStructure(Mass mass_, std::shared_ptr<const SparseRowMajor> k, const Eigen::VectorXd& f, double alpha,
                  double beta, double bound, int dense_limit)
      : eps(alpha > 0.0 || beta > 0.0 ? 1.0 : 0.0),
        mass(std::move(mass_)),
        stiffness(std::move(k)),
        force(f),
        damping(alpha, beta, stiffness, mass, bound, dense_limit),
        n(static_cast<int>(mass.size())) {
    finish();
  }

  void finish() {
    if (force.size() != n) throw std::invalid_argument("f: expected " + std::to_string(n) + " entries");
    if (!force.allFinite()) throw std::invalid_argument("f: must be finite");
    if (damping.dense()) dense_stiffness = std::make_shared<const Eigen::MatrixXd>(SparseColMajor(*stiffness));
  }
};

}  // namespace raydamp
