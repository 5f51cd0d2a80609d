// raydamp.Kepler's and raydamp.Planets' compiled model: test particles around a central body, and
// interacting planets in Jacobi coordinates, both split with the exact Kepler drift (models/kepler.hpp,
// models/planets.hpp), one C++ kind.
#include "model_functions.hpp"
#include "raydamp/models/planets.hpp"
#include "run.hpp"
#include "run_ensemble.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

void bind_kepler(py::module_& m) {
  // One compiled kind for test particles and planets (models/planets.hpp): raydamp.Kepler's model is a
  // Planets whose bodies do not interact.
  py::class_<Planets> planets(m, "Planets");
  planets
      .def(py::init([](double G, double central, std::vector<double> masses, int dim, std::vector<double> eps,
                       int drag) { return Planets(G, central, std::move(masses), dim, std::move(eps), drag_direction(drag)); }),
           py::arg("G"), py::arg("central_mass"), py::arg("masses"), py::arg("dim"), py::arg("eps"), py::arg("drag") = 0)
      .def_readonly("planets", &Planets::planets)
      .def_readonly("mu", &Planets::mu)
      .def_property_readonly("reduced_masses", [](const Planets& p) {
        std::vector<double> out;
        for (int i = 0; i < p.planets; ++i) out.push_back(p.mass.m[p.d * i]);
        return out;
      })
      .def_property_readonly("space_dim", [](const Planets& p) { return p.d; });
  m.def(
      "Kepler",
      [](double mu, double mass, int dim, int particles, double eps, int drag) {
        return Planets(TestParticles{}, mu, mass, dim, particles, eps, drag_direction(drag));
      },
      py::arg("mu"), py::arg("mass"), py::arg("dim"), py::arg("particles"), py::arg("eps"), py::arg("drag") = 0);
  add_model_functions<Planets>(planets);
  def_integrate<Planets>(m);
  def_integrate_ensemble<Planets>(m);
}

}  // namespace raydamp::bindings
