// The built-in models, with the functions Python needs for diagnostics and reference
// solutions (energy, gradient, damping, momenta) and the exact sub-flows one at a time;
// and their catalogue, _core.models(): each model's parameter table as Python reads it.
#include "builtin_models.hpp"
#include "model_functions.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

namespace {

const char* rule_name(Rule rule) {
  switch (rule) {
    case Rule::nonnegative: return ">= 0";
    case Rule::positive: return "> 0";
    default: return "finite";
  }
}

// One model's catalogue row: its name, Python class, dimension, momentum maps and
// parameters (name, size, default: a number, or a list for a vector; rule; description).
template <class Model>
py::dict describe(const char* class_name) {
  py::list parameters;
  for (const Parameter& p : Model::parameters) {
    py::dict row;
    row["name"] = p.name;
    row["size"] = p.size;
    if (p.size == 1) row["default"] = p.defaults[0];
    else row["default"] = std::vector<double>(p.defaults.begin(), p.defaults.begin() + p.size);
    row["rule"] = rule_name(p.rule);
    row["description"] = p.doc;
    parameters.append(row);
  }
  py::dict out;
  out["name"] = Model::name;
  out["class_name"] = class_name;
  out["dim"] = Model::dim;
  out["momenta"] = std::vector<std::string>(Model::momentum_names.begin(), Model::momentum_names.end());
  out["parameters"] = parameters;
  out["value_names"] = value_names<Model>();
  return out;
}

// The class, built from the flat values in table order (a vector's components in turn),
// which `values` gives back.
template <class Model>
void bind_builtin(py::module_& m, const char* class_name) {
  py::class_<Model> cls(m, class_name);
  cls.def(py::init<const typename Model::Values&>(), py::arg("values")).def_readonly("values", &Model::values);
  add_model_functions<Model>(cls);
}

}  // namespace

void bind_models(py::module_& m) {
  for_each_builtin_model([&](auto tag, const char* class_name) { bind_builtin<typename decltype(tag)::type>(m, class_name); });
  m.def("models", [] {
    py::list rows;
    for_each_builtin_model([&](auto tag, const char* class_name) {
      rows.append(describe<typename decltype(tag)::type>(class_name));
    });
    return rows;
  });
}

}  // namespace raydamp::bindings
