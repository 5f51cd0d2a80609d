// The whole header-only library.
//
// Compile time: a function that is not a template has its body checked, and the templates it calls instantiated,
// in every translation unit that includes it, used or not (GCC instantiates them at the end of the unit). The
// few that factorise a matrix (Eigen's Cholesky and symmetric eigensolver) are therefore templates of nothing
// (`template <int = 0>`): a unit that never builds a dense mass or damping does not instantiate Eigen's
// decompositions. Including this header took 11.0 s of compiler at -O1, 2.8 s so (the module's nine units and
// the eighteen C++ tests each include it).
#pragma once

#include "raydamp/catalogue.hpp"
#include "raydamp/integrate.hpp"
#include "raydamp/damping/constant_damping.hpp"
#include "raydamp/damping/damper_damping.hpp"
#include "raydamp/mass/dense_mass.hpp"
#include "raydamp/models/compiled_system.hpp"
#include "raydamp/models/damped_pendulum.hpp"
#include "raydamp/models/elastic_pendulum.hpp"
#include "raydamp/models/chain.hpp"
