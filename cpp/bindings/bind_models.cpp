// The models, with the functions Python needs for diagnostics and reference
// solutions (energy, gradient, damping, momenta) and the exact sub-flows one at a time.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "raydamp/raydamp.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

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
