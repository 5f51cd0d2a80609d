// The ensemble's lane path for Kepler test particles: runs of consecutive members that share mu, the
// mass, eps and its direction (or matrix), the dimension and the particle count (only their initial states differ:
// the usual ensemble of decaying orbits) go through the one step loop as the particles of one Planets,
// then are split back into members.
//
// Why a member's rows equal its single run's bit for bit: test particles do not interact, so each
// sub-flow acts on every particle alone, with the arithmetic of a member's own run. The drift is
// kepler::drift per particle; the kick is none; the damping multiplies p element by element by one set of
// factors (PlanetDrag::same, as in a member's run; with g = 0 the kick-damp flow too). The loop is the
// compiled run_steps<Method, Planets> a single run takes (no new instantiation of the step loop), its
// blocks end at the same saves and progress points, so steps merge at the same places. What the loop
// sums over the whole state is redone per member when the batch is split: each row's energy and angular
// momentum from the member's (q, p) with its own model, the single run's formula.
//
// What is not the single run's:
// - max_momentum_drift. The batch lists each member's L (Planets::groups), so the loop's drift at a step
//   is the largest of the members' drifts, each from its own law; every member of the batch is given
//   that largest, the largest of their single runs' values (>= its own, equal for one of them).
// - The loop's checks are of the whole state. A batch that ends other than completed or cancelled (a
//   member's state stopped being finite, the summed energy diverged, memory ran out) is run again
//   member by member, so each member gets its own status, rows and message. A cancelled batch is split:
//   each member cancelled at the batch's step with its rows so far, as its own run would be. The
//   divergence test sees the batch's summed energy, where a single run sees the member's; it cannot
//   fire for test particles in either (the drift keeps each particle's energy, the damping only removes
//   kinetic energy, and there is no load or temperature here), so none is missed.
// - A block whose merged steps leave a member non-finite where the same steps run whole do not goes on
//   from the whole steps' replay (integrate.hpp): the batch's other members then take that block whole
//   too, which changes their rounding (about 1e-16 relative per step; both are the same exact flows).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "raydamp/ensemble/lanes.hpp"
#include "raydamp/errors.hpp"
#include "raydamp/integrate.hpp"
#include "raydamp/models/planets.hpp"

namespace raydamp {

// Whether members a and b run as particles of one model: test particles with the same parameters.
inline bool same_test_particles(const Planets& a, const Planets& b) {
  if (&a == &b) return !a.interacting;
  return !a.interacting && !b.interacting && a.G == b.G && a.d == b.d && a.planets == b.planets &&
         a.eps == b.eps && a.drag == b.drag && a.mass.m[0] == b.mass.m[0] &&
         a.drag_matrix.rows() == b.drag_matrix.rows() && a.drag_matrix.cols() == b.drag_matrix.cols() &&
         a.drag_matrix == b.drag_matrix;
}

// Consecutive members that run as one model's particles, cut every `lanes` members; an interacting
// member is a batch of its own.
inline std::vector<LaneBatch> kepler_batches(const std::vector<const Planets*>& models, long lanes) {
  return consecutive_batches(models, lanes, same_test_particles);
}

// Runs batch's members (test particles, same_test_particles) as the particles of one Planets and hands
// each to store(i, RunResult) as its own run; a batch that ends other than completed or cancelled is run
// again member by member with run_member(i), each member's single run.
template <class Method, class Store, class RunMember>
void run_kepler_lanes(const Planets& member, const LaneBatch& batch, const ButcherTableau& tab,
                      const Composition& comp, const double* q0, const double* p0, const RunSpec& spec,
                      const Control& control, Store& store, RunMember& run_member) {
  using Vec = Planets::Vec;
  const int lanes = static_cast<int>(batch.end - batch.begin);
  const int n = member.size();
  // integrate's own check, as a member's single run makes it. Test particles' drag does not depend on q,
  // so it gives every member of the batch the same answer: made once, for the first.
  try {
    check_amplification<Method>(member, Vec(Eigen::Map<const Vec>(q0 + batch.begin * n, n)), tab, comp, spec.h);
  } catch (const std::invalid_argument& e) {
    rethrow_prefixed("member " + std::to_string(batch.begin) + ": ", e);
  }
  Planets model(TestParticles{}, member.G, member.mass.m[0], member.d, member.planets * lanes, member.eps,
                member.drag, member.drag_matrix);
  model.groups = lanes;
  State<Eigen::Dynamic> z{Eigen::Map<const Vec>(q0 + batch.begin * n, static_cast<long>(lanes) * n),
                          Eigen::Map<const Vec>(p0 + batch.begin * n, static_cast<long>(lanes) * n)};
  RunResult r = detail::run_steps<Method>(model, tab, comp, std::move(z), spec, control);
  if (r.status != Status::completed && r.status != Status::cancelled) {
    for (long i = batch.begin; i < batch.end; ++i) run_member(i);
    return;
  }
  const Trajectory& tr = r.trajectory;
  const long rows = tr.rows();
  const int m = momentum_count(member);
  // One member's result, refilled for each: its buffers are allocated once per batch (store() copies what
  // it keeps). x is a member's state as its run holds it, on the heap, so that the energy's sums take the
  // same path through Eigen as there.
  RunResult one;
  Trajectory& out = one.trajectory;
  State<Eigen::Dynamic> x{Vec(n), Vec(n)};
  for (int lane = 0; lane < lanes; ++lane) {
    copy_outcome(r, one);
    out.n = n;
    out.n_momenta = m;
    out.t = tr.t;
    out.q.resize(rows * n);
    out.p.resize(rows * n);
    out.energy.resize(rows);
    out.momentum.resize(rows * m);
    for (long row = 0; row < rows; ++row) {
      const long at = row * static_cast<long>(lanes) * n + static_cast<long>(lane) * n;
      for (int k = 0; k < n; ++k) {
        out.q[row * n + k] = x.q[k] = tr.q[at + k];
        out.p[row * n + k] = x.p[k] = tr.p[at + k];
      }
      out.energy[row] = energy(member, x);
      if (m > 0) member.momenta(x.q, x.p, out.momentum.data() + row * m);
    }
    store(batch.begin + lane, std::move(one));
  }
}

}  // namespace raydamp
