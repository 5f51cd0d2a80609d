// What can be asked for: methods (one row per usable tableau) and tableaux.
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "raydamp/amplification.hpp"
#include "raydamp/catalogue.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

static const char* kind_name(TableauKind k) {
  switch (k) {
    case TableauKind::explicit_: return "explicit";
    case TableauKind::diagonally_implicit: return "diagonally_implicit";
    default: return "implicit";
  }
}

void bind_catalogue(py::module_& m) {
  m.def("methods", [] {
    py::list rows;
    for (const MethodEntry& e : method_entries()) {
      auto add = [&](const ButcherTableau* tab) {
        py::dict row;
        row["name"] = e.name;
        row["description"] = e.description;
        row["tableau"] = tab ? py::cast(tab->name()) : py::none();
        row["default"] = !tab || tab->name() == e.default_tableau;
        row["order"] = tab ? method_order(e, *tab) : e.splitting_order;
        row["explicit"] = tab ? tab->is_explicit() : !e.linear_implicit && !e.springs_only;
        row["damped"] = !e.ignores_damping;
        row["symmetric"] = is_composable(e, tab ? *tab : builtin_tableau("euler"));
        row["linear_structure_only"] = e.linear_implicit;
        row["structure_only"] = e.springs_only;
        rows.append(row);
      };
      if (e.tableau_use == TableauUse::none) {
        add(nullptr);
        continue;
      }
      for (const ButcherTableau& tab : builtin_tableaux()) {
        try {
          resolve_tableau(e, tab.name());
        } catch (const std::invalid_argument&) {
          continue;  // this method cannot use this tableau
        }
        add(&tab);
      }
    }
    return rows;
  });
  m.def("tableaux", [] {
    py::list rows;
    for (const ButcherTableau& tab : builtin_tableaux()) {
      const int s = tab.stages();
      std::vector<std::vector<double>> a(s, std::vector<double>(s));
      std::vector<double> b(s), c(s);
      for (int i = 0; i < s; ++i) {
        b[i] = tab.b(i);
        c[i] = tab.c(i);
        for (int j = 0; j < s; ++j) a[i][j] = tab.a(i, j);
      }
      py::dict row;
      row["name"] = tab.name();
      row["stages"] = s;
      row["order"] = tab.order();
      row["kind"] = kind_name(tab.kind());
      row["a"] = a;
      row["b"] = b;
      row["c"] = c;
      rows.append(row);
    }
    return rows;
  });
  // A method's stage table, in the order applied: [(sub-flow, fraction of h), ...].
  // Python derives from it what it builds of a method (the fused 3s body of a
  // compiled system, system/compile.py) instead of writing the table again.
  m.def("splitting", [](const std::string& method) {
    return with_method(method, [](auto table) {
      py::list stages;
      for (const Stage& s : decltype(table)::stages) stages.append(py::make_tuple(flow_name(s.flow), s.fraction));
      return stages;
    });
  });
  m.attr("MAX_AMPLIFICATION") = kMaxAmplification;
  m.def("compositions", [] {
    py::list rows;
    for (const Composition& c : builtin_compositions()) {
      py::dict row;
      row["name"] = c.name();
      row["order"] = c.order();
      row["stages"] = c.stages();
      row["gammas"] = c.gammas();
      row["reference"] = c.reference();
      row["kind"] = c.is_table() ? "near_integrable" : "composition";
      row["ends"] = c.ends();
      row["eps_order"] = c.eps_order();
      rows.append(row);
    }
    return rows;
  });
  // Validates a (method, tableau, composition) triple the way a run would; returns
  // the composition used and the run's order.
  m.def("resolve_composition", [](const std::string& method, const std::string& tableau,
                                   const std::string& composition) {
    const MethodEntry& e = method_entry(method);
    const ButcherTableau& tab = resolve_tableau(e, tableau);
    const Composition& c = resolve_composition(e, tab, composition);
    return py::make_tuple(c.name(), method_order(e, tab, c));
  });
  // A user's tableau, validated and stored; its name and what was computed of it.
  m.def("define_tableau", [](std::vector<std::vector<double>> a, std::vector<double> b, std::vector<double> c) {
    const ButcherTableau& tab = define_tableau(std::move(a), std::move(b), std::move(c));
    py::dict row;
    row["name"] = tab.name();
    row["order"] = tab.order();
    row["kind"] = kind_name(tab.kind());
    row["symmetric"] = tab.is_symmetric();
    return row;
  });
  // Validates a (method, tableau) pair the way a run would; returns the tableau used.
  m.def("resolve", [](const std::string& method, const std::string& tableau) {
    return resolve_tableau(method_entry(method), tableau).name();
  });
}

}  // namespace raydamp::bindings
