// raydamp.Kepler's and raydamp.Planets' compiled model: test particles around a central body, and
// interacting planets in Jacobi coordinates, both split with the exact Kepler drift (models/kepler.hpp,
// models/planets.hpp), one C++ kind.
#include "model_functions.hpp"
#include "raydamp/methods/corrector.hpp"
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
                       int drag, Eigen::MatrixXd matrix) {
             return Planets(G, central, std::move(masses), dim, std::move(eps), drag_direction(drag), std::move(matrix));
           }),
           py::arg("G"), py::arg("central_mass"), py::arg("masses"), py::arg("dim"), py::arg("eps"), py::arg("drag") = 0,
           py::arg("drag_matrix") = Eigen::MatrixXd())
      .def_readonly("planets", &Planets::planets)
      .def_readonly("mu", &Planets::mu)
      .def_property_readonly("reduced_masses", [](const Planets& p) {
        std::vector<double> out;
        for (int i = 0; i < p.planets; ++i) out.push_back(p.mass.m[p.d * i]);
        return out;
      })
      .def_property_readonly("space_dim", [](const Planets& p) { return p.d; })
      // Each row of (q, p) through the symplectic corrector C of the leapfrog of step h (or C^{-1}), with the
      // energy and angular momentum of the rows it gives (methods/corrector.hpp; raydamp/run/correctors.py).
      .def("correct", [](const Planets& model, py::array_t<double, py::array::c_style | py::array::forcecast> q,
                         py::array_t<double, py::array::c_style | py::array::forcecast> p, double h, int order,
                         bool inverse) {
        const int n = model.size(), m = momentum_count(model);
        check_rows(q, p, n);
        const Corrector corrector(order);
        const py::ssize_t rows = q.shape(0);
        py::array_t<double> qo({rows, static_cast<py::ssize_t>(n)}), po({rows, static_cast<py::ssize_t>(n)});
        py::array_t<double> energies(rows), momenta({rows, static_cast<py::ssize_t>(m)});
        auto qi = q.unchecked<2>();
        auto pi = p.unchecked<2>();
        auto qw = qo.mutable_unchecked<2>();
        auto pw = po.mutable_unchecked<2>();
        auto ew = energies.mutable_unchecked<1>();
        auto mw = momenta.mutable_unchecked<2>();
        State<Eigen::Dynamic> z{Planets::Vec(n), Planets::Vec(n)};
        std::vector<double> l(m);
        for (py::ssize_t r = 0; r < rows; ++r) {
          for (int i = 0; i < n; ++i) z.q[i] = qi(r, i), z.p[i] = pi(r, i);
          apply_corrector(model, corrector, h, inverse, z.q, z.p);
          for (int i = 0; i < n; ++i) qw(r, i) = z.q[i], pw(r, i) = z.p[i];
          ew(r) = energy(model, z);
          model.momenta(z.q, z.p, l.data());
          for (int k = 0; k < m; ++k) mw(r, k) = l[k];
        }
        py::dict out;
        out["q"] = qo;
        out["p"] = po;
        out["energy"] = energies;
        out["momentum"] = momenta;
        return out;
      }, py::arg("q"), py::arg("p"), py::arg("h"), py::arg("order"), py::arg("inverse"));
  m.def(
      "Kepler",
      [](double mu, double mass, int dim, int particles, double eps, int drag, Eigen::MatrixXd matrix) {
        return Planets(TestParticles{}, mu, mass, dim, particles, eps, drag_direction(drag), std::move(matrix));
      },
      py::arg("mu"), py::arg("mass"), py::arg("dim"), py::arg("particles"), py::arg("eps"), py::arg("drag") = 0,
      py::arg("drag_matrix") = Eigen::MatrixXd());
  add_model_functions<Planets>(planets);
  def_integrate<Planets>(m);
  def_integrate_ensemble<Planets>(m);
}

}  // namespace raydamp::bindings
