// The factorisations the linear implicit methods (methods/linear_implicit.hpp) step with:
// M + c C + c^2 K, c = s lambda, one per distinct sub-step length s of a run (one, two
// with a shortened last step, more for a composition; implicit/linear_implicit_step.hpp).
// They depend on the structure and on s only, not on the state, so one set, made before
// the first step and read-only after, serves a single run or every member of an ensemble
// on any thread: SparseLDLT::solve works in buffers its caller owns.
#pragma once

#include <complex>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#include "raydamp/linalg/sparse_ldlt.hpp"
#include "raydamp/models/linear_structure.hpp"

namespace raydamp {

namespace detail {

// What the implicit steps read of a structure, the same for either mass kind (one
// compiled step for both).
struct LinearSystem {
  SparseRowMajor mass;
  std::shared_ptr<const SparseRowMajor> stiffness;
  Eigen::VectorXd force;
  double alpha, beta, spectral_bound;
  std::shared_ptr<const SparsePattern> pattern;  // of M + K

  template <class Mass>
  explicit LinearSystem(const LinearStructure<Mass>& s)
      : mass(s.mass.matrix()), stiffness(s.stiffness), force(s.force), alpha(s.damping.alpha()),
        beta(s.damping.beta()), spectral_bound(s.damping.spectral_bound()) {
    const SparseColMajor m(mass), k(*stiffness);
    pattern = std::make_shared<const SparsePattern>(SparseColMajor(m.cwiseAbs() + k.cwiseAbs()));
  }

  // Whether this is structure s's system: the same K (shared, not copied), f and damping.
  template <class Mass>
  bool describes(const LinearStructure<Mass>& s) const {
    return stiffness == s.stiffness && alpha == s.damping.alpha() && beta == s.damping.beta() &&
           mass.rows() == s.mass.size() && force == s.force;
  }

  // M + c C + c^2 K = (1 + c alpha) M + (c beta + c^2) K.
  template <class Scalar>
  Eigen::SparseMatrix<Scalar, Eigen::ColMajor, int> shifted(Scalar c) const {
    const Scalar a = Scalar(1) + c * alpha, b = c * beta + c * c;
    return SparseColMajor(mass).cast<Scalar>() * a + SparseColMajor(*stiffness).cast<Scalar>() * b;
  }
};

// One factorised sub-step length.
template <class Scalar>
struct ImplicitFactor {
  double s;
  SparseLDLT<Scalar> solver;
};

}  // namespace detail

// The factors of one structure's system: real for the midpoint rule, complex symmetric
// for gauss4, over one shared symbolic analysis.
class LinearImplicitFactors {
 public:
  explicit LinearImplicitFactors(detail::LinearSystem system) : system_(std::move(system)) {}

  const detail::LinearSystem& system() const { return system_; }

  // The factor of sub-steps of length s, or null if none was made.
  template <class Scalar>
  const detail::ImplicitFactor<Scalar>* find(double s) const {
    for (const auto& f : list<Scalar>())
      if (f->s == s) return f.get();
    return nullptr;
  }

  // The factor of sub-steps of length s, c = s lambda: made on the first call for s.
  template <class Scalar>
  const detail::ImplicitFactor<Scalar>* make(double s, Scalar lambda) {
    if (const detail::ImplicitFactor<Scalar>* f = find<Scalar>(s)) return f;
    const Scalar c = Scalar(s) * lambda;
    auto& factors = list<Scalar>();
    factors.push_back(std::make_unique<detail::ImplicitFactor<Scalar>>(
        detail::ImplicitFactor<Scalar>{s, SparseLDLT<Scalar>(system_.pattern, system_.shifted(c), "M + c C + c^2 K")}));
    return factors.back().get();
  }

  // The factorisations made: one per distinct sub-step length.
  int count() const { return static_cast<int>(real_.size() + complex_.size()); }

 private:
  template <class Scalar>
  auto& list() {
    if constexpr (std::is_same_v<Scalar, double>) return real_;
    else return complex_;
  }
  template <class Scalar>
  const auto& list() const {
    if constexpr (std::is_same_v<Scalar, double>) return real_;
    else return complex_;
  }

  detail::LinearSystem system_;
  std::vector<std::unique_ptr<detail::ImplicitFactor<double>>> real_;
  std::vector<std::unique_ptr<detail::ImplicitFactor<std::complex<double>>>> complex_;
};

}  // namespace raydamp
