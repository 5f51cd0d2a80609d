// A user's system with holonomic constraints g(q) = 0: a compiled system (models/compiled_system.hpp) and
// its ConstraintSet. The capability is the `constraints` member: the step loop sees it at compile time
// (constraints/rattle.hpp, has_constraints) and runs the constrained sub-flows; a model without it runs
// the same loop as before, with no test and no call more.
#pragma once

#include <type_traits>
#include <utility>
#include <vector>

#include "raydamp/constraints/constraint_set.hpp"
#include "raydamp/constraints/dashpots.hpp"
#include "raydamp/models/compiled_system.hpp"

namespace raydamp {

template <class Mass, class Damping>
struct ConstrainedSystem : CompiledSystem<Mass, Damping> {
  using Base = CompiledSystem<Mass, Damping>;
  // Its drift is SHAKE + RATTLE on the constraint manifold, not q += t M^{-1} p: the methods that step a
  // free drift inside a Runge-Kutta stage (rksb, heun, rk4, rk) refuse it (catalogue.hpp).
  static constexpr bool free_drift = false;
  static constexpr const char* name = "the constrained system (SHAKE and RATTLE on g(q) = 0)";

  ConstraintSet constraints;
  // With dashpot damping, what their flow on the tangent space needs (constraints/projected_dampers.hpp).
  constraints::Dashpots dashpots;

  ConstrainedSystem(Base base, ConstraintSet constraints_, constraints::Dashpots dashpots_ = {})
      : Base(std::move(base)), constraints(std::move(constraints_)), dashpots(std::move(dashpots_)) {
    if (constraints.n != this->n) throw std::invalid_argument("constraints: made for another number of coordinates");
    // 3s's fused body (a dashpot's) has no constraint hook.
    this->functions.damp_then_3s_body = CompiledFunction{};
    constraints.analyse(inverse_mass_entries());
  }

  // M^{-1}'s non-zeros, from which G M^{-1} G^T's pattern follows.
  std::vector<constraints::InverseMassEntry> inverse_mass_entries() const {
    std::vector<constraints::InverseMassEntry> entries;
    const Mass& mass = this->mass;
    if constexpr (std::is_same_v<std::decay_t<decltype(mass.inverse)>, double>) {
      for (int i = 0; i < this->n; ++i) entries.push_back({i, i, mass.inverse});
    } else {
      for (int j = 0; j < this->n; ++j)
        for (int i = 0; i < this->n; ++i)
          if (mass.inverse(i, j) != 0.0) entries.push_back({i, j, mass.inverse(i, j)});
    }
    return entries;
  }
};

}  // namespace raydamp
