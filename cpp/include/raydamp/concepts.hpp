// What a Model must provide, checked at compile time (C++17 detection idiom), so a
// model missing a piece fails with one readable static_assert instead of pages
// of template errors.
//
// A Model is one small struct with
//   static constexpr int dim;         // n, or Eigen::Dynamic
//   static constexpr int n_momenta;   // momentum maps of its symmetries (may be 0, or
//                                     // kDynamicMomenta with int momentum_count() const)
//   using Vec = Vector<dim>;
//   double eps;                       // damping strength
//   mass:    velocity(p, v) -> v = M^{-1} p; kinetic(p) -> 1/2 p^T M^{-1} p
//   damping: factors(t), decay(q, factors, p), decay_affine(q, factors, g, p), rate(q, p, out),
//            solve_shifted(q, c, x)
//            (the exact flows of A = eps D(q) M^{-1}, see damping/)
//   int size() const; double potential(q) const; void gradient(q, g) const;
//   void hessian_product(q, v, out) const; void momenta(q, p, double* out) const;
#pragma once

#include <type_traits>
#include <utility>

#include "raydamp/state.hpp"

namespace raydamp {

template <class M, class = void>
struct is_model : std::false_type {};

template <class M>
struct is_model<M, std::void_t<
    decltype(M::dim), decltype(M::n_momenta), typename M::Vec, decltype(std::declval<const M&>().eps),
    decltype(std::declval<const M&>().size()),
    decltype(std::declval<const M&>().potential(std::declval<const typename M::Vec&>())),
    decltype(std::declval<const M&>().gradient(std::declval<const typename M::Vec&>(),
                                               std::declval<typename M::Vec&>())),
    decltype(std::declval<const M&>().momenta(std::declval<const typename M::Vec&>(),
                                              std::declval<const typename M::Vec&>(), std::declval<double*>())),
    decltype(std::declval<const M&>().mass.kinetic(std::declval<const typename M::Vec&>())),
    decltype(std::declval<const M&>().damping.decay(std::declval<const typename M::Vec&>(),
                                                    std::declval<const M&>().damping.factors(0.0),
                                                    std::declval<typename M::Vec&>()))>>
    : std::true_type {};

template <class M>
inline constexpr bool is_model_v = is_model<M>::value;

// The momentum maps' values: their count is fixed per model type (n_momenta >= 0)
// or, for compiled systems, per model (n_momenta = kDynamicMomenta).
inline constexpr int kDynamicMomenta = -1;

template <class Model>
int momentum_count(const Model& model) {
  if constexpr (Model::n_momenta == kDynamicMomenta) return model.momentum_count();
  else return Model::n_momenta;
}


}  // namespace raydamp
