// The save grid: the rows a completed run keeps (step 0, every save_every-th step, and the
// last step) and their times. The step loop, the ensemble's arrays and Python's size checks
// all count rows here.
#pragma once

#include <stdexcept>
#include <vector>

namespace raydamp {

// Time after k of n_steps steps of size h, the last of size h_last (so the run lands on t_end).
inline double step_time(long k, double h, long n_steps, double h_last) {
  return k == n_steps && h_last != h ? (n_steps - 1) * h + h_last : k * h;
}

// Rows a completed run of n_steps steps saves every save_every steps: step 0, each multiple of
// save_every, and the last step when it is not one.
inline long save_rows(long n_steps, long save_every) {
  if (n_steps < 0 || save_every < 1) throw std::invalid_argument("save_rows: n_steps >= 0 and save_every >= 1");
  return n_steps / save_every + 1 + (n_steps % save_every != 0 ? 1 : 0);
}

// The times of those rows.
inline std::vector<double> save_grid(double h, long n_steps, double h_last, long save_every) {
  std::vector<double> grid;
  grid.reserve(static_cast<std::size_t>(save_rows(n_steps, save_every)));
  for (long k = 0; k <= n_steps; k += save_every) grid.push_back(step_time(k, h, n_steps, h_last));
  if (n_steps % save_every != 0) grid.push_back(step_time(n_steps, h, n_steps, h_last));
  return grid;
}

}  // namespace raydamp
