// Compiler attributes the step loop's speed depends on.
#pragma once

// Out of line: the step loop of a small model is flattened (integrate.hpp), and inlined there a
// load's evaluation or the noise's generator would enlarge every step's code, loaded or not.
// Such a call must never see the address of the loop's state (flows/exact.hpp, add_load).
#ifndef RAYDAMP_OUT_OF_LINE
#if defined(__GNUC__) || defined(__clang__)
#define RAYDAMP_OUT_OF_LINE __attribute__((noinline))
#else
#define RAYDAMP_OUT_OF_LINE
#endif
#endif
