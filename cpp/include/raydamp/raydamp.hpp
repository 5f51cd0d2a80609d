// The whole header-only library.
#pragma once

#include "raydamp/catalogue.hpp"
#include "raydamp/integrate.hpp"
#include "raydamp/models/damped_pendulum.hpp"
#include "raydamp/models/elastic_pendulum.hpp"
