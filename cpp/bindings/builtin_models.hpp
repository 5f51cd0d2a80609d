// The built-in models the module binds, each once, with the name of its Python class:
// bind_models.cpp binds their classes and the catalogue _core.models() from this list,
// bind_integrate.cpp their runs.
#pragma once

#include "raydamp/models/damped_pendulum.hpp"
#include "raydamp/models/elastic_pendulum.hpp"

namespace raydamp::bindings {

template <class Model>
struct ModelTag {
  using type = Model;
};

// Calls f(ModelTag<Model>{}, class name) for every built-in model, in catalogue order.
template <class F>
void for_each_builtin_model(F&& f) {
  f(ModelTag<DampedPendulum>{}, "DampedPendulum");
  f(ModelTag<ElasticPendulum>{}, "ElasticPendulum");
}

}  // namespace raydamp::bindings
