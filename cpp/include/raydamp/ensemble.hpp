// Ensembles: many independent runs ("members"), spread over threads. Each member is
// one call of the one step loop (integrate.hpp) on its own model and initial state,
// exactly as a single run, so member i equals a single run bit for bit whatever the
// number of threads or the order in which they pick members up (the members share
// nothing but read-only tables, and no floating-point reduction crosses members).
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace raydamp {

struct EnsembleControl {
  // Called as progress(members finished, members) from whichever thread finished
  // the member, one call at a time, a bounded number of times; the counts only grow
  // and the last call says (members, members).
  std::function<void(long done, long total)> progress;
  long max_progress_calls = 100;
};

// The thread count a request of `threads` (<= 0: one per hardware thread) gives
// for `members` members: never more threads than members.
inline int ensemble_threads(int threads, long members) {
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return static_cast<int>(std::max(1L, std::min<long>(threads, members)));
}

// Calls run_member(i) once for every i in [0, members) on `threads` threads (the
// calling thread is one of them). Members are handed out in increasing order from
// one atomic counter, so a slow member never holds up the others. If run_member
// throws, no further member starts; once every thread has joined, the exception of
// the lowest member index is rethrown (every lower member had already started, so
// which one that is does not depend on timing).
template <class RunMember>
void for_each_member(long members, int threads, RunMember&& run_member, const EnsembleControl& control = {}) {
  threads = ensemble_threads(threads, members);
  std::atomic<long> next{0}, done{0};
  std::atomic<bool> failed{false};
  std::mutex mutex;  // guards the failure record, `reported` and the progress callback
  long failed_member = members;
  long reported = 0;  // the last count given to control.progress
  std::exception_ptr failure;
  const long report_every = std::max(1L, members / std::max(1L, control.max_progress_calls));

  auto work = [&]() {
    for (;;) {
      if (failed.load(std::memory_order_relaxed)) return;
      const long i = next.fetch_add(1, std::memory_order_relaxed);
      if (i >= members) return;
      try {
        run_member(i);
        const long finished = done.fetch_add(1, std::memory_order_acq_rel) + 1;
        if (control.progress && (finished % report_every == 0 || finished == members)) {
          // Two threads can reach here out of order (37 locks before 36): report the
          // count as it is under the lock, and only when it grew, so counts never go
          // back and the last call says `members`.
          std::lock_guard<std::mutex> lock(mutex);
          const long now = done.load(std::memory_order_acquire);
          if (now > reported) {
            reported = now;
            control.progress(now, members);
          }
        }
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (i < failed_member) {
          failed_member = i;
          failure = std::current_exception();
        }
        failed.store(true, std::memory_order_relaxed);
        return;
      }
    }
  };

  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  try {
    for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  } catch (...) {
    failed.store(true);  // could not start a thread: stop the others and report
    for (auto& th : pool) th.join();
    throw;
  }
  work();
  for (auto& th : pool) th.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace raydamp
