// The whole header-only library.
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
