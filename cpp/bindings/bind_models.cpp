// The models, with the functions Python needs for diagnostics and reference
// solutions (energy, gradient, damping, momenta) and the exact sub-flows one at a time.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "raydamp/raydamp.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

// Applies f(model, state, workspace) -> double to each row of (q, p): diagnostics
// over a whole trajectory in one call.
template <class Model, class F>
py::array_t<double> per_row(const Model& model, py::array_t<double, py::array::c_style | py::array::forcecast> q,
                            py::array_t<double, py::array::c_style | py::array::forcecast> p, F f) {
  const int n = model.size();
  if (q.ndim() != 2 || p.ndim() != 2 || q.shape(1) != n || p.shape(1) != n || q.shape(0) != p.shape(0))
    throw std::invalid_argument("q, p: expected two arrays of shape (rows, " + std::to_string(n) + ")");
  const py::ssize_t rows = q.shape(0);
  py::array_t<double> out(rows);
  auto qv = q.template unchecked<2>();
  auto pv = p.template unchecked<2>();
  auto ov = out.template mutable_unchecked<1>();
  Workspace<Model::dim> ws(n, 1);
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
void add_model_functions(Class& cls) {
  using Vec = typename Model::Vec;
  cls.def_readonly("eps", &Model::eps)
      .def_property_readonly_static("dim", [](py::object) { return Model::dim; })
      .def_property_readonly_static("n_momenta", [](py::object) { return Model::n_momenta; })
      .def("potential", [](const Model& m, const Vec& q) { return m.potential(q); })
      .def("kinetic", [](const Model& m, const Vec& p) { return m.mass.kinetic(p); })
      .def("energy", [](const Model& m, const Vec& q, const Vec& p) { return energy(m, State<Model::dim>{q, p}); })
      .def("gradient", [](const Model& m, const Vec& q) { Vec g; m.gradient(q, g); return g; })
      .def("velocity", [](const Model& m, const Vec& p) { Vec v; m.mass.velocity(p, v); return v; })
      .def("damping_rate", [](const Model& m, const Vec& q, const Vec& p) { Vec out; m.damping.rate(q, p, out); return out; })
      .def("hessian_product", [](const Model& m, const Vec& q, const Vec& v) { Vec out; m.hessian_product(q, v, out); return out; })
      .def("momenta", [](const Model& m, const Vec& q, const Vec& p) {
        std::vector<double> out(Model::n_momenta);
        m.momenta(q, p, out.data());
        return out;
      })
      .def("modified_energy_sv", [](const Model& m, py::array_t<double> q, py::array_t<double> p, double h) {
        return per_row(m, q, p, [h](const Model& mm, const State<Model::dim>& z, Workspace<Model::dim>& ws) {
          return modified_energy_sv(mm, z, h, ws);
        });
      })
      .def("dissipated_power", [](const Model& m, py::array_t<double> q, py::array_t<double> p) {
        return per_row(m, q, p, [](const Model& mm, const State<Model::dim>& z, Workspace<Model::dim>& ws) {
          return dissipated_power(mm, z, ws);
        });
      })
      .def("flow", [](const Model& m, const std::string& name, const Vec& q, const Vec& p, double t) {
        State<Model::dim> z{q, p};
        Workspace<Model::dim> ws(m.size(), 1);
        if (name == "drift") flows::drift(m, z, t, ws);
        else if (name == "kick") flows::kick(m, z, t, ws);
        else if (name == "damp") flows::damp(m, z, t, ws);
        else if (name == "kick_damp") flows::kick_damp(m, z, t, ws);
        else throw std::invalid_argument("flow: unknown sub-flow '" + name + "' (known: drift, kick, damp, kick_damp)");
        return py::make_tuple(z.q, z.p);
      });
}

void bind_models(py::module_& m) {
  py::class_<DampedPendulum> pendulum(m, "DampedPendulum");
  pendulum.def(py::init<double>(), py::arg("eps"));
  add_model_functions<DampedPendulum>(pendulum);

  py::class_<ElasticPendulum> elastic(m, "ElasticPendulum");
  elastic.def(py::init<double, double, double, double, std::array<double, 3>>(), py::arg("eps"), py::arg("m"),
              py::arg("k"), py::arg("l"), py::arg("g"))
      .def_property_readonly("m", [](const ElasticPendulum& e) { return e.mass.m; })
      .def_readonly("k", &ElasticPendulum::k)
      .def_readonly("l", &ElasticPendulum::l)
      .def_property_readonly("g", [](const ElasticPendulum& e) { return Vector<3>(e.g); });
  add_model_functions<ElasticPendulum>(elastic);
}

}  // namespace raydamp::bindings
