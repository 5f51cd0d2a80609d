// The structure kinds with hysteretic springs (models/structure.hpp), lumped and consistent mass, each
// bound once. The springs arrive as columns (kind, i, j, parameters), in the order Python lists them;
// the core keeps them by kind (materials/springs.hpp), and Python maps the two orders.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "model_functions.hpp"
#include "raydamp/models/structure.hpp"
#include "run.hpp"
#include "run_ensemble.hpp"

namespace raydamp::bindings {

namespace py = pybind11;

namespace {

materials::Springs make_springs(const std::vector<std::string>& kinds, const std::vector<int>& from,
                                const std::vector<int>& to, const std::vector<std::vector<double>>& parameters) {
  if (from.size() != kinds.size() || to.size() != kinds.size() || parameters.size() != kinds.size())
    throw std::invalid_argument("springs: kinds, i, j and parameters differ in length");
  materials::Springs springs;
  for (std::size_t s = 0; s < kinds.size(); ++s) {
    const std::vector<double>& v = parameters[s];
    auto need = [&](std::size_t count) {
      if (v.size() != count)
        throw std::invalid_argument("springs[" + std::to_string(s) + "].material: " + kinds[s] + " takes " +
                                    std::to_string(count) + " parameters");
    };
    if (kinds[s] == materials::ElasticPlastic::name) {
      need(2);
      springs.elastic_plastic.add(from[s], to[s], materials::ElasticPlastic{v[0], v[1]});
    } else if (kinds[s] == materials::Bilinear::name) {
      need(3);
      springs.bilinear.add(from[s], to[s], materials::Bilinear(v[0], v[1], v[2]));
    } else if (kinds[s] == materials::BoucWen::name) {
      need(5);
      springs.bouc_wen.add(from[s], to[s], materials::BoucWen(v[0], v[1], v[2], v[3], v[4]));
    } else {
      throw std::invalid_argument("springs[" + std::to_string(s) + "].material: unknown kind '" + kinds[s] + "'");
    }
  }
  return springs;
}

template <class Mass, class MassArgument>
void bind_structure_kind(py::module_& m, const char* name) {
  using Model = Structure<Mass>;
  py::class_<Model> cls(m, name);
  cls.def(py::init([](const MassArgument& mass, const SparseColMajor& k, const std::vector<std::string>& kinds,
                      const std::vector<int>& i, const std::vector<int>& j,
                      const std::vector<std::vector<double>>& parameters, const Eigen::VectorXd& f, double alpha,
                      double beta, int dense_limit, bool tangent_damping) {
            materials::Springs springs = make_springs(kinds, i, j, parameters);
            py::gil_scoped_release release;
            return Model(Mass(mass, "M"), k, std::move(springs), f, alpha, beta, dense_limit, tangent_damping);
          }),
          py::arg("M"), py::arg("K"), py::arg("kinds"), py::arg("i"), py::arg("j"), py::arg("parameters"),
          py::arg("f"), py::arg("alpha"), py::arg("beta"), py::arg("dense_limit") = kMaxDenseDim,
          py::arg("tangent_damping") = false);
  cls.def_property_readonly("mass_kind", [](const Model&) { return Mass::kind; })
      .def_property_readonly("alpha", [](const Model& s) { return s.damping.alpha(); })
      .def_property_readonly("beta", [](const Model& s) { return s.damping.beta(); })
      .def_property_readonly("spectral_bound", [](const Model& s) { return s.damping.spectral_bound(); })
      .def_property_readonly("damping_rate_bound", [](const Model& s) { return s.damping.rate_bound(); })
      .def_property_readonly("dense", [](const Model& s) { return s.damping.dense(); })
      .def_property_readonly("n_springs", [](const Model& s) { return s.springs.size(); })
      .def_property_readonly("tangent_damping", [](const Model& s) { return s.damping.tangent(); })
      // Whether runs split steps at the springs' kinks (materials/kinks.hpp); set once, before any run.
      .def_property(
          "locate_kinks", [](const Model& s) { return s.springs.phased(); },
          [](Model& s, bool on) { s.springs.set_phased(on); })
      .def(
          "gradient_with_spring_forces",
          [](const Model& s, const Eigen::VectorXd& q, const std::vector<double>& forces) {
            if (q.size() != s.size() || forces.size() != s.springs.size())
              throw std::invalid_argument("gradient_with_spring_forces: q needs " + std::to_string(s.size()) +
                                          " values and forces " + std::to_string(s.springs.size()));
            Eigen::VectorXd g(s.size());
            s.gradient_with_forces(q, forces.data(), g);
            return g;
          },
          py::arg("q"), py::arg("forces"))
      .def("chebyshev_degrees", [](const Model& s, double t) {
        const auto series = s.damping.chebyshev(t);
        return py::make_tuple(series->exp.degree(), series->t_phi1.degree());
      });
  add_model_functions<Model>(cls);
  def_integrate<Model>(m);
  def_integrate_ensemble<Model>(m);
}

}  // namespace

void bind_structure(py::module_& m) {
  bind_structure_kind<LumpedMass, Eigen::VectorXd>(m, "Structure_lumped");
  bind_structure_kind<ConsistentMass, SparseColMajor>(m, "Structure_consistent");
}

}  // namespace raydamp::bindings
