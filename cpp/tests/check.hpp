// A minimal assertion harness for the ctest executables: each failed check prints
// what was expected and the test exits non-zero.
#pragma once

#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>

namespace raydamp::test {
inline int failures = 0;

// Whether f refuses with std::invalid_argument (how the core reports a bad table or argument).
inline bool throws(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument&) {
    return true;
  }
  return false;
}
}  // namespace raydamp::test

#define CHECK(cond)                                                                   \
  do {                                                                                \
    if (!(cond)) {                                                                    \
      std::printf("%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);            \
      ++raydamp::test::failures;                                                      \
    }                                                                                 \
  } while (0)

#define CHECK_NEAR(actual, expected, tol)                                             \
  do {                                                                                \
    const double a_ = (actual), e_ = (expected), t_ = (tol);                          \
    if (!(std::abs(a_ - e_) <= t_)) {                                                 \
      std::printf("%s:%d: CHECK_NEAR failed: %s = %.17g, expected %.17g +- %.3g\n", __FILE__, __LINE__, \
                  #actual, a_, e_, t_);                                               \
      ++raydamp::test::failures;                                                      \
    }                                                                                 \
  } while (0)

#define TEST_MAIN_RETURN()                                                             \
  do {                                                                                \
    if (raydamp::test::failures) std::printf("%d check(s) failed\n", raydamp::test::failures); \
    else std::printf("all checks passed\n");                                          \
    return raydamp::test::failures ? 1 : 0;                                           \
  } while (0)
