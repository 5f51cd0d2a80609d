// raydamp.Kepler's and raydamp.Planets' compiled models: test particles around a central body, and
// interacting planets in Jacobi coordinates, both split with the exact Kepler drift (models/kepler.hpp,
// models/planets.hpp).
#include "model_functions.hpp"
#include "raydamp/models/kepler.hpp"
#include "raydamp/models/planets.hpp"
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

  py::class_<Planets> planets(m, "Planets");
  planets
      .def(py::init<double, double, std::vector<double>, int, std::vector<double>>(), py::arg("G"),
           py::arg("central_mass"), py::arg("masses"), py::arg("dim"), py::arg("eps"))
      .def_readonly("planets", &Planets::planets)
      .def_readonly("mu", &Planets::mu)
      .def_property_readonly("reduced_masses", [](const Planets& p) {
        std::vector<double> out;
        for (int i = 0; i < p.planets; ++i) out.push_back(p.mass.m[p.d * i]);
        return out;
      })
      .def_property_readonly("space_dim", [](const Planets& p) { return p.d; });
  add_model_functions<Planets>(planets);
  def_integrate<Planets>(m);
  def_integrate_ensemble<Planets>(m);
}

}  // namespace raydamp::bindings
