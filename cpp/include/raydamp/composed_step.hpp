// A step of a symmetric splitting table composed with coefficients gamma_i, as
// the durations of its sub-flows, and the step loop's three ways of applying it.
//
// A symmetric table starts and ends with the same exact flow (damp for 3s, drift
// for sv, 2s and rks, kick for rksb). Two such sub-flows in a row are one flow
// for the summed time (exp(a X) exp(b X) = exp((a + b) X)), so
// - inside a composed step, the end of stage i and the start of stage i + 1 are
//   merged (a "joint"), always;
// - between two steps whose intermediate state nobody reads, the end of one and
//   the start of the next are merged too (first-same-as-last): 3s then runs
//   damp h/2, [drift h/2, kick h, drift h/2, damp h]*, ..., drift h/2, damp h/2.
// Results equal the unmerged steps to rounding.
#pragma once

#include <array>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "raydamp/methods/composition.hpp"
#include "raydamp/step.hpp"

namespace raydamp {

// Sub-flow durations of one step of size h: the first sub-flow (lead), then for
// each composition stage c its inner sub-flows 1 .. S-2 followed (except after the
// last stage) by the joint, then the last sub-flow (trail). Fixed storage, so the
// step loop can copy it into a local the compiler keeps in registers.
template <class Method>
struct StepDurations {
  static constexpr int S = static_cast<int>(Method::stages.size());
  static constexpr int stride = S - 1;  // inner sub-flows and the joint after them
  double lead = 0.0, trail = 0.0;
  int m = 1;
  std::array<double, kMaxCompositionStages * stride> body{};  // m * stride used; the last joint slot unused
  std::array<double, kMaxCompositionStages> stage{};           // gamma_s h: each stage's step size
  bool table = false;  // a near-integrable table: each end and middle sub-flow its own fraction, no joints

  StepDurations(const Composition& c, double h) : m(c.stages()) {
    if (c.is_table()) {
      from_table(c, h);
      return;
    }
    const double first = Method::stages[0].fraction, last = Method::stages[S - 1].fraction;
    lead = first * c.gamma(0) * h;
    trail = last * c.gamma(m - 1) * h;
    for (int s = 0; s < m; ++s) {
      stage[s] = c.gamma(s) * h;
      for (int j = 1; j < S - 1; ++j) body[s * stride + j - 1] = Method::stages[j].fraction * c.gamma(s) * h;
      if (s + 1 < m) body[s * stride + S - 2] = (last * c.gamma(s) + first * c.gamma(s + 1)) * h;
    }
  }

  // X(a_0 h) Y(b_1 h) X(a_1 h) ... Y(b_m h) X(a_m h) of a base X Y X: lead a_0 h, trail a_m h, and the X
  // between two Y's where a composition has its joints.
  void from_table(const Composition& c, double h) {
    if constexpr (S != 3) {
      throw std::invalid_argument("composition: '" + c.name() + "' is a near-integrable table of a base drift, kick, "
                                  "drift (sv, 2s, rks); method table '" + Method::name + "' has " +
                                  std::to_string(S) + " sub-flows");
    } else {
      table = true;
      lead = c.ends()[0] * h;
      trail = c.ends()[m] * h;
      for (int s = 0; s < m; ++s) {
        stage[s] = c.gamma(s) * h;
        body[s * stride] = c.gamma(s) * h;
        if (s + 1 < m) body[s * stride + 1] = c.ends()[s + 1] * h;
      }
    }
  }

  // Every sub-flow of the step in order (for the amplification bound), as
  // f(flow, duration, stage, fraction, joint): the sub-flow runs for fraction * gamma_stage * h,
  // or, a joint, for fraction * (gamma_stage + gamma_{stage+1}) * h (a symmetric table's first
  // and last fractions are equal), stages counted from 0.
  template <class F>
  void for_each(F f) const {
    if (table) {  // every sub-flow forward: fraction = its duration / h, in stage s's place
      double h = 0.0;  // the kicks' fractions sum to 1
      for (int s = 0; s < m; ++s) h += stage[s];
      f(Method::stages[0].flow, lead, 0, lead / h, false);
      for (int s = 0; s < m; ++s) {
        f(Method::stages[1].flow, body[s * stride], s, body[s * stride] / h, false);
        if (s + 1 < m) f(Method::stages[0].flow, body[s * stride + 1], s, body[s * stride + 1] / h, false);
      }
      f(Method::stages[S - 1].flow, trail, m - 1, trail / h, false);
      return;
    }
    const double first = Method::stages[0].fraction;
    f(Method::stages[0].flow, lead, 0, first, false);
    for (int s = 0; s < m; ++s) {
      for (int j = 1; j < S - 1; ++j)
        f(Method::stages[j].flow, body[s * stride + j - 1], s, Method::stages[j].fraction, false);
      if (s + 1 < m) f(Method::stages[0].flow, body[s * stride + S - 2], s, first, true);
    }
    f(Method::stages[S - 1].flow, trail, m - 1, Method::stages[S - 1].fraction, false);
  }
};

// A model that runs 3s's join and the next step's body as one call of its own
// (a System's compiled damp_then_3s_body, models/compiled_system.hpp).
template <class M, class = void>
struct fuses_3s : std::false_type {};
template <class M>
struct fuses_3s<M, std::void_t<decltype(std::declval<const M&>().fuses_3s())>> : std::true_type {};

namespace detail {

template <class Method, class Model, class Tab, int Dim, class WS, std::size_t... I>
inline void inner_stages(const Model& model, const Tab& tab, State<Dim>& z, const double* t, WS& ws,
                         std::index_sequence<I...>) {
  (apply_flow<Method::stages[I + 1].flow>(model, tab, z, t[I], ws), ...);
}

}  // namespace detail

// The steps of one run: Method composed with a composition, for a run of n_steps
// steps of size h whose last step has size h_last.
template <class Method>
class ComposedStepper {
 public:
  using Table = Method;
  static constexpr int S = StepDurations<Method>::S;
  static_assert(is_mergeable<Method>(), "ComposedStepper needs a symmetric table with an exact end sub-flow");

  ComposedStepper(const Composition& c, double h, double h_last, long n_steps)
      : regular_(c, h), last_(c, h_last), last_step_(n_steps - 1), join_regular_(regular_.trail + regular_.lead),
        single_(c.stages() == 1) {
    for (int j = 0; j < S - 2; ++j) inner_regular_[j] = regular_.body[j];
  }

  const StepDurations<Method>& durations(long i) const { return i == last_step_ ? last_ : regular_; }

  // The whole step i, unmerged at both ends.
  template <class Model, class Tab, int Dim, class WS>
  void step(const Model& model, const Tab& tab, State<Dim>& z, long i, WS& ws) const {
    const StepDurations<Method>& d = durations(i);
    apply_flow<Method::stages[0].flow>(model, tab, z, d.lead, ws);
    body(model, tab, z, d, ws);
    apply_flow<Method::stages[S - 1].flow>(model, tab, z, d.trail, ws);
  }

  // Composition stages: 1 for the method itself. A near-integrable table counts as one: its sub-flows are not
  // steps of a symmetric base, so the damping work's trapezoid takes the whole step's ends (order 2).
  int stages() const { return regular_.table ? 1 : regular_.m; }

  // The whole step i, one composition stage at a time (each joint run as the two flows it merges, equal
  // to rounding), calling at_stage(gamma_s h) after stage s: for a quadrature at the stages' end points.
  // The damping work's trapezoid there makes (state, W) a symmetric order-2 step of size gamma_s h, which
  // the composition raises to its order; at the composed step's end points alone it stays order 2.
  template <class Model, class Tab, int Dim, class WS, class AtStage>
  void step_by_stage(const Model& model, const Tab& tab, State<Dim>& z, long i, WS& ws, AtStage&& at_stage) const {
    const StepDurations<Method>& d = durations(i);
    const double first = Method::stages[0].fraction, last = Method::stages[S - 1].fraction;
    for (int s = 0; s < d.m; ++s) {
      apply_flow<Method::stages[0].flow>(model, tab, z, first * d.stage[s], ws);
      detail::inner_stages<Method>(model, tab, z, d.body.data() + s * StepDurations<Method>::stride, ws,
                                   std::make_index_sequence<S - 2>{});
      apply_flow<Method::stages[S - 1].flow>(model, tab, z, last * d.stage[s], ws);
      at_stage(d.stage[s]);
    }
  }

  // Step i without its first sub-flow (run by lead() or the previous join()) and
  // without its last (run by join() or trail()).
  template <class Model, class Tab, int Dim, class WS>
  void lead(const Model& model, const Tab& tab, State<Dim>& z, long i, WS& ws) const {
    apply_flow<Method::stages[0].flow>(model, tab, z, durations(i).lead, ws);
  }
  template <class Model, class Tab, int Dim, class WS>
  void body(const Model& model, const Tab& tab, State<Dim>& z, long i, WS& ws) const {
    // The uncomposed method's regular step reads its durations from this object,
    // a local of the step loop that nothing else can write, so the compiler keeps
    // them in registers across the model's calls (heap data it must reload).
    if (single_ && i != last_step_)
      detail::inner_stages<Method>(model, tab, z, inner_regular_.data(), ws, std::make_index_sequence<S - 2>{});
    else
      body(model, tab, z, durations(i), ws);
  }
  // The last sub-flow of step i and the first of step i + 1, as one flow.
  template <class Model, class Tab, int Dim, class WS>
  void join(const Model& model, const Tab& tab, State<Dim>& z, long i, WS& ws) const {
    const double t = i + 1 == last_step_ ? regular_.trail + last_.lead : join_regular_;
    apply_flow<Method::stages[0].flow>(model, tab, z, t, ws);
  }
  // join(i) then body(i + 1); one call of the model where it fuses them (3s between
  // two regular steps of the uncomposed method), the same sub-flows otherwise.
  template <class Model, class Tab, int Dim, class WS>
  void join_then_body(const Model& model, const Tab& tab, State<Dim>& z, long i, WS& ws) const {
    if constexpr (std::is_same_v<Method, ThreeTermSplitting> && fuses_3s<Model>::value) {
      if (single_ && i + 1 != last_step_ && model.fuses_3s() && !load_of(ws) && !noisy(ws)) {  // its body has no load, no noise
        model.damp_then_3s_body(z.q, z.p, flows::damp_factors(model, join_regular_, ws), inner_regular_.data());
        return;
      }
    }
    join(model, tab, z, i, ws);
    body(model, tab, z, i + 1, ws);
  }
  template <class Model, class Tab, int Dim, class WS>
  void trail(const Model& model, const Tab& tab, State<Dim>& z, long i, WS& ws) const {
    apply_flow<Method::stages[S - 1].flow>(model, tab, z, durations(i).trail, ws);
  }

 private:
  template <class Model, class Tab, int Dim, class WS>
  static void body(const Model& model, const Tab& tab, State<Dim>& z, const StepDurations<Method>& d,
                   WS& ws) {
    const double* t = d.body.data();
    for (int s = 0; s < d.m; ++s, t += StepDurations<Method>::stride) {
      detail::inner_stages<Method>(model, tab, z, t, ws, std::make_index_sequence<S - 2>{});
      if (s + 1 < d.m) {
        if constexpr (has_constraints<Model>::value) {  // a constrained drift for a, then b, is not the one for a + b
          if (d.table) {  // a table's drift between two kicks is one flow, not a joint
            apply_flow<Method::stages[0].flow>(model, tab, z, t[S - 2], ws);
          } else {
            apply_flow<Method::stages[S - 1].flow>(model, tab, z, Method::stages[S - 1].fraction * d.stage[s], ws);
            apply_flow<Method::stages[0].flow>(model, tab, z, Method::stages[0].fraction * d.stage[s + 1], ws);
          }
        } else {
          apply_flow<Method::stages[0].flow>(model, tab, z, t[S - 2], ws);
        }
      }
    }
  }

  StepDurations<Method> regular_, last_;
  long last_step_;
  double join_regular_;
  bool single_;  // one composition stage: the method itself
  std::array<double, S - 2> inner_regular_{};
};

}  // namespace raydamp
