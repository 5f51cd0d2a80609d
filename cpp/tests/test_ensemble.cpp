// Ensembles: members spread over threads equal their single runs bit for bit whatever
// the thread count; a failing member reports the lowest failing index.
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"
#include "raydamp/ensemble.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

int main() {
  const ButcherTableau heun = builtin_tableau("heun");
  const long members = 37;
  std::vector<DampedPendulum> models;
  std::vector<State<1>> starts;
  for (long i = 0; i < members; ++i) {
    models.emplace_back(0.01 * i);
    starts.push_back(State<1>{Vector<1>(-3.0 + 0.15 * i), Vector<1>(0.1 * (i % 5))});
  }
  const RunSpec spec{0.05, 301, 0.05, 7};
  std::vector<RunResult> single(members);
  for (long i = 0; i < members; ++i) single[i] = integrate<ThreeTermSplitting>(models[i], heun, starts[i], spec);

  for (int threads : {1, 2, 3, 8}) {
    std::vector<RunResult> ens(members);
    long reported = 0;
    EnsembleControl control;
    control.progress = [&](long done, long total) {
      CHECK(total == members);
      CHECK(done > reported);  // one call at a time, counts only grow
      reported = done;
    };
    for_each_member(members, threads, [&](long i) {
      ens[i] = integrate<ThreeTermSplitting>(models[i], heun, starts[i], spec);
    }, control);
    CHECK(reported == members);
    for (long i = 0; i < members; ++i) {
      CHECK(ens[i].trajectory.q == single[i].trajectory.q);  // exact equality of every saved double
      CHECK(ens[i].trajectory.p == single[i].trajectory.p);
      CHECK(ens[i].trajectory.t == single[i].trajectory.t);
      CHECK(ens[i].steps == single[i].steps);
    }
  }

  // Members 11 and 23 fail; whatever the threads, member 11's error is the one reported.
  for (int threads : {1, 2, 4}) {
    std::string what;
    try {
      for_each_member(members, threads, [&](long i) {
        if (i == 11 || i == 23) throw std::invalid_argument("h: bad for member " + std::to_string(i));
      });
    } catch (const std::invalid_argument& e) {
      what = e.what();
    }
    CHECK(what == "member 11: h: bad for member 11");
  }
  CHECK(ensemble_threads(0, 5) >= 1);
  CHECK(ensemble_threads(4, 2) == 2);
  return raydamp::test::failures == 0 ? 0 : 1;
}
