// The load a run takes (raydamp/load.hpp) as the Python side hands it over: the terms,
// and the Python objects that own its compiled expressions (kept alive with it).
#pragma once

#include <pybind11/pybind11.h>

#include "raydamp/load.hpp"

namespace raydamp::bindings {

struct BoundLoad {
  Load load;
  pybind11::object owners;
};

// The C++ load of an optional BoundLoad (None: no load).
inline const Load* load_of(const BoundLoad* bound) { return bound && !bound->load.empty() ? &bound->load : nullptr; }

}  // namespace raydamp::bindings
