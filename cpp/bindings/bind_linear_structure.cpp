// The linear-structure kinds (lumped and consistent mass), each bound once: M and
// K arrive as scipy.sparse matrices (pybind11's Eigen sparse caster copies their
// CSC arrays; nothing is densified).
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "model_functions.hpp"
#include "raydamp/models/linear_structure.hpp"
#include "run.hpp"
#include "run_ensemble.hpp"

namespace raydamp::bindings {

namespace py = pybind11;

namespace {

template <class Mass, class MassArgument>
void bind_linear_structure_kind(py::module_& m, const char* name) {
  using Model = LinearStructure<Mass>;
  py::class_<Model> cls(m, name);
  cls.def(py::init([](const MassArgument& mass, const SparseColMajor& k, const Eigen::VectorXd& f, double alpha,
                      double beta, int dense_limit) {
            // Factorising M and estimating the spectrum take a while for large n.
            py::gil_scoped_release release;
            return Model(Mass(mass, "M"), k, f, alpha, beta, dense_limit);
          }),
          py::arg("M"), py::arg("K"), py::arg("f"), py::arg("alpha"), py::arg("beta"),
          py::arg("dense_limit") = kMaxDenseDim);
  // An ensemble member: K scaled, alpha and beta replaced, M, f and the certified bound (scaled) shared.
  cls.def("with_parameters", &Model::with_parameters, py::arg("alpha"), py::arg("beta"), py::arg("K_scale"));
  cls.def_property_readonly("mass_kind", [](const Model&) { return Mass::kind; })
      .def_property_readonly("alpha", [](const Model& s) { return s.damping.alpha(); })
      .def_property_readonly("beta", [](const Model& s) { return s.damping.beta(); })
      .def_property_readonly("spectral_bound", [](const Model& s) { return s.damping.spectral_bound(); })
      .def_property_readonly("damping_rate_bound", [](const Model& s) { return s.damping.rate_bound(); })
      .def_property_readonly("dense", [](const Model& s) { return s.damping.dense(); })
      .def("chebyshev_degrees", [](const Model& s, double t) {
        const auto series = s.damping.chebyshev(t);
        return py::make_tuple(series->exp.degree(), series->t_phi1.degree());
      })
      // One noise sub-flow at kT = 1 from p = 0: N xi, N N^T = M - E M E^T, E = exp(-t C M^{-1}) (a testing
      // hook: tests compare N against a dense reference), and the degree of its Chebyshev series.
      .def("thermal_noise",
           [](const Model& s, double t, const Eigen::VectorXd& xi) {
             if (!(t >= 0.0) || !std::isfinite(t)) throw std::invalid_argument("t: must be finite and >= 0");
             if (xi.size() != s.n) throw std::invalid_argument("xi: expected " + std::to_string(s.n) + " entries");
             if (!s.damping.has_noise()) throw std::invalid_argument(s.damping.kNoNoise);
             Eigen::VectorXd p = Eigen::VectorXd::Zero(s.n);
             s.damping.add_noise(p, s.damping.factors(t), s.mass, 1.0, xi, p);
             return p;
           },
           py::arg("t"), py::arg("xi"))
      .def(
          "noise_chebyshev_degree",
          [](const Model& s, double t) {
            if (s.damping.beta() == 0.0) return 0;
            return s.damping.noise_series(*s.damping.series(t)).degree();
          },
          py::arg("t"));
  add_model_functions<Model>(cls);
  def_integrate<Model>(m);
  def_integrate_ensemble<Model>(m);
}

}  // namespace

void bind_linear_structure(py::module_& m) {
  m.attr("STRUCTURE_DENSE_LIMIT") = kMaxDenseDim;
  bind_linear_structure_kind<LumpedMass, Eigen::VectorXd>(m, "LinearStructure_lumped");
  bind_linear_structure_kind<ConsistentMass, SparseColMajor>(m, "LinearStructure_consistent");
}

}  // namespace raydamp::bindings
