// A built-in model's parameters, declared once beside its struct: a table of rows
// {name, size (1, or 3 for a vector), default(s), rule, doc}. The model is built from
// a flat array of values in table order (a vector's components in turn) and keeps
// that array, so it can be read back; the checks, the names of the values ("eps",
// "g[1]"), an ensemble's per-member parameters and the catalogue Python reads
// (_core.models()) all come from the table. Adding a parameter is a row here and its
// use in the model's formulas.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "raydamp/models/check.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

// What a parameter's values must be: every value is finite, and >= 0 or > 0 if so stated.
enum class Rule { finite, nonnegative, positive };

struct Parameter {
  const char* name;
  int size;                        // 1, or 3 for a vector
  std::array<double, 3> defaults;  // the first `size` are used
  Rule rule;
  const char* doc;

  constexpr Parameter(const char* name_, double default_, Rule rule_, const char* doc_)
      : name(name_), size(1), defaults{default_, 0.0, 0.0}, rule(rule_), doc(doc_) {}
  constexpr Parameter(const char* name_, std::array<double, 3> default_, Rule rule_, const char* doc_)
      : name(name_), size(3), defaults(default_), rule(rule_), doc(doc_) {}
};

// How many values a table takes: the sum of its rows' sizes.
template <std::size_t N>
constexpr int value_count(const std::array<Parameter, N>& table) {
  int n = 0;
  for (const Parameter& p : table) n += p.size;
  return n;
}

// Whether Model declares a parameter table (the built-in models do; a System, a Chain
// and a LinearStructure carry their parameters in their own forms).
template <class Model, class = void>
struct has_parameter_table : std::false_type {};
template <class Model>
struct has_parameter_table<Model, std::void_t<decltype(Model::parameters), typename Model::Values>>
    : std::true_type {};

// The values of the table's defaults, in table order.
template <class Model>
constexpr typename Model::Values default_values() {
  typename Model::Values values{};
  int at = 0;
  for (const Parameter& p : Model::parameters)
    for (int i = 0; i < p.size; ++i) values[at++] = p.defaults[i];
  return values;
}

// The index of parameter `name`'s first value in the flat array (a constant expression
// when the name is; -1 if the table has no such parameter).
template <class Model>
constexpr int value_index(std::string_view name) {
  int at = 0;
  for (const Parameter& p : Model::parameters) {
    if (name == p.name) return at;
    at += p.size;
  }
  return -1;
}

// Parameter `name`'s value (its first component for a vector): what a model's
// constructor reads its fields from. A name not in the table is a programming error.
template <class Model>
constexpr double value_of(const typename Model::Values& values, std::string_view name) {
  const int at = value_index<Model>(name);
  if (at < 0) throw std::logic_error("parameters: no parameter '" + std::string(name) + "' in the table");
  return values[at];
}

// A vector parameter's N components, as an Eigen vector.
template <class Model, int N>
Vector<N> vector_of(const typename Model::Values& values, std::string_view name) {
  const int at = value_index<Model>(name);
  if (at < 0) throw std::logic_error("parameters: no parameter '" + std::string(name) + "' in the table");
  return Eigen::Map<const Vector<N>>(values.data() + at);
}

// The names of the flat values: a scalar's own name, a vector's components "g[0]" ...
template <class Model>
std::vector<std::string> value_names() {
  std::vector<std::string> names;
  for (const Parameter& p : Model::parameters) {
    if (p.size == 1) names.emplace_back(p.name);
    else
      for (int i = 0; i < p.size; ++i) names.push_back(std::string(p.name) + "[" + std::to_string(i) + "]");
  }
  return names;
}

// The index of the value named `name` ("eps", "g[1]"); an unknown name raises, naming it
// and the model.
template <class Model>
int resolve_value(const std::string& name) {
  const std::vector<std::string> names = value_names<Model>();
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  throw std::invalid_argument("parameters: " + std::string(Model::name) + " has no parameter '" + name + "'");
}

// Refuses values that break their row's rule, naming the value ("m", "g[2]").
template <class Model>
const typename Model::Values& check_values(const typename Model::Values& values) {
  int at = 0;
  for (const Parameter& p : Model::parameters) {
    for (int i = 0; i < p.size; ++i, ++at) {
      const double x = values[at];
      if (std::isfinite(x) && (p.rule == Rule::finite || (p.rule == Rule::nonnegative && x >= 0.0) ||
                               (p.rule == Rule::positive && x > 0.0)))
        continue;
      const std::string name = p.size == 1 ? p.name : std::string(p.name) + "[" + std::to_string(i) + "]";
      detail::require(false, name,
                      p.rule == Rule::finite        ? "finite"
                      : p.rule == Rule::nonnegative ? "a finite number >= 0"
                                                    : "a finite number > 0",
                      x);
    }
  }
  return values;
}

namespace detail {

// Writes one leading value (a scalar, or a vector's components) at `at`; returns the next index.
template <class Values>
constexpr int put_leading(Values& values, int at, double value) {
  values[at] = value;
  return at + 1;
}

template <class Values, std::size_t N>
constexpr int put_leading(Values& values, int at, const std::array<double, N>& value) {
  for (std::size_t i = 0; i < N; ++i) values[at + static_cast<int>(i)] = value[i];
  return at + static_cast<int>(N);
}

}  // namespace detail

// The defaults with the first parameters, in table order, replaced by `leading`
// (scalars, and std::array<double, 3> for a vector): what a C++ caller's positional
// constructor passes on, e.g. ElasticPendulum(0.3) or ElasticPendulum(0.3, 1.3).
template <class Model, class... Leading>
constexpr typename Model::Values leading_values(const Leading&... leading) {
  typename Model::Values values = default_values<Model>();
  int at = 0;
  ((at = detail::put_leading(values, at, leading)), ...);
  return values;
}

}  // namespace raydamp
