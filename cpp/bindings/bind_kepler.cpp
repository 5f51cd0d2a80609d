// raydamp.Kepler's compiled model: test particles around a central body, split with the exact
// Kepler drift (models/kepler.hpp).
#include "model_functions.hpp"
#include "raydamp/models/kepler.hpp"
#include "run.hpp"
#include "run_ensemble.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

void bind_kepler(py::module_& m) {
  py::class_<Kepler> cls(m, "Kepler");
  cls.def(py::init<double, double, int, int, double>(), py::arg("mu"), py::arg("mass"), py::arg("dim"),
          py::arg("particles"), py::arg("eps"))
      .def_readonly("mu", &Kepler::mu)
      .def_readonly("particles", &Kepler::particles)
      .def_property_readonly("mass", [](const Kepler& k) { return k.mass.m; })
      .def_property_readonly("space_dim", [](const Kepler& k) { return k.d; });
  add_model_functions<Kepler>(cls);
  def_integrate<Kepler>(m);
  def_integrate_ensemble<Kepler>(m);
}

}  // namespace raydamp::bindings
