// The recorder: what a run keeps as it goes, observed from the step loop (integrate.hpp) by
// inline calls, never a virtual one. It saves rows (q, p, energy, momentum maps, work), sums the
// damping work and the load's work by the trapezoidal rule on the step's end points, and takes
// back a row that ran out of memory, so every array keeps the same rows.
//
// The loop drives it through
//   on_step(x, dt, t)   after each step (or each stage of a composed step, with work tracked):
//                       per-step quantities accumulate here (work; envelopes and event functions
//                       hook in the same way);
//   save(z, t) -> bool  a saved row; false when memory ran out (the partial row is taken back);
//   marks(), restore()  what a checkpoint keeps of it, so a block can be replayed.
#pragma once

#include <algorithm>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/concepts.hpp"
#include "raydamp/diagnostics.hpp"
#include "raydamp/record/marks.hpp"
#include "raydamp/record/save_grid.hpp"
#include "raydamp/record/spring_work.hpp"
#include "raydamp/run_types.hpp"
#include "raydamp/workspace.hpp"

namespace raydamp {

inline constexpr long kReserveRows = 1L << 16;  // saved rows reserved before the first step

// Trapezoid: the work is summed here (false: the method integrates it itself, see integrates_work).
template <class Model, int Dim, bool Trapezoid>
class Recorder {
 public:
  using Marks = RecorderMarks;

  Recorder(const Model& model, const RunSpec& spec, WorkspaceFor<Model>& ws, Trajectory& out)
      : model_(model), ws_(ws), out_(out), dofs_(spec.save_dofs), j_(momentum_count(model)),
        track_(spec.track_work && Trapezoid), track_load_(track_ && ws.load), springs_(model, spec.track_work) {
    const int n = model.size();
    for (int i : dofs_)
      if (i < 0 || i >= n) throw std::invalid_argument("save_dofs: " + std::to_string(i) + " is not a coordinate");
    out.n = dofs_.empty() ? n : static_cast<int>(dofs_.size());
    out.n_momenta = static_cast<int>(j_.size());
    out.n_springs = static_cast<int>(spring_count(model));
    // Reserved up to kReserveRows rows; past that the buffers grow at save points (never inside a
    // block of steps), so a run asking for more rows than memory holds saves what fits and stops
    // with out_of_memory instead of failing before its first step.
    const long rows = std::min(save_rows(spec.n_steps, spec.save_every), kReserveRows);
    out.t.reserve(rows);
    out.q.reserve(rows * out.n);
    out.p.reserve(rows * out.n);
    out.energy.reserve(rows);
    out.momentum.reserve(rows * j_.size());
    if (spec.track_work) out.work.reserve(rows);
    if (spec.track_work && ws.load) out.load_work.reserve(rows);
    out.spring_force.reserve(rows * out.n_springs);
    out.spring_deformation.reserve(rows * out.n_springs);
    out.spring_work.reserve(rows * springs_.size());
  }

  bool tracks_work() const { return track_; }

  // Row 0 and the powers the trapezoids start from.
  void start(const State<Dim>& z) {
    springs_.start(z);
    save_row(z, 0.0);
    if (track_) power_ = dissipated_power(model_, z, ws_);
    if (track_load_) power_f_ = load_power(z, 0.0);
  }

  // After a step or stage of length dt that ended at t.
  void on_step(const State<Dim>& x, double dt, double t) {
    springs_.on_point(x, t);  // each spring's hysteretic work (record/spring_work.hpp), with work tracked
    if constexpr (Trapezoid) {
      if (!track_) return;
      const double next = dissipated_power(model_, x, ws_);
      ws_.work += 0.5 * dt * (power_ + next);
      power_ = next;
      if (track_load_) {
        const double next_f = load_power(x, t);
        ws_.load_work += 0.5 * dt * (power_f_ + next_f);
        power_f_ = next_f;
      }
    }
  }

  bool save(const State<Dim>& z, double t) {
    const std::size_t sizes[] = {out_.t.size(), out_.q.size(), out_.p.size(), out_.energy.size(),
                                 out_.momentum.size(), out_.work.size(), out_.load_work.size(),
                                 out_.spring_work.size(), out_.spring_force.size(),
                                 out_.spring_deformation.size()};
    try {
      save_row(z, t);
      return true;
    } catch (const std::bad_alloc&) {
      out_.t.resize(sizes[0]);
      out_.q.resize(sizes[1]);
      out_.p.resize(sizes[2]);
      out_.energy.resize(sizes[3]);
      out_.momentum.resize(sizes[4]);
      out_.work.resize(sizes[5]);
      out_.load_work.resize(sizes[6]);
      out_.spring_work.resize(sizes[7]);
      out_.spring_force.resize(sizes[8]);
      out_.spring_deformation.resize(sizes[9]);
      return false;
    }
  }

  // Where the damping changes while the state does not (a spring changing phase under tangent-stiffness
  // damping), the next trapezoid starts from the power on the new branch: from the old one, the work would
  // be O(h) off at every yield and unloading.
  void restart_power(const State<Dim>& x) {
    if constexpr (Trapezoid) {
      if (track_) power_ = dissipated_power(model_, x, ws_);
    }
  }

  Marks marks() const { return {ws_.work, power_, ws_.load_work, power_f_}; }
  void restore(const Marks& m) {
    ws_.work = m.work;
    power_ = m.power;
    ws_.load_work = m.load_work;
    power_f_ = m.power_f;
  }

 private:
  // The load's power f(t) . M^{-1} p.
  double load_power(const State<Dim>& x, double t) {
    model_.mass.velocity(x.p, ws_.v);
    return ws_.load->dot(t, ws_.v.data());
  }

  void save_row(const State<Dim>& z, double t) {
    out_.t.push_back(t);
    if (ws_.track_work) out_.work.push_back(ws_.work);
    if (ws_.track_work && ws_.load) out_.load_work.push_back(ws_.load_work);
    springs_.append(out_.spring_work);
    append_springs(z.q);
    if (dofs_.empty()) {
      out_.q.insert(out_.q.end(), z.q.data(), z.q.data() + z.q.size());
      out_.p.insert(out_.p.end(), z.p.data(), z.p.data() + z.p.size());
    } else {
      for (int i : dofs_) out_.q.push_back(z.q[i]);
      for (int i : dofs_) out_.p.push_back(z.p[i]);
    }
    out_.energy.push_back(energy(model_, z));
    if (j_.empty()) return;
    model_.momenta(z.q, z.p, j_.data());
    out_.momentum.insert(out_.momentum.end(), j_.begin(), j_.end());
  }

  static std::size_t spring_count(const Model& model) {
    if constexpr (has_materials_v<Model>) return model.springs.size();
    else return (static_cast<void>(model), 0);
  }

  // d_s and sigma_s at the row's q, sigma_s from the committed states. A row is saved after its step's commit,
  // so these are the forces of the material state of that row, which a model rebuilt afterwards (in its virgin
  // state) cannot give: Solution.absolute_acceleration and the force-deformation loops read them.
  template <class Vec>
  void append_springs(const Vec& q) {
    if constexpr (has_materials_v<Model>) {
      const std::size_t at = out_.spring_force.size(), n = model_.springs.size();
      out_.spring_force.resize(at + n);
      out_.spring_deformation.resize(at + n);
      double* f = out_.spring_force.data() + at;
      double* d = out_.spring_deformation.data() + at;
      model_.springs.for_each([&](const auto& set) {
        set.forces(q, f);
        for (std::size_t s = 0; s < set.size(); ++s) d[s] = set.deformation(q, s);
        f += set.size();
        d += set.size();
      });
    } else {
      static_cast<void>(q);
    }
  }

  const Model& model_;
  WorkspaceFor<Model>& ws_;
  Trajectory& out_;
  const std::vector<int>& dofs_;
  std::vector<double> j_;  // the momentum maps of a saved row
  const bool track_, track_load_;
  double power_ = 0.0, power_f_ = 0.0;  // the trapezoids' last points
  SpringWork<Model> springs_;
};

// What a restart needs: the state, the recorder's sums and the noise streams' position. The loop
// takes one at each block's start and replays a block that blew up from it.
template <int Dim, class Marks>
struct Checkpoint {
  State<Dim> z;
  Marks marks;

  explicit Checkpoint(const State<Dim>& start) : z(start) {}  // sized now: taking one never allocates
  template <class WS, class Rec>
  void take(const State<Dim>& x, WS& ws, const Rec& rec, bool noise = true) {
    z = x;
    marks = rec.marks();
    if (noise) ws.save_noise();
  }
  template <class WS, class Rec>
  void restore(State<Dim>& x, WS& ws, Rec& rec, bool noise = true) const {
    x = z;
    rec.restore(marks);
    if (noise) ws.restore_noise();
  }
};

}  // namespace raydamp
