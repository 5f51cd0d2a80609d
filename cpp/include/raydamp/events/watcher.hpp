// The step loop's observer of events and dense output (issue 41). After every whole step it reads
// the step's end: q, p, v = M^{-1} p and, where needed, f = pdot = -grad V - eps D M^{-1} p + load;
// keeps that row for dense output; evaluates each event function g and its rate dg/dt; and where g
// changes sign over the step, or its rate does (an extremum inside the step: a touch or a double
// crossing), locates the crossing on the step's cubic Hermite interpolant (events/hermite.hpp) by a
// bracketing root finder to within a few roundings of t. It never changes the state it observes, so
// the stepped trajectory is the same with and without it. A terminal event stops it; the loop then
// asks finish() to step from the crossing step's start to the crossing time only.
//
// Its cost when off is one branch per step; the work sits in observe(), kept out of line so that the
// flattened step loops do not carry copies of it. On, a step costs one call of the events' compiled
// function and a branch-free scan of the signs of g and dg/dt at both ends (detect()). Affine events
// cost less (quiet()): those whose g differ only by their constant (levels of one drift, of q and of p)
// share one form L = sum of coefficient * input, computed once a step; its rate is every such g's
// dg/dt, and which of their g are positive is which of their levels -constant L passes. A step whose
// every form stays inside the same gap between its levels, clear of both by a rounding bound, with its
// rate's sign kept, has no crossing; any other step gets every g at both ends and the scan above.
// Affine events of q and t alone (no force needed at a step end) are screened without observing the
// quiet steps. On a model of fixed size (the damped pendulum), the loop only stores each step's end, and
// the block's ends are screened when it is done, four to a vector (batch_screens, events/block_sums.hpp);
// elsewhere each step is screened inline in the loop (screen), from the start the loop kept. Where several
// groups read the q of a model of run-time size, the step is screened by a bound on how far its q moved
// instead (within_budget): no sum per group until some group's L may have come near one of its levels.
#pragma once

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "raydamp/events/block_sums.hpp"
#include "raydamp/events/henon.hpp"
#include "raydamp/events/hermite.hpp"
#include "raydamp/events/types.hpp"
#include "raydamp/mass/unit_mass.hpp"
#include "raydamp/record/marks.hpp"
#include "raydamp/record/model_view.hpp"
#include "raydamp/record/save_grid.hpp"
#include "raydamp/run_types.hpp"

#if defined(__GNUC__) || defined(__clang__)
#define RAYDAMP_NOINLINE __attribute__((noinline))
// Out of line, with everything it calls inlined except what is marked RAYDAMP_NOINLINE: the per-step
// path is one call, and calls through the module's PLT stay on the rare paths.
#define RAYDAMP_NOINLINE_FLAT __attribute__((noinline, flatten))
#else
#define RAYDAMP_NOINLINE
#define RAYDAMP_NOINLINE_FLAT
#endif

namespace raydamp {

// One class for every model (record/model_view.hpp): the model is seen through a ModelView, the
// state through its raw q and p.
class EventWatcher {
  using Vec = Eigen::VectorXd;
  using Kind = EventSlot::Kind;
  // A step's end as raw values (q, p, v, f: the observer's vectors, or the model's own at a fixed size).
  struct End {
    const double *q, *p, *v, *f;
  };

 public:
  // From the initial state z at t: each g must be finite there (a g that is not is refused, naming it).
  EventWatcher(const ModelView& model, const RunSpec& spec, RunResult& result, StateView z, double t)
      : model_(model), set_(spec.events && !spec.events->empty() ? spec.events : nullptr), load_(spec.load),
        dense_(spec.dense ? &result.dense : nullptr), log_(result.events), on_(set_ != nullptr || spec.dense),
        h_(spec.h), h_last_(spec.h_last), steps_(spec.n_steps) {
    if (!on_) return;
    n_ = model.n;
    for (Vec* v : {&q_[0], &p_[0], &v_[0], &f_[0], &q_[1], &p_[1], &v_[1], &f_[1], &grad_, &rate_, &fa_, &fb_,
                   &land_q_, &land_p_, &kept_q_, &kept_p_, &speed_})
      v->setZero(n_);
    log_.n = n_;
    forces_ = spec.dense;
    if (set_) {
      const auto& events = set_->events;
      if (!set_->fn) throw std::invalid_argument("events: no compiled function");
      for (std::size_t e = 0; e < events.size(); ++e) {
        if (events[e].direction < -1 || events[e].direction > 1)
          throw std::invalid_argument("events[" + std::to_string(e) + "].direction must be -1, 0 or +1");
        terminal_ = terminal_ || events[e].terminal;
      }
      for (const EventSlot& s : set_->slots)
        if (s.kind != Kind::t && (s.index < 0 || s.index >= n_))
          throw std::invalid_argument("events: g reads coordinate " + std::to_string(s.index) +
                                      ", not one of the model's 0.." + std::to_string(n_ - 1));
      for (const EventFunction& f : events)
        for (const EventFunction::Term& term : f.terms)
          if (term.kind != Kind::t && (term.index < 0 || term.index >= n_))
            throw std::invalid_argument("events: g reads coordinate " + std::to_string(term.index) +
                                        ", not one of the model's 0.." + std::to_string(n_ - 1));
      affine_ = set_->all_affine();
      if (affine_) group(events);
      for (const EventFunction& f : events)
        if (f.henon) {
          if (f.terminal)
            throw std::invalid_argument("events: Hénon's step refines a section's points, not a terminal event");
          henon_.resize(n_);
        }
      forces_ = forces_ || set_->reads_momenta();
      gated_ = screens(spec);
      keeps_ = gated_;
      batchable_ = gated_ && spec.batch_screens && !spec.envelope && spec.temperature == 0.0;
      budgeted_ = gated_ && groups_.size() > 1;
      for (const Input& in : inputs_) {
        budgeted_ = budgeted_ && in.which == 0;
        if (in.which == 0 && std::find(read_q_.begin(), read_q_.end(), in.index) == read_q_.end())
          read_q_.push_back(in.index);
      }
      h_max_ = std::max(std::abs(h_), std::abs(h_last_));
      read_all_ = static_cast<int>(read_q_.size()) == n_;
      in_.assign(set_->slots.size(), 0.0);
      out_.assign(2 * events.size(), 0.0);
      g0_.assign(events.size(), 0.0);
      g1_ = dg0_ = dg1_ = g0_;
      found_.reserve(3 * events.size());
      log_.t.reserve(256);  // (a log that grows reallocates rarely: 256 crossings, then doubling)
      log_.event.reserve(256), log_.direction.reserve(256);
      log_.q.reserve(256 * static_cast<std::size_t>(n_)), log_.p.reserve(256 * static_cast<std::size_t>(n_));
    }
    if (dense_) {
      const std::size_t rows = static_cast<std::size_t>(spec.n_steps) + 1;  // reserved now: no allocation per step
      dense_->n = n_;
      dense_->t.reserve(rows);
      for (auto* v : {&dense_->q, &dense_->p, &dense_->v, &dense_->f}) v->reserve(rows * n_);
    }
    if (finite(z)) start(z, t);  // else the loop stops before its first step
  }

  bool on() const { return on_; }
  bool stopped() const { return stopped_; }
  double stop_time() const { return t_stop_; }
  const std::string& stop_name() const { return set_->events[stop_event_].name; }

  // Screened runs (gated_: affine events of q and t only, no dense output) rule a quiet step out inline, in
  // the loop (screen), and observe only the others, out of line (observe_from), from their end and the state
  // the loop kept before stepping (keep). Observing every step's end out of line cost the damped pendulum's
  // whole step 1.65x, screened 1.3x (benchmarks/bench_event_watcher.cpp).
  template <int Dim, class Rec>
  void keep(const State<Dim>& x, const Rec& rec) {
    if (!keeps_) return;
    put<Dim>(kept_q_, x.q);  // no allocation: the sizes are the model's
    put<Dim>(kept_p_, x.p);
    if (terminal_) marks_ = rec.marks();  // what a terminal event's restep starts from
  }

  // After whole step i of model, ending at t, of a state that rec (the recorder) observed.
  template <class Model, int Dim, class Rec>
  void after_step(const Model& model, const State<Dim>& x, long i, double t, const Rec& rec) {
    const Rows rows = rows_mode_;  // (one load and compare a step where rows are kept, not three)
    if constexpr (Dim != Eigen::Dynamic) {
      if (rows == Rows::ends) return write_row<false>(x, rec);
      if (rows == Rows::ends_and_marks) return write_row<true>(x, rec);
    }
    if (!on_) return;
    if (gated_) {
      if (!screen(model, x, t)) observe_from(model, x, i, t);
      return;
    }
    if (terminal_ && i > step_) marks_ = rec.marks();  // what a terminal event's restep starts from
    observe(model, x, i, t);
  }

  // Batched screens. A screened run on a model of fixed size (fixed_size: without springs, whose states
  // the block's steps move on) screens its steps a block at a time: each step's end (and, with a terminal
  // event, the recorder's marks there) is stored as the block runs (write_row: a few stores a step, no
  // keep), and end_block() screens the stored ends in order with screen()'s test, observing the steps that
  // are not quiet from their two rows as the loop would have; a step whose only news is a rate that turned
  // well inside its gap is ruled out there too (turns_inside). The events are the same, bit for bit, as
  // screening each step in the loop (RunSpec::batch_screens = false; test_events.cpp). Inline, that screen
  // cost the damped pendulum's 11.6 ns step 3-4 ns; batched, 1.2 (benchmarks/bench_event_watcher.cpp).
  // Call once, before the first block; block: its most steps. (No envelope, no noise: both would have to
  // be taken back past a terminal event found after the block ran on.)
  void batch_screens(bool fixed_size, long block) {
    batched_ = batchable_ && fixed_size;
    keeps_ = gated_ && !batched_;
    if (!batched_) return;
    rows_mode_ = terminal_ ? Rows::ends_and_marks : Rows::ends;
    // + 4: the last four ends first_loud4() reads (past the block's: found after its own, never returned)
    const std::size_t rows = static_cast<std::size_t>(block + 1 + 4), n = static_cast<std::size_t>(n_);
    rows_.assign(2 * rows * n, 0.0);
    rows_v_.assign(rows * n, 0.0);
    rows_t_.assign(rows, 0.0);
    count_.resize(rows);
    for (std::size_t j = 0; j < rows; ++j) count_[j] = static_cast<double>(j);
    if (terminal_) row_marks_.assign(rows, RecorderMarks{});
    spans_.reserve(groups_.size());
    for (const Input& in : inputs_) reads_time_ = reads_time_ || in.which == 2;
  }

  // Before a block that starts at step k from z (the recorder rec at that point).
  template <int Dim, class Rec>
  void begin_block(const State<Dim>& z, long k, const Rec& rec) {
    if constexpr (Dim != Eigen::Dynamic) {
      if (!batched_) return;
      first_ = k;
      cursor_ = rows_.data();
      if (terminal_) write_row<true>(z, rec);
      else write_row<false>(z, rec);
    }
  }

  // After the block: its stored ends screened and observed (out of line), up to a terminal event.
  template <int Dim, class Model>
  void end_block(const Model& model) {
    if constexpr (Dim != Eigen::Dynamic) {
      if (batched_) screen_rows<Dim>(model);
    }
  }

  // After a terminal event: z becomes the state at the crossing time, stepped by restep(z, i, dt) from
  // the start of the crossing step (dt = the crossing time minus that start; the recorder's sums back
  // where they were); the dense record's last row is that state. Returns the steps taken.
  template <int Dim, class Rec, class Restep>
  long finish(State<Dim>& z, Rec& rec, const Restep& restep) {
    if (t_stop_ == t1_) {  // on the step's end: the stepped state itself
      z.q = q1();
      z.p = p1();
      if (batched_) rec.restore(marks1_);  // the block went on past it
      return step_ + 1;
    }
    z.q = q0();
    z.p = p0();
    rec.restore(marks0_);
    restep(z, step_, t_stop_ - t0_);
    if (dense_) {
      resize_dense(dense_->rows() - 1);
      read_end(view_of(z), t_stop_);
      push_dense();
    }
    return step_ + 1;
  }

 private:
  bool finite(StateView x) const {
    return Eigen::Map<const Vec>(x.q, n_).allFinite() && Eigen::Map<const Vec>(x.p, n_).allFinite();
  }

  void start(StateView z, double t) {
    if (!on_) return;
    read_end(z, t);
    if (set_)
      for (std::size_t e = 0; e < g1_.size(); ++e)
        if (!std::isfinite(g1_[e]))
          throw std::invalid_argument("events[" + std::to_string(e) + "].g ('" + set_->events[e].name +
                                      "') is not finite at the initial state");
    if (affine_) {
      quiet({q1().data(), p1().data(), v1().data(), f1().data()}, t);
      settle();
    }
    if (gated_) kept_q_ = q1(), kept_p_ = p1();
    if (budgeted_) speed_ = v1().cwiseAbs(), rearm();
    push_dense();
  }

  // The one part made per model type: the step's end read with the model's own functions, inlined
  // (v and, where needed, f: a call through the ModelView here would cost the events floor a tenth
  // of a pendulum's step), then g and the sign scan; the crossing search (locate), the log and
  // Hénon's landing are this class's, out of line, the same for every model.
  template <class Model, int Dim>
  RAYDAMP_NOINLINE_FLAT void observe(const Model& model, const State<Dim>& x, long i, double t) {
    // A state that is not finite ends the run (dense output ends at the last finite one); a block replayed
    // to find that step (integrate.hpp) runs steps already observed again, which add nothing.
    if (i <= step_ || !finite_end(x)) return;
    shift(i);
    t1_ = t;
    put<Dim>(q1(), x.q);
    put<Dim>(p1(), x.p);
    using MVec = typename Model::Vec;
    if constexpr (std::is_same_v<MVec, Vec>) {
      model.mass.velocity(x.p, v1());
      if (forces_) {
        model.gradient(x.q, grad_);
        model.damping.rate(x.q, x.p, rate_);
        f1() = -(grad_ + rate_);
        if (load_ && !load_->empty()) load_->add(t, 1.0, f1().data());
      }
      after_read(t, {q1().data(), p1().data(), v1().data(), f1().data()});
    } else {
      // g is read from these locals (the model's fixed size, in registers), not back from the
      // run-time-size vectors just written.
      MVec v = MVec::Zero(x.p.size()), f = MVec::Zero(x.p.size());
      model.mass.velocity(x.p, v);
      put<Dim>(v1(), v);
      if (forces_) {
        MVec grad = MVec::Zero(x.q.size()), rate = MVec::Zero(x.q.size());
        model.gradient(x.q, grad);
        model.damping.rate(x.q, x.p, rate);
        f = -(grad + rate);
        if (load_ && !load_->empty()) load_->add(t, 1.0, f.data());
        put<Dim>(f1(), f);
      }
      after_read(t, {x.q.data(), x.p.data(), v.data(), f.data()});
    }
  }

  // Whether every group stays quiet at x's end (quiet(), without storing anything): inlined in the loop.
  // A state that is not finite is never quiet (its comparisons are false).
  template <class Model, int Dim>
  bool screen(const Model& model, const State<Dim>& x, double t) {
    using MVec = typename Model::Vec;
    if constexpr (std::is_same_v<MVec, Vec>) {
      model.mass.velocity(x.p, v1());  // v1 is rewritten by a step observed out of line anyway
      if (budgeted_) {
        // |v| at the step's start is the last end's, kept (speed_): a product a step fewer, 12 ns of the
        // frame's 140. (The first step after a replay starts elsewhere: its budget is spent whatever it reads.)
        if (read_all_) {  // every q: in vectors, without the indices
          const double most =
              (1.25 * (x.q - kept_q_).array().abs() + (0.25 * h_max_) * speed_.array().max(v1().array().abs()))
                  .maxCoeff();
          speed_ = v1().cwiseAbs();
          if (spend(most)) return true;
        } else if (within_budget(x.q.data(), v1().data())) {
          return true;
        }
        model.mass.velocity(kept_p_, v0());  // v1 and v0 are rewritten by a step observed out of line anyway
        return overrun({x.q.data(), x.p.data(), v1().data(), nullptr}, v0().data());
      }
      return screen_groups({x.q.data(), x.p.data(), v1().data(), nullptr}, t);
    } else {
      // on copies: the address of x itself, taken, would keep the loop's state out of registers
      // (A model of fixed size has a few q: its groups are summed, without the budget's branch.)
      MVec q = x.q, v = MVec::Zero(x.p.size());
      model.mass.velocity(x.p, v);
      return screen_groups({q.data(), nullptr, v.data(), nullptr}, t);
    }
  }

  // The block's next row: x's q and p (and the recorder's marks where a terminal event may restep).
  template <bool Marks, int Dim, class Rec>
  void write_row(const State<Dim>& x, const Rec& rec) {
    using Row = Eigen::Map<Eigen::Matrix<double, Dim, 1>>;
    double* row = cursor_;  // (a pointer kept, not an index: the damped pendulum's step 0.6 ns less)
    Row{row} = x.q;
    Row{row + Dim} = x.p;
    cursor_ = row + 2 * Dim;
    if constexpr (Marks) row_marks_[static_cast<std::size_t>((row - rows_.data()) / (2 * Dim))] = rec.marks();
  }

  // Rows 1 .. m - 1 of the block's m (row 0: its start), each the end of step first_ + row - 1, screened in
  // order, four at a time (block_sums::first_loud: screen_groups()'s sums and inside()'s test on the same bits);
  // an end that is not quiet is observed from the row before it (its start) and its own, as observe_from()
  // would have from keep() and after_step(), and the ends after it screened against the gaps it left.
  template <int Dim, class Model>
  RAYDAMP_NOINLINE_FLAT void screen_rows(const Model& model) {
    using Row = Eigen::Map<const Eigen::Matrix<double, Dim, 1>>;
    using MVec = typename Model::Vec;
    const long m = (cursor_ - rows_.data()) / (2 * Dim);  // rows written
    constexpr bool unit = std::is_same_v<std::decay_t<decltype(model.mass)>, UnitMass>;  // v = p, in the rows
    if constexpr (!unit) {
      // v = M^-1 p by the model's own (inlined) mass, as screen() takes it; from row 0, the block's start,
      // which turns_inside() reads as the first step's start
      for (long j = 0; j < m; ++j) {
        MVec vj = MVec::Zero(Dim);
        model.mass.velocity(Row(rows_.data() + 2 * Dim * j + Dim), vj);
        Eigen::Map<Eigen::Matrix<double, Dim, 1>>{rows_v_.data() + Dim * j} = vj;
      }
    }
    if (reads_time_) {  // the loop's clock, step_time(first_ + j): (first_ + j) h, exact in either form
      const double first = static_cast<double>(first_);  // (vectorised over count_; step_time() a row, with its
      for (long j = 0; j < m; ++j) rows_t_[j] = (first + count_[j]) * h_;  // branch, cost the floor 0.4 ns a step)
      if (first_ + m - 1 == steps_) rows_t_[m - 1] = step_time(steps_, h_, steps_, h_last_);
    }
    const block_sums::Rows rows{rows_.data(), unit ? rows_.data() + Dim : rows_v_.data(), rows_t_.data()};
    constexpr int v_stride = unit ? 2 * Dim : Dim;
    for (long j = 1; j < m;) {
      spans_.clear();  // (reserved: no allocation) the groups' gaps as the last end observed left them
      for (const Group& g : groups_)
        spans_.push_back({inputs_.data() + g.first, inputs_.data() + g.last, g.lo, g.hi, g.lo_slack, g.hi_slack,
                          g.slack, std::signbit(g.R)});
      const long r = block_sums::first_loud<2 * Dim, v_stride>(spans_.data(), spans_.size(), rows, j, m);
      if (r == m) return;
      if (turns_inside<Dim, v_stride>(rows, r)) {
        j = r + 1;
        continue;
      }
      const double* q = rows_.data() + 2 * Dim * r;
      const State<Dim> x{Row(q), Row(q + Dim)};
      kept_q_ = Row(q - 2 * Dim);
      kept_p_ = Row(q - Dim);
      if (terminal_) marks_ = row_marks_[static_cast<std::size_t>(r - 1)];
      observe_from(model, x, first_ + r - 1, step_time(first_ + r, h_, steps_, h_last_));
      if (stopped_) {
        if (terminal_) marks1_ = row_marks_[static_cast<std::size_t>(r)];
        return;
      }
      j = r + 1;
    }
  }

  // Whether end r's only news is a rate that turned: every group's L inside its gap at both of step r's
  // ends, and where its rate R changed sign, its interpolant (the cubic Hermite of L and h R, within
  // max(|a|, |b|) / 4 of the chord: keeps_sign()) clear inside the gap too, by the rounding bound and a
  // margin for the Hermite's own roundings. Observing the step would then find no crossing and no touch;
  // the groups take the sums of its end as quiet() would (their gaps stay, as settle() would find), and
  // the step is not observed. A damped pendulum turns twice a swing: each turn observed cost as much as a
  // crossing (locate()'s scan of every event, settle()'s of every level).
  template <int Dim, int VS>
  bool turns_inside(block_sums::Rows rows, long r) {
    const double t0 = step_time(first_ + r - 1, h_, steps_, h_last_), t1 = step_time(first_ + r, h_, steps_, h_last_);
    const double h = t1 - t0;
    // row j as an end: its q and v (the groups read no p, no force)
    auto row = [&](long j) { return End{rows.q + j * 2 * Dim, nullptr, rows.v + j * VS, nullptr}; };
    for (const Group& g : groups_) {
      const Sums end = sums(g, row(r), t1);  // the bits screen_groups() takes
      if (!inside(g, end.L, end.S)) return false;
      if (!((bits(g.R) ^ bits(end.R)) >> 63)) continue;
      const Sums start = sums(g, row(r - 1), t0);
      const double *v0 = row(r - 1).v, *v1 = row(r).v;
      double rates = 0.0;  // sum of |c dx/dt| at both ends
      for (std::size_t k = g.first; k < g.last; ++k) {
        const Input& in = inputs_[k];
        rates += std::abs(in.coefficient) * (in.which == 0 ? std::abs(v0[in.index]) + std::abs(v1[in.index]) : 2.0);
      }
      const double chord = end.L - start.L;
      const double a = std::abs(h * start.R - chord), b = std::abs(h * end.R - chord);
      const double S = std::max(start.S, end.S);
      // the interpolant's roundings, term by term (its values and h times its rates at both ends)
      // (8 slack: 64 (terms + 2) roundings, as many as the interpolant's sum has terms)
      const double guard = 8.0 * g.slack * (start.S + end.S + std::abs(h) * rates);
      const double reach = 0.25 * std::max(a, b) * (1.0 + 64.0 * DBL_EPSILON) + guard;
      if (!(reach < DBL_MAX) || !inside(g, std::min(start.L, end.L) - reach, S) ||
          !inside(g, std::max(start.L, end.L) + reach, S))
        return false;
    }
    for (Group& g : groups_) {
      const Sums end = sums(g, row(r), t1);
      g.L = end.L, g.S = end.S, g.R_was = g.R, g.R = end.R;
    }
    return true;
  }

  // Several groups (storey drifts, say) cost a sum each a step. Instead, the movement of every q they read
  // is bounded: on a step, q_j's cubic Hermite interpolant (which events are located on) differs from
  // q_j at the start by at most |dq| + max(|a|, |b|) / 4 <= 1.25 |dq| + 0.25 h max(|v0|, |v1|) (dq over the
  // step; a, b as at keeps_sign()); summed over the steps since every group's L was last taken, moved_
  // bounds how far any q has gone, and C moved_ how far a group's L. While that stays within the room its L
  // had to the nearest of its levels (less the rounding bound, rearm()), no g can reach zero on any step's
  // interpolant: the step is quiet whatever the rates do.
  bool within_budget(const double* q, const double* v1) {
    double most = 0.0;
    for (const int j : read_q_) {
      const double dq = std::abs(q[j] - kept_q_[j]), speed = std::abs(v1[j]);
      most = std::max(most, 1.25 * dq + 0.25 * h_max_ * std::max(speed_[j], speed));
      speed_[j] = speed;
    }
    return spend(most);
  }
  bool spend(double most) {
    moved_ += most * (1.0 + 64.0 * DBL_EPSILON);  // (a NaN never fits: the groups are then taken)
    return moved_ <= budget_;
  }

  // A step the budget does not cover: quiet where every group's L lies inside its gap at the step's end and
  // its rate has one sign at both of the step's ends, as screen_groups() decides, but with the rate at the
  // start taken from the kept state (v0), not the sign kept in the group: steps the budget passed did not
  // update that, and a rate may have turned since (a level crossed twice inside this step, its ends on one
  // side, looked quiet against the kept sign: test_events_screened.py). Then the budget is rearmed there.
  RAYDAMP_NOINLINE bool overrun(End end, const double* v0) {
    for (const Group& g : groups_) {  // (budgeted groups read q only: no t, p or f)
      const Sums at_end = sums(g, end, 0.0);
      const double R0 = sums(g, {end.q, end.p, v0, nullptr}, 0.0).R;
      if (!inside(g, at_end.L, at_end.S) || ((bits(R0) ^ bits(at_end.R)) >> 63)) return false;
    }
    rearm(end);
    return true;
  }

  // Each group's room at end (its gap settled there): how far its L can move and keep every member's g
  // clear of zero by the rounding bound (inside()); the budget is the least room over C (none where a group
  // has no gap: L within the rounding bound of a level).
  RAYDAMP_NOINLINE void rearm(End end) {
    double budget = DBL_MAX;
    for (const Group& g : groups_) {
      const Sums at = sums(g, end, 0.0);  // (budgeted groups read q only)
      const double L = at.L, S = at.S;
      // L' - lo > lo_slack + slack S' for |L' - L| <= m and S' <= S + m: m (1 + slack) < L - lo - lo_slack - slack S
      const double room = std::min(L - g.lo - g.lo_slack - g.slack * S, g.hi - g.hi_slack - g.slack * S - L);
      if (g.C > 0.0) budget = std::min(budget, room / ((1.0 + g.slack) * g.C));
    }
    budget_ = budget * (1.0 - 64.0 * DBL_EPSILON);
    moved_ = 0.0;
  }
  void rearm() { rearm({q1().data(), p1().data(), v1().data(), f1().data()}); }

 public:
  // Before steps replayed from a checkpoint: the budget's movement counts from a later state; a batched
  // run's replay writes its rows again from the block's start, and they are not screened again: the block
  // screened them when it ended, and with events steps run whole, so the replay steps the same states.
  void restart_screen() {
    budget_ = -1.0;
    if (batched_) cursor_ = rows_.data() + 2 * n_;
  }

 private:

  // quiet()'s test without storing, inlined in the step loop: the sums of sums() for groups that read no p,
  // without its switch.
  bool screen_groups(End end, double t) const {
    bool all = true;
    for (const Group& g : groups_) {
      double L = 0.0, S = 0.0, R = 0.0;
      for (std::size_t k = g.first; k < g.last; ++k) {
        const Input& in = inputs_[k];
        const double c = in.coefficient;
        const double term = in.which == 0 ? c * end.q[in.index] : c * t;  // screened groups read no p
        R += in.which == 0 ? c * end.v[in.index] : c;
        L += term;
        S += std::abs(term);
      }
      all = all && inside(g, L, S) && !((bits(g.R) ^ bits(R)) >> 63);
    }
    return all;
  }

  // A screened step that was not quiet: both its ends read (the start from what the loop kept), then the
  // scan of quiet()'s groups, rescan() and settle() as observe() would.
  template <class Model, int Dim>
  RAYDAMP_NOINLINE_FLAT void observe_from(const Model& model, const State<Dim>& x, long i, double t) {
    if (i <= step_ || !finite_end(x)) return;
    step_ = i;
    t0_ = step_time(i, h_, steps_, h_last_);  // as the loop's clock reads it
    t1_ = t;
    q0() = kept_q_;
    p0() = kept_p_;
    marks0_ = marks_;
    put<Dim>(q1(), x.q);
    put<Dim>(p1(), x.p);
    // v by the same inlined code as screen(), so that the rate kept for it has the bits it computes
    using MVec = typename Model::Vec;
    if constexpr (std::is_same_v<MVec, Vec>) {
      model.mass.velocity(p0(), v0());
      model.mass.velocity(x.p, v1());
    } else {
      MVec v = MVec::Zero(x.p.size());
      model.mass.velocity(MVec(kept_p_), v);
      put<Dim>(v0(), v);
      model.mass.velocity(x.p, v);
      put<Dim>(v1(), v);
    }
    quiet({q1().data(), p1().data(), v1().data(), f1().data()}, t);
    rescan();
    if (budgeted_) rearm();
  }

  // Whether a run's events are screened (gated_).
  static bool screens(const RunSpec& spec) {
    return spec.events && spec.events->all_affine() && !spec.events->reads_momenta() && !spec.dense;
  }

  // Whether every q and p of x is finite: x * 0 is 0 for a finite x and NaN for an infinite or NaN one,
  // and their sum is 0 only when all are; without a branch per value (a 10-storey frame's scan of its 20
  // values one by one cost a tenth of its 3s step).
  template <int Dim>
  static bool finite_end(const State<Dim>& x) {
    return (x.q.array() * 0.0).sum() + (x.p.array() * 0.0).sum() == 0.0;
  }

  // from into to (of size n): for a fixed n, a copy of that size, without a run-time size's checks.
  template <int Dim, class E>
  static void put(Vec& to, const E& from) {
    if constexpr (Dim == Eigen::Dynamic) to = from;
    else Eigen::Map<Eigen::Matrix<double, Dim, 1>>(to.data()) = from;
  }

  // The step's start (0) and end (1).
  Vec& q0() { return q_[end_ ^ 1]; }
  Vec& p0() { return p_[end_ ^ 1]; }
  Vec& v0() { return v_[end_ ^ 1]; }
  Vec& f0() { return f_[end_ ^ 1]; }
  Vec& q1() { return q_[end_]; }
  Vec& p1() { return p_[end_]; }
  Vec& v1() { return v_[end_]; }
  Vec& f1() { return f_[end_]; }

  // The step's ends move back: the end just read becomes the start.
  void shift(long i) {
    end_ ^= 1;
    if (!affine_) {  // affine events' g are computed at both ends only where quiet() cannot rule a crossing out
      std::swap(g0_, g1_);
      std::swap(dg0_, dg1_);
    }
    t0_ = t1_;
    if (terminal_) {
      marks0_ = marks1_;
      marks1_ = marks_;
    }
    step_ = i;
  }

  // After the end (q1, p1, v1, f1 at t) is read: g and dg/dt there, the dense row, the crossings
  // (inlined in observe: one call per step fewer).
  void after_read(double t, End end) {
    if (set_ && !affine_) evaluate_compiled(t, end, g1_, dg1_);
    push_dense();
    if (!set_) return;
    if (!affine_) detect();
    else if (!quiet(end, t)) rescan();  // affine: every g read only where a crossing may be
  }

  // q1, p1, v1 (and f1 where needed) from x at t, and g, dg/dt there.
  void read_end(StateView x, double t) {
    t1_ = t;
    q1() = Eigen::Map<const Vec>(x.q, n_);
    p1() = Eigen::Map<const Vec>(x.p, n_);
    model_.velocity(model_.model, p1(), v1());
    if (forces_) force(q1(), p1(), t, f1());
    if (set_) evaluate(t, {q1().data(), p1().data(), v1().data(), f1().data()});
  }

  // g and dg/dt at the end just read (end: its values), into g1_ and dg1_ (by default).
  void evaluate(double t, End end) { evaluate(t, end, g1_, dg1_); }

  void evaluate(double t, End end, std::vector<double>& g_out, std::vector<double>& dg_out) {
    if (affine_) evaluate_affine(t, end, g_out, dg_out);
    else evaluate_compiled(t, end, g_out, dg_out);
  }

  // Affine events: no compiled call, g and dg/dt from their coefficients (out of line: a step reads them
  // only where quiet() cannot rule a crossing out).
  RAYDAMP_NOINLINE void evaluate_affine(double t, End end, std::vector<double>& g_out, std::vector<double>& dg_out) {
    const std::vector<EventFunction>& events = set_->events;
    for (std::size_t e = 0; e < events.size(); ++e) {
      double g = events[e].constant, rate = 0.0;
      for (const EventFunction::Term& term : events[e].terms) {
        switch (term.kind) {
          case Kind::q: g += term.coefficient * end.q[term.index], rate += term.coefficient * end.v[term.index]; break;
          case Kind::p: g += term.coefficient * end.p[term.index], rate += term.coefficient * end.f[term.index]; break;
          default: g += term.coefficient * t, rate += term.coefficient; break;
        }
      }
      g_out[e] = g;
      dg_out[e] = rate;
    }
  }

  // Through the events' compiled function: one call for every g and dg/dt.
  void evaluate_compiled(double t, End end, std::vector<double>& g_out, std::vector<double>& dg_out) {
    const std::vector<EventSlot>& slots = set_->slots;
    for (std::size_t k = 0; k < slots.size(); ++k) in_[k] = end_value(slots[k], t, end);
    set_->fn(out_.data(), in_.data());
    for (std::size_t e = 0; e < g_out.size(); ++e) {
      g_out[e] = out_[2 * e];
      dg_out[e] = out_[2 * e + 1];
    }
  }

  // Affine events grouped by form (the same terms, coefficients and order; they differ by constant
  // only): the group's L = sum of coefficient * input at a step end is every member's g less its
  // constant, and the group's R = sum of coefficient * rate is, bit for bit, each member's dg/dt as
  // evaluate() computes it (the same sums from 0 in the same order). The members' levels -constant,
  // sorted and distinct, cut the line into gaps; gap k lies between level k - 1 and level k.
  struct Input {
    int which;  // 0: q, 1: p, 2: t
    int index;
    double coefficient;
  };
  struct Group {
    std::size_t first, last;    // its inputs: inputs_[first, last)
    std::size_t level, levels;  // its levels: levels_[level, level + levels), between -DBL_MAX and DBL_MAX
    double slack;               // the rounding bound's factor, by the number of terms
    long gap = -1;              // the gap its L lay clear inside at the last step end, or -1
    double lo = 0.0, hi = 0.0, lo_slack = 0.0, hi_slack = 0.0;  // that gap's levels, slack * |level|
    double L = 0.0, S = 0.0, R = 0.0, R_was = 0.0;  // at the end just read (S: sum of |terms|); R at the one before
    double C = 0.0;                                 // sum of |coefficient| (budgeted groups read q only)
  };

  void group(const std::vector<EventFunction>& events) {
    std::vector<std::vector<double>> levels;
    for (const EventFunction& f : events) {
      std::size_t g = 0;
      for (; g < groups_.size(); ++g) {
        const Group& gr = groups_[g];
        bool same = gr.last - gr.first == f.terms.size();
        for (std::size_t k = 0; same && k < f.terms.size(); ++k) {
          const Input& in = inputs_[gr.first + k];
          same = in.which == which(f.terms[k].kind) && in.index == f.terms[k].index &&
                 bits(in.coefficient) == bits(f.terms[k].coefficient);
        }
        if (same) break;
      }
      if (g == groups_.size()) {
        Group gr;
        gr.first = inputs_.size();
        for (const EventFunction::Term& term : f.terms)
          inputs_.push_back({which(term.kind), term.kind == Kind::t ? 0 : term.index, term.coefficient});
        gr.last = inputs_.size();
        for (const EventFunction::Term& term : f.terms) gr.C += std::abs(term.coefficient);
        // g = constant + L is computed as ((constant + c_1 x_1) + c_2 x_2) + ..., L as (c_1 x_1 + c_2 x_2) + ...:
        // each within (terms + 1) roundings of the exact sum, relative to |constant| + S; 8x that
        // bounds their difference with room to spare.
        gr.slack = 8.0 * static_cast<double>(f.terms.size() + 2) * DBL_EPSILON;
        groups_.push_back(gr);
        levels.emplace_back();
      }
      levels[g].push_back(-f.constant);
    }
    for (std::size_t g = 0; g < groups_.size(); ++g) {
      std::vector<double>& l = levels[g];
      std::sort(l.begin(), l.end());
      l.erase(std::unique(l.begin(), l.end()), l.end());
      groups_[g].level = levels_.size();
      groups_[g].levels = l.size() + 2;
      levels_.push_back(-DBL_MAX);
      levels_.insert(levels_.end(), l.begin(), l.end());
      levels_.push_back(DBL_MAX);
    }
  }

  static int which(Kind kind) { return kind == Kind::q ? 0 : kind == Kind::p ? 1 : 2; }

  // Whether L lies inside gap k of group g, clear of both its levels by more than the rounding bound (so
  // every member's g, as evaluate() computes it, has the sign the gap gives it, and none is zero).
  bool clear(const Group& g, long k) const {
    const double lo = levels_[g.level + k], hi = levels_[g.level + k + 1];
    return g.L - lo > g.slack * (std::abs(lo) + g.S) && hi - g.L > g.slack * (std::abs(hi) + g.S);
  }

  // The same for the gap settle() found, from its levels kept in g.
  static bool inside(const Group& g, double L, double S) {
    const double margin = g.slack * S;
    return L - g.lo > g.lo_slack + margin && g.hi - L > g.hi_slack + margin;
  }

  // Every group's L, S and R at the end just read; true where no affine g can have changed sign or
  // touched zero over the step, nor its rate changed sign: then detect() would find nothing.
  // Group g's L, S and R at end (t: its time).
  struct Sums {
    double L, S, R;
  };
  Sums sums(const Group& g, End end, double t) const {
    double L = 0.0, S = 0.0, R = 0.0;
    for (std::size_t k = g.first; k < g.last; ++k) {
      const Input& in = inputs_[k];
      const double c = in.coefficient;
      double term;
      switch (in.which) {
        case 0: term = c * end.q[in.index], R += c * end.v[in.index]; break;
        case 1: term = c * end.p[in.index], R += c * end.f[in.index]; break;
        default: term = c * t, R += c; break;
      }
      L += term;
      S += std::abs(term);
    }
    return {L, S, R};
  }

  bool quiet(End end, double t) {
    bool all = true;
    for (Group& g : groups_) {
      const auto [L, S, R] = sums(g, end, t);
      g.L = L, g.S = S, g.R_was = g.R, g.R = R;
      // (A gap of -1 has lo = hi = 0, which nothing lies clear inside.)
      all = all && inside(g, L, S) && !((bits(g.R_was) ^ bits(R)) >> 63);
    }
    return all;
  }

  // Each group's gap at the end just read (-1 where L is near a level, or not finite).
  void settle() {
    for (Group& g : groups_) {
      g.gap = -1;
      g.lo = g.hi = g.lo_slack = g.hi_slack = 0.0;
      for (std::size_t k = 0; k + 1 < g.levels; ++k)
        if (clear(g, static_cast<long>(k))) {
          g.gap = static_cast<long>(k);
          g.lo = levels_[g.level + k], g.hi = levels_[g.level + k + 1];
          g.lo_slack = g.slack * std::abs(g.lo), g.hi_slack = g.slack * std::abs(g.hi);
          break;
        }
    }
  }

  // A step quiet() could not rule out: every affine g and dg/dt at both ends, the scan and the search.
  RAYDAMP_NOINLINE void rescan() {
    evaluate(t0_, {q0().data(), p0().data(), v0().data(), f0().data()}, g0_, dg0_);
    evaluate(t1_, {q1().data(), p1().data(), v1().data(), f1().data()}, g1_, dg1_);
    detect();
    settle();
  }

  static double end_value(const EventSlot& s, double t, End end) {
    switch (s.kind) {
      case Kind::t: return t;
      case Kind::q: return end.q[s.index];
      case Kind::p: return end.p[s.index];
      case Kind::v: return end.v[s.index];
      case Kind::f: return end.f[s.index];
    }
    return 0.0;
  }

  // pdot at (q, p, t): -grad V(q) - eps D(q) M^{-1} p + f(t).
  void force(const Vec& q, const Vec& p, double t, Vec& out) {
    model_.force(model_.model, q, p, grad_, rate_, out);
    if (load_ && !load_->empty()) load_->add(t, 1.0, out.data());
  }

  // g (which = 0) or dg/dt (which = 1) of event e on the step's interpolant at s in [0, 1].
  double on_step(std::size_t e, double s, int which) {
    const std::vector<EventSlot>& slots = set_->slots;
    const double h = t1_ - t0_;
    const hermite::Weights w = hermite::value(s), d = hermite::slope(s);
    if (affine_) {
      const EventFunction& f = set_->events[e];
      double g = which == 0 ? f.constant : 0.0;
      for (const EventFunction::Term& term : f.terms) {
        const int j = term.index;
        double x;
        switch (term.kind) {
          case Kind::q:
            x = which == 0 ? hermite::at(w, q0()[j], v0()[j], q1()[j], v1()[j], h)
                           : hermite::rate_at(d, q0()[j], v0()[j], q1()[j], v1()[j], h);
            break;
          case Kind::p:
            x = which == 0 ? hermite::at(w, p0()[j], f0()[j], p1()[j], f1()[j], h)
                           : hermite::rate_at(d, p0()[j], f0()[j], p1()[j], f1()[j], h);
            break;
          default: x = which == 0 ? (s == 1.0 ? t1_ : t0_ + s * h) : 1.0; break;
        }
        g += term.coefficient * x;
      }
      return g;
    }
    for (std::size_t k = 0; k < slots.size(); ++k) {
      const int j = slots[k].index;
      switch (slots[k].kind) {
        case Kind::t: in_[k] = s == 1.0 ? t1_ : t0_ + s * h; break;
        case Kind::q: in_[k] = hermite::at(w, q0()[j], v0()[j], q1()[j], v1()[j], h); break;
        case Kind::p: in_[k] = hermite::at(w, p0()[j], f0()[j], p1()[j], f1()[j], h); break;
        case Kind::v: in_[k] = hermite::rate_at(d, q0()[j], v0()[j], q1()[j], v1()[j], h); break;
        case Kind::f: in_[k] = hermite::rate_at(d, p0()[j], f0()[j], p1()[j], f1()[j], h); break;
      }
    }
    set_->fn(out_.data(), in_.data());
    return out_[2 * e + which];
  }

  // A root of on_step(e, ., which) in (a, b], where its values fa, fb have opposite signs (or fb = 0):
  // false position with the Illinois halving, a bisection every fourth step, until the bracket spans a
  // few roundings of t; the end with the smaller value.
  double root(std::size_t e, double a, double b, double fa, double fb, int which) {
    if (fb == 0.0) return b;
    const double h = t1_ - t0_;
    const double tol = 4.0 * DBL_EPSILON * std::max(std::abs(t1_), h) / h;
    int side = 0;
    for (int it = 0; it < 400 && b - a > tol; ++it) {
      double m = (it % 4 == 3) ? 0.5 * (a + b) : (a * fb - b * fa) / (fb - fa);
      if (!(m > a && m < b)) m = 0.5 * (a + b);
      if (!(m > a && m < b)) break;
      const double fm = on_step(e, m, which);
      if (fm == 0.0) return m;
      if (!std::isfinite(fm)) break;
      if ((fm < 0.0) == (fa < 0.0)) {
        a = m, fa = fm;
        if (side == -1) fb *= 0.5;
        side = -1;
      } else {
        b = m, fb = fm;
        if (side == 1) fa *= 0.5;
        side = 1;
      }
    }
    return std::abs(fa) < std::abs(fb) ? a : b;
  }

  struct Found {
    double s;
    std::size_t e;
    int direction;
    int from;  // the step's end (0: start, 1: end) between which and the crossing g is monotone
  };

  // The crossings of step [t0, t1], in time order, into the log; a terminal one stops the run there.
  void detect() {
    // The common step, scanned without a branch per event: every g and its rate keep their signs and
    // no g is zero. (A NaN may pass either way: locate() skips it.)
    // On the values' bits: a sign that differs is the top bit of their xor, a zero (either sign) is a
    // value whose bits but the sign are all 0. Integer operations with no dependence on a comparison's
    // flags, which the compiler vectorises: the compared form cost a pendulum about 3 ns per event a step.
    const std::size_t m = g1_.size();
    std::uint64_t signs = 0, zero = 0;
    for (std::size_t e = 0; e < m; ++e) {
      const std::uint64_t a = bits(g0_[e]), b = bits(g1_[e]);
      signs |= (a ^ b) | (bits(dg0_[e]) ^ bits(dg1_[e]));
      zero |= static_cast<std::uint64_t>((a << 1) == 0) | static_cast<std::uint64_t>((b << 1) == 0);
    }
    if ((signs >> 63) | zero) locate();
  }

  // On an affine g the interpolant is the cubic Hermite c(s) of g and h dg/dt at the step's ends, and
  // c(s) - chord(s) = s (1 - s) ((1 - s) a - s b), a = h g0' - (g1 - g0), b = h g1' - (g1 - g0): within
  // max(|a|, |b|) / 4 of the chord. With g0 and g1 of one sign and both further from 0 than that (with
  // a margin for rounding), c has no zero in the step, and the extremum need not be found.
  static std::uint64_t bits(double x) {
    std::uint64_t u;
    std::memcpy(&u, &x, sizeof u);
    return u;
  }

  static bool keeps_sign(double g0, double g1, double dg0, double dg1, double h) {
    const double chord = g1 - g0, a = std::abs(h * dg0 - chord), b = std::abs(h * dg1 - chord);
    const double scale = std::abs(g0) + std::abs(g1) + std::abs(h * dg0) + std::abs(h * dg1);
    return std::min(std::abs(g0), std::abs(g1)) > 0.25 * std::max(a, b) + 64.0 * DBL_EPSILON * scale;
  }

  RAYDAMP_NOINLINE void locate() {
    const std::size_t m = g1_.size();
    found_.clear();
    for (std::size_t e = 0; e < m; ++e) {
      const double ga = g0_[e], gb = g1_[e];
      const bool ga_negative = ga < 0.0, rate_negative = dg0_[e] < 0.0;
      if (!std::isfinite(ga) || !std::isfinite(gb)) continue;
      // Points of [0, 1] between which g is monotone on the interpolant: the ends and, where g keeps
      // its sign but its rate changes sign, the extremum between (a touch or two crossings).
      double s[3] = {0.0, 1.0, 1.0}, g[3] = {ga, gb, gb};
      int points = 2;
      if (ga != 0.0 && ga_negative == (gb < 0.0) && dg0_[e] != 0.0 && dg1_[e] != 0.0 &&
          rate_negative != (dg1_[e] < 0.0)) {
        if (set_->events[e].affine && keeps_sign(ga, gb, dg0_[e], dg1_[e], t1_ - t0_)) continue;
        s[1] = root(e, 0.0, 1.0, dg0_[e], dg1_[e], 1);
        g[1] = on_step(e, s[1], 0);
        points = std::isfinite(g[1]) ? 3 : 2;
        if (points == 2) s[1] = 1.0, g[1] = gb;
      }
      for (int k = 0; k + 1 < points; ++k) {
        if (g[k] == 0.0 || (g[k + 1] != 0.0 && (g[k] < 0.0) == (g[k + 1] < 0.0))) continue;
        const int direction = g[k] < 0.0 ? 1 : -1;
        const int wanted = set_->events[e].direction;
        if (wanted != 0 && wanted != direction) continue;
        const int from = points == 3 ? k : (std::abs(ga) <= std::abs(gb) ? 0 : 1);
        found_.push_back({root(e, s[k], s[k + 1], g[k], g[k + 1], 0), e, direction, from});
      }
    }
    if (found_.empty()) return;
    std::sort(found_.begin(), found_.end(), [](const Found& x, const Found& y) { return x.s < y.s; });
    for (const Found& f : found_) {
      const double t = f.s == 1.0 ? t1_ : t0_ + f.s * (t1_ - t0_);
      record(f, t);
      if (set_->events[f.e].terminal) {
        stopped_ = true;
        t_stop_ = t;
        stop_event_ = f.e;
        return;
      }
    }
  }

  // The log's row: q and p of every coordinate on the interpolant at the crossing.
  void record(const Found& f, double t) {
    const double h = t1_ - t0_;
    const Vec* fa = &f0();
    const Vec* fb = &f1();
    if (!forces_) {  // p's interpolant needs the force at both ends; computed here, at a crossing only
      force(q0(), p0(), t0_, fa_);
      force(q1(), p1(), t1_, fb_);
      fa = &fa_, fb = &fb_;
    }
    const hermite::Weights w = hermite::value(f.s);
    log_.event.push_back(static_cast<int>(f.e));
    log_.direction.push_back(f.direction);
    log_.t.push_back(t);
    for (int j = 0; j < n_; ++j) log_.q.push_back(hermite::at(w, q0()[j], v0()[j], q1()[j], v1()[j], h));
    for (int j = 0; j < n_; ++j) log_.p.push_back(hermite::at(w, p0()[j], (*fa)[j], p1()[j], (*fb)[j], h));
    if (set_->events[f.e].henon) land(f);
  }

  // The last row of the log becomes Hénon's landing on g = 0 from the stepped state at the crossing
  // step's end f.from, where it lands (a finite point with its time inside the step, give or take a
  // rounding); else it stays the interpolant's.
  RAYDAMP_NOINLINE void land(const Found& f) {
    henon::Work<Vec>& w = henon_;
    double t = f.from == 0 ? t0_ : t1_;
    Vec& q = land_q_;
    Vec& p = land_p_;
    q = f.from == 0 ? q0() : q1();
    p = f.from == 0 ? p0() : p1();
    auto rates = [&](double ts, const Vec& qs, const Vec& ps, Vec& v, Vec& force_out) {
      model_.velocity(model_.model, ps, v);
      force(qs, ps, ts, force_out);
      return value_at(f.e, ts, qs, ps, v, force_out);
    };
    const double h = t1_ - t0_, slack = 4.0 * DBL_EPSILON * std::max(std::abs(t1_), h);
    if (!henon::land(t, q, p, w, rates, 4) || !(t >= t0_ - slack && t <= t1_ + slack) || !q.allFinite() ||
        !p.allFinite())
      return;
    const std::size_t row = log_.t.size() - 1;
    log_.t[row] = t;
    std::copy(q.data(), q.data() + n_, log_.q.begin() + static_cast<std::ptrdiff_t>(row * n_));
    std::copy(p.data(), p.data() + n_, log_.p.begin() + static_cast<std::ptrdiff_t>(row * n_));
  }

  // g and dg/dt of event e at the state (t, q, p) with v = M^{-1} p and f = pdot there.
  std::pair<double, double> value_at(std::size_t e, double t, const Vec& q, const Vec& p, const Vec& v,
                                     const Vec& f) {
    if (affine_) {
      const EventFunction& fn = set_->events[e];
      double g = fn.constant, rate = 0.0;
      for (const EventFunction::Term& term : fn.terms) {
        switch (term.kind) {
          case Kind::q: g += term.coefficient * q[term.index], rate += term.coefficient * v[term.index]; break;
          case Kind::p: g += term.coefficient * p[term.index], rate += term.coefficient * f[term.index]; break;
          default: g += term.coefficient * t, rate += term.coefficient; break;
        }
      }
      return {g, rate};
    }
    const std::vector<EventSlot>& slots = set_->slots;
    for (std::size_t k = 0; k < slots.size(); ++k) {
      const int j = slots[k].index;
      switch (slots[k].kind) {
        case Kind::t: in_[k] = t; break;
        case Kind::q: in_[k] = q[j]; break;
        case Kind::p: in_[k] = p[j]; break;
        case Kind::v: in_[k] = v[j]; break;
        case Kind::f: in_[k] = f[j]; break;
      }
    }
    set_->fn(out_.data(), in_.data());
    return {out_[2 * e], out_[2 * e + 1]};
  }

  void push_dense() {
    if (!dense_) return;
    dense_->t.push_back(t1_);
    dense_->q.insert(dense_->q.end(), q1().data(), q1().data() + n_);
    dense_->p.insert(dense_->p.end(), p1().data(), p1().data() + n_);
    dense_->v.insert(dense_->v.end(), v1().data(), v1().data() + n_);
    dense_->f.insert(dense_->f.end(), f1().data(), f1().data() + n_);
  }

  void resize_dense(long rows) {
    dense_->t.resize(rows);
    for (auto* v : {&dense_->q, &dense_->p, &dense_->v, &dense_->f}) v->resize(rows * n_);
  }

  const ModelView model_;
  const EventSet* set_;
  const Load* load_;
  DenseRecord* dense_;
  EventLog& log_;
  const bool on_;
  const double h_, h_last_;  // the run's steps, for a step's start time
  const long steps_;
  bool forces_ = false, terminal_ = false, stopped_ = false, affine_ = false, gated_ = false, budgeted_ = false;
  bool read_all_ = false;                             // the groups read every q
  bool keeps_ = false;      // keep() copies the step's start (screened in the loop)
  bool batchable_ = false;  // screened, and the spec allows batch_screens
  bool batched_ = false;    // batch_screens(): rows_ hold the block's step ends
  enum class Rows : unsigned char { none, ends, ends_and_marks };
  Rows rows_mode_ = Rows::none;  // what after_step() writes to rows_
  bool reads_time_ = false;  // some group reads t
  // q then p of each step end in the block, row 0 its start; M^-1 p and t there, once screened; count_[j] = j
  std::vector<double> rows_, rows_v_, rows_t_, count_;
  double* cursor_ = nullptr;  // the next row of rows_ to write
  std::vector<RecorderMarks> row_marks_;  // the recorder's marks there (terminal events)
  long first_ = 0;                        // the block's first step
  std::vector<block_sums::Group<Input>> spans_;  // the groups as screen_rows() passes them
  double h_max_ = 0.0, moved_ = 0.0, budget_ = -1.0;  // within_budget()
  std::vector<int> read_q_;                           // the q the groups read
  int n_ = 0;
  long step_ = -1;
  std::size_t stop_event_ = 0;
  double t0_ = 0.0, t1_ = 0.0, t_stop_ = 0.0;
  // The step's two ends, q_[end_] (its end) and q_[end_ ^ 1] (its start), and so p, v, f: a step moves
  // them back by flipping end_ (swapping the vectors cost the pendulum's watcher a tenth of its step).
  Vec q_[2], p_[2], v_[2], f_[2];
  int end_ = 1;
  Vec grad_, rate_, fa_, fb_, land_q_, land_p_;
  Vec kept_q_, kept_p_;  // a screened run: the state the step being taken starts from (keep)
  Vec speed_;            // a budgeted run: |M^-1 p| at the last step's end
  henon::Work<Vec> henon_;
  std::vector<double> in_, g0_, g1_, dg0_, dg1_;
  std::vector<double> out_;
  std::vector<Found> found_;
  std::vector<Group> groups_;  // affine events by form (quiet())
  std::vector<Input> inputs_;
  std::vector<double> levels_;
  RecorderMarks marks0_{}, marks1_{}, marks_{};
};

}  // namespace raydamp
