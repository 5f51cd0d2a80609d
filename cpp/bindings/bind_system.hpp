// The compiled-system kinds (mass kind x damping kind), each bound once: a user's
// system is data passed to one of these constructors, never new C++.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "model_functions.hpp"
#include "run.hpp"
#include "run_ensemble.hpp"

namespace raydamp::bindings {

// Addresses of the compiled functions, as Python passes them: (function, data)
// pairs for potential, gradient, hessian_product, damper_gradients, momenta,
// damper_projection, damp_then_3s_body (0 where absent).
using FunctionAddresses = std::vector<std::uintptr_t>;

inline CompiledFunction compiled(const FunctionAddresses& a, int i) {
  return {reinterpret_cast<CompiledFunction::Fn>(a.at(2 * i)), reinterpret_cast<void*>(a.at(2 * i + 1))};
}

template <class Mass>
Mass make_mass(const Eigen::MatrixXd& mass) {
  if constexpr (std::is_same_v<Mass, ScalarMass>) return ScalarMass(mass(0, 0), "mass");
  else return DenseMass(mass, "mass");
}

template <class Damping>
Damping make_damping(const Eigen::MatrixXd& mass, double eps, double scalar, const Eigen::MatrixXd& matrix,
                     const std::vector<double>& coefficients, CompiledFunction damper_gradients, double damper_norm,
                     CompiledFunction damper_projection) {
  if constexpr (std::is_same_v<Damping, IsotropicDamping>) {
    IsotropicDamping d;
    d.a = eps * scalar;  // D = c M: A = eps c I
    return d;
  } else if constexpr (std::is_same_v<Damping, ConstantDamping>) {
    return ConstantDamping(mass, matrix, eps);
  } else {
    return DamperDamping(mass, eps, coefficients, damper_gradients, damper_norm, damper_projection);
  }
}

template <class Mass, class Damping>
void bind_system_kind(py::module_& m, const char* name) {
  using Model = CompiledSystem<Mass, Damping>;
  py::class_<Model> cls(m, name);
  cls.def(py::init([](int n, double eps, const Eigen::MatrixXd& mass, double damping_scalar,
                      const Eigen::MatrixXd& damping_matrix, const std::vector<double>& damper_coefficients,
                      const FunctionAddresses& functions, int n_momenta, py::object /*keep_alive*/,
                      double damper_norm) {
            if (mass.rows() != n || mass.cols() != n) throw std::invalid_argument("mass: expected an n x n matrix");
            if (functions.size() != 14) throw std::invalid_argument("functions: expected 7 (function, data) pairs");
            const SystemFunctions f{compiled(functions, 0), compiled(functions, 1), compiled(functions, 2),
                                    compiled(functions, 4), compiled(functions, 6)};
            return Model(n, eps, make_mass<Mass>(mass),
                         make_damping<Damping>(mass, eps, damping_scalar, damping_matrix, damper_coefficients,
                                               compiled(functions, 3), damper_norm, compiled(functions, 5)),
                         f, n_momenta);
          }),
          py::arg("n"), py::arg("eps"), py::arg("mass"), py::arg("damping_scalar"), py::arg("damping_matrix"),
          py::arg("damper_coefficients"), py::arg("functions"), py::arg("n_momenta"), py::arg("keep_alive"),
          // a = grad g^T M^{-1} grad g of a single dashpot when constant (NaN: it varies).
          py::arg("damper_norm") = std::numeric_limits<double>::quiet_NaN(),
          // The compiled code lives as long as the Python object that owns it.
          py::keep_alive<1, 10>());
  add_model_functions<Model>(cls);
  def_integrate<Model>(m);
  def_integrate_ensemble<Model>(m);
}

}  // namespace raydamp::bindings
