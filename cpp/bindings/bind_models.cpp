// The models, with the functions Python needs for diagnostics and reference
// solutions (energy, gradient, damping, momenta) and the exact sub-flows one at a time.
#include "model_functions.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

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
