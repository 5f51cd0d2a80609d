// The sparse LDL^T solver lives in linalg/, owned by neither the methods nor the models
// that use it; this path forwards there for code written against it.
#pragma once

#include "raydamp/linalg/sparse_ldlt.hpp"
