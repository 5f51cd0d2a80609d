// The functions every model kind exposes to Python: diagnostics and reference
// solutions (energy, gradient, damping, momenta) and the exact sub-flows one at a time.
#pragma once

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "raydamp/raydamp.hpp"

namespace raydamp::bindings {

namespace py = pybind11;

// q and p as rows of a trajectory: two arrays of shape (rows, n).
inline void check_rows(const py::array& q, const py::array& p, int n) {
  if (q.ndim() != 2 || p.ndim() != 2 || q.shape(1) != n || p.shape(1) != n || q.shape(0) != p.shape(0))
    throw std::invalid_argument("q, p: expected two arrays of shape (rows, " + std::to_string(n) + ")");
}

// Applies f(model, state, workspace) -> double to each row of (q, p): diagnostics
// over a whole trajectory in one call.
template <class Model, class F>
inline py::array_t<double> per_row(const Model& model, py::array_t<double, py::array::c_style | py::array::forcecast> q,
                            py::array_t<double, py::array::c_style | py::array::forcecast> p, F f) {
  const int n = model.size();
  check_rows(q, p, n);
  const py::ssize_t rows = q.shape(0);
  py::array_t<double> out(rows);
  auto qv = q.template unchecked<2>();
  auto pv = p.template unchecked<2>();
  auto ov = out.template mutable_unchecked<1>();
  WorkspaceFor<Model> ws(n, 1);
  State<Model::dim> z{Vector<Model::dim>::Zero(n), Vector<Model::dim>::Zero(n)};
  for (py::ssize_t r = 0; r < rows; ++r) {
    for (int i = 0; i < n; ++i) {
      z.q[i] = qv(r, i);
      z.p[i] = pv(r, i);
    }
    ov(r) = f(model, z, ws);
  }
  return out;
}

template <class Model, class Class>
inline void add_model_functions(Class& cls) {
  using Vec = typename Model::Vec;
  cls.def_readonly("eps", &Model::eps)
      .def_property_readonly("dim", [](const Model& m) { return m.size(); })
      .def_property_readonly("n_momenta", [](const Model& m) { return momentum_count(m); })
      .def("potential", [](const Model& m, const Vec& q) { return m.potential(q); })
      .def("kinetic", [](const Model& m, const Vec& p) { return m.mass.kinetic(p); })
      .def("energy", [](const Model& m, const Vec& q, const Vec& p) { return energy(m, State<Model::dim>{q, p}); })
      .def("gradient", [](const Model& m, const Vec& q) { Vec g = Vec::Zero(m.size()); m.gradient(q, g); return g; })
      .def("velocity", [](const Model& m, const Vec& p) { Vec v = Vec::Zero(m.size()); m.mass.velocity(p, v); return v; })
      .def("damping_rate", [](const Model& m, const Vec& q, const Vec& p) { Vec out = Vec::Zero(m.size()); m.damping.rate(q, p, out); return out; })
      .def("hessian_product", [](const Model& m, const Vec& q, const Vec& v) { Vec out = Vec::Zero(m.size()); m.hessian_product(q, v, out); return out; })
      .def("momenta", [](const Model& m, const Vec& q, const Vec& p) {
        std::vector<double> out(momentum_count(m));
        m.momenta(q, p, out.data());
        return out;
      })
      .def("modified_energy_sv", [](const Model& m, py::array_t<double> q, py::array_t<double> p, double h) {
        return per_row(m, q, p, [h](const Model& mm, const State<Model::dim>& z, WorkspaceFor<Model>& ws) {
          return modified_energy_sv(mm, z, h, ws);
        });
      })
      .def("dissipated_power", [](const Model& m, py::array_t<double> q, py::array_t<double> p) {
        return per_row(m, q, p, [](const Model& mm, const State<Model::dim>& z, WorkspaceFor<Model>& ws) {
          return dissipated_power(mm, z, ws);
        });
      })
      .def("flow", [](const Model& m, const std::string& name, const Vec& q, const Vec& p, double t) {
        State<Model::dim> z{q, p};
        WorkspaceFor<Model> ws(m.size(), 1);
        if (name == "drift") flows::drift(m, z, t, ws);
        else if (name == "kick") flows::kick(m, z, t, ws);
        else if (name == "damp") flows::damp(m, z, t, ws);
        else if (name == "kick_damp") flows::kick_damp(m, z, t, ws);
        else throw std::invalid_argument("flow: unknown sub-flow '" + name + "' (known: drift, kick, damp, kick_damp)");
        return py::make_tuple(z.q, z.p);
      });
}

}  // namespace raydamp::bindings
