// A model as the step loop's observers see it (events/watcher.hpp, record/envelope.hpp,
// record/divergence.hpp): its size and the few functions they call, on vectors of run-time size,
// through plain function pointers. The observers run at a step's end, outside the flattened step
// loop, so one copy of each serves every model type and method of a translation unit; only these
// thunks are made per model type. (Each model type of fixed size 1, 2 or 3 is a type of its own,
// and the observers as templates were a fifth of a compiled-system unit's code.)
//
// A model of fixed size is called on copies on the stack (a few doubles); one of run-time size on
// the observer's own vectors, without a copy.
#pragma once

#include <cstddef>
#include <type_traits>

#include <Eigen/Core>

#include "raydamp/materials/commit.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

struct ModelView {
  using Vec = Eigen::VectorXd;
  const void* model = nullptr;
  int n = 0;
  std::size_t springs = 0;  // hysteretic springs (materials/): 0 for a model without them
  void (*velocity)(const void*, const Vec& p, Vec& v) = nullptr;  // v = M^{-1} p
  // out = pdot without the load: -grad V(q) - eps D(q) M^{-1} p (grad and rate: scratch of size n).
  void (*force)(const void*, const Vec& q, const Vec& p, Vec& grad, Vec& rate, Vec& out) = nullptr;
  double (*kinetic)(const void*, const Vec& p) = nullptr;
  double (*potential)(const void*, const Vec& q) = nullptr;
  void (*deformations)(const void*, const Vec& q, double* d) = nullptr;     // springs' d_s(q)
  void (*spring_forces)(const void*, const Vec& q, double* s) = nullptr;    // springs' sigma_s
};

// A view of the raw q, p of a State, whatever its size (what the observers take).
struct StateView {
  const double* q;
  const double* p;
};

template <int Dim>
StateView view_of(const State<Dim>& z) {
  return {z.q.data(), z.p.data()};
}

namespace detail {

template <class Model>
struct ViewThunks {
  using Vec = ModelView::Vec;
  using MVec = typename Model::Vec;
  static constexpr bool same = std::is_same_v<MVec, Vec>;
  static const Model& of(const void* m) { return *static_cast<const Model*>(m); }

  // x as the model's own vector type: itself, or a copy on the stack.
  static std::conditional_t<same, const Vec&, MVec> in(const Vec& x) { return x; }

  // f(out) on the model's own vector type, then into out.
  template <class F>
  static void into(Vec& out, const F& f) {
    if constexpr (same) {
      f(out);
    } else {
      MVec local = MVec::Zero(out.size());
      f(local);
      out = local;
    }
  }

  static void velocity(const void* m, const Vec& p, Vec& v) {
    into(v, [&](auto& out) { of(m).mass.velocity(in(p), out); });
  }
  static void force(const void* m, const Vec& q, const Vec& p, Vec& grad, Vec& rate, Vec& out) {
    const Model& model = of(m);
    if constexpr (same) {
      model.gradient(q, grad);
      model.damping.rate(q, p, rate);
      out = -(grad + rate);
    } else {
      const MVec qm = q, pm = p;
      MVec g = MVec::Zero(q.size()), r = MVec::Zero(q.size());
      model.gradient(qm, g);
      model.damping.rate(qm, pm, r);
      out = -(g + r);
    }
  }
  static double kinetic(const void* m, const Vec& p) { return of(m).mass.kinetic(in(p)); }
  static double potential(const void* m, const Vec& q) { return of(m).potential(in(q)); }
  static void deformations(const void* m, const Vec& q, double* d) {
    if constexpr (has_materials_v<Model>) {
      const auto& qm = in(q);
      of(m).springs.for_each([&](const auto& set) {
        for (std::size_t s = 0; s < set.size(); ++s) *d++ = set.deformation(qm, s);
      });
    } else {
      static_cast<void>(m), static_cast<void>(q), static_cast<void>(d);
    }
  }
  static void spring_forces(const void* m, const Vec& q, double* f) {
    if constexpr (has_materials_v<Model>) {
      const auto& qm = in(q);
      of(m).springs.for_each([&](const auto& set) {
        set.forces(qm, f);
        f += set.size();
      });
    } else {
      static_cast<void>(m), static_cast<void>(q), static_cast<void>(f);
    }
  }
};

}  // namespace detail

template <class Model>
ModelView model_view(const Model& model) {
  using T = detail::ViewThunks<Model>;
  ModelView v;
  v.model = &model;
  v.n = model.size();
  if constexpr (has_materials_v<Model>) v.springs = model.springs.size();
  v.velocity = &T::velocity;
  v.force = &T::force;
  v.kinetic = &T::kinetic;
  v.potential = &T::potential;
  v.deformations = &T::deformations;
  v.spring_forces = &T::spring_forces;
  return v;
}

}  // namespace raydamp
