// The built-in models' parameter tables (models/parameters.hpp): the flat values a model is
// built from and gives back, their names, the rules, and the positional constructors.
#include <stdexcept>
#include <string>

#include "check.hpp"
#include "raydamp/models/damped_pendulum.hpp"
#include "raydamp/models/elastic_pendulum.hpp"

using namespace raydamp;
using test::throws;

// What the ensemble's with_parameters relies on: a model built from its own values is that
// model again.
template <class Model>
void check_round_trip(const Model& model) {
  const Model again(model.values);
  CHECK(again.values == model.values);
  CHECK(again.eps == model.eps);
}

// The message a refused value gets: it names the value.
template <class Model>
std::string refusal(typename Model::Values values) {
  try {
    Model model(values);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

int main() {
  static_assert(value_count(ElasticPendulum::parameters) == 7 && value_count(DampedPendulum::parameters) == 1);
  static_assert(value_index<ElasticPendulum>("g") == 4 && value_index<ElasticPendulum>("mass") == -1);
  static_assert(has_parameter_table<ElasticPendulum>::value && !has_parameter_table<Vector<3>>::value);

  // The defaults are the table's, and a model gives back what it was built from.
  const ElasticPendulum standard;
  CHECK(standard.eps == 0.1 && standard.mass.m == 1.0 && standard.k == 1.0 && standard.l == 1.0);
  CHECK(standard.g[0] == 0.0 && standard.g[1] == 0.0 && standard.g[2] == -1.0);
  CHECK(standard.values == default_values<ElasticPendulum>());
  CHECK(DampedPendulum().eps == 0.01);
  check_round_trip(standard);
  check_round_trip(ElasticPendulum(0.3, 1.3, 2.0, 0.9, {0.1, 0.0, -1.0}));
  check_round_trip(DampedPendulum(0.5));

  // Positionally, in table order; the parameters left out keep their defaults.
  const ElasticPendulum leading(0.3);
  CHECK(leading.eps == 0.3 && leading.mass.m == 1.0 && leading.g[2] == -1.0);
  const ElasticPendulum given(0.3, 1.3, 2.0, 0.9, {0.1, 0.0, -1.0});
  CHECK(given.mass.m == 1.3 && given.k == 2.0 && given.l == 0.9 && given.g[0] == 0.1);
  CHECK(given.damping.a == 0.3 / 1.3 && given.mg[2] == -1.3);

  // Names: a vector's components are "g[i]"; an unknown name is refused, naming the model.
  const std::vector<std::string> names = value_names<ElasticPendulum>();
  CHECK(names.size() == 7 && names[0] == "eps" && names[1] == "m" && names[4] == "g[0]" && names[6] == "g[2]");
  CHECK(resolve_value<ElasticPendulum>("g[1]") == 5 && resolve_value<ElasticPendulum>("l") == 3);
  CHECK(throws([] { resolve_value<ElasticPendulum>("g"); }));
  CHECK(throws([] { resolve_value<DampedPendulum>("k"); }));

  // The rules, each refusal naming its value.
  auto values = default_values<ElasticPendulum>();
  values[1] = 0.0;
  CHECK(refusal<ElasticPendulum>(values).rfind("m must be a finite number > 0", 0) == 0);
  values = default_values<ElasticPendulum>();
  values[2] = -1.0;
  CHECK(refusal<ElasticPendulum>(values).rfind("k must be a finite number >= 0", 0) == 0);
  values = default_values<ElasticPendulum>();
  values[6] = std::nan("");
  CHECK(refusal<ElasticPendulum>(values).rfind("g[2] must be finite", 0) == 0);
  values = default_values<ElasticPendulum>();
  values[4] = -5.0;  // a component of g may be any finite number
  CHECK(refusal<ElasticPendulum>(values).empty());
  CHECK(refusal<DampedPendulum>({-0.1}).rfind("eps must be a finite number >= 0", 0) == 0);
  CHECK(throws([] { const DampedPendulum infinite(INFINITY); }));
  TEST_MAIN_RETURN();
}
