// raydamp.Chain's compiled model: one model type for every bond family, boundary
// and set of dampers (the family is a run-time choice made once per pass).
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "model_functions.hpp"
#include "run.hpp"
#include "run_ensemble.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

namespace {

ChainBoundary boundary_of(const std::string& name) {
  if (name == "fixed") return ChainBoundary::fixed;
  if (name == "periodic") return ChainBoundary::periodic;
  if (name == "free") return ChainBoundary::free;
  throw std::invalid_argument("boundary: unknown boundary '" + name + "' (known: fixed, periodic, free)");
}

double parameter(const std::map<std::string, double>& p, const char* name) {
  const auto it = p.find(name);
  if (it == p.end()) throw std::invalid_argument(std::string("parameters.") + name + ": missing");
  return it->second;
}

// The bond family and its parameters (Python fills in defaults and checks ranges);
// functions: (function, data) pairs for V, V', V'' of an expression bond.
ChainBonds make_bonds(const std::string& bond, const std::map<std::string, double>& p,
                      const std::vector<std::uintptr_t>& functions) {
  ChainBonds b;
  if (bond == "harmonic") {
    b.kind = BondKind::harmonic;
    b.harmonic.k = parameter(p, "k");
  } else if (bond == "fput") {
    b.kind = BondKind::fput;
    b.fput = {parameter(p, "k"), parameter(p, "alpha"), parameter(p, "beta")};
  } else if (bond == "toda") {
    b.kind = BondKind::toda;
    b.toda = {parameter(p, "a"), parameter(p, "b")};
  } else if (bond == "morse") {
    b.kind = BondKind::morse;
    b.morse = {parameter(p, "depth"), parameter(p, "a")};
  } else if (bond == "lennard_jones") {
    b.kind = BondKind::lennard_jones;
    b.lennard_jones = {parameter(p, "depth"), parameter(p, "spacing")};
  } else if (bond == "expression") {
    b.kind = BondKind::expression;
    if (functions.size() != 6) throw std::invalid_argument("bond: expected 3 compiled (function, data) pairs");
    auto f = [&](int i) {
      return CompiledFunction{reinterpret_cast<CompiledFunction::Fn>(functions[2 * i]),
                              reinterpret_cast<void*>(functions[2 * i + 1])};
    };
    b.expression = {f(0), f(1), f(2)};
  } else {
    throw std::invalid_argument("bond: unknown bond family '" + bond + "'");
  }
  return b;
}

// The on-site potential: "none", "polynomial" (k2, k4) or "sine" (g); Python maps its
// named forms (harmonic, phi4, sine) onto these and checks the values.
ChainOnSite make_on_site(const std::string& kind, const std::map<std::string, double>& p) {
  ChainOnSite u;
  if (kind == "none") return u;
  if (kind == "polynomial") {
    u.kind = OnSiteKind::polynomial;
    u.polynomial = {parameter(p, "k2"), parameter(p, "k4")};
  } else if (kind == "sine") {
    u.kind = OnSiteKind::sine;
    u.sine.g = parameter(p, "g");
  } else {
    throw std::invalid_argument("on_site: unknown on-site kind '" + kind + "'");
  }
  return u;
}

}  // namespace

void bind_chain(py::module_& m) {
  py::class_<Chain> cls(m, "Chain");
  cls.def(py::init([](int n, const std::string& boundary, const std::string& bond,
                      const std::map<std::string, double>& parameters, double mass, double eps,
                      const std::vector<int>& bonds, const std::vector<double>& bond_c, const std::vector<int>& sites,
                      const std::vector<double>& site_c, const std::vector<std::uintptr_t>& functions,
                      py::object /*keep_alive*/, const std::string& on_site,
                      const std::map<std::string, double>& on_site_parameters) {
            const ChainBoundary b = boundary_of(boundary);
            if (n < 2) throw std::invalid_argument("n must be >= 2 (sites of the chain), got " + std::to_string(n));
            return Chain(n, b, make_bonds(bond, parameters, functions), mass, eps,
                         ChainDamping(b, n, mass, eps, bonds, bond_c, sites, site_c), !sites.empty(),
                         make_on_site(on_site, on_site_parameters));
          }),
          py::arg("n"), py::arg("boundary"), py::arg("bond"), py::arg("parameters"), py::arg("mass"), py::arg("eps"),
          py::arg("bonds"), py::arg("bond_c"), py::arg("sites"), py::arg("site_c"), py::arg("functions"),
          py::arg("keep_alive"), py::arg("on_site") = "none",
          py::arg("on_site_parameters") = std::map<std::string, double>{},
          // An expression bond's compiled code lives as long as the Python object owning it.
          py::keep_alive<1, 13>())
      .def_property_readonly("damping_blocks", [](const Chain& c) { return c.damping.blocks(); })
      .def_property_readonly("largest_damping_block", [](const Chain& c) { return c.damping.largest_block(); })
      .def_property_readonly("damping_spectral_radius", [](const Chain& c) { return c.damping.spectral_radius(); });
  add_model_functions<Chain>(cls);
  def_integrate<Chain>(m);
  def_integrate_ensemble<Chain>(m);
}

}  // namespace raydamp::bindings
