// A structure's hysteretic springs: struct-of-arrays, one set per material kind, each bound once, so the
// step loop runs one plain loop per kind with no allocation and no virtual call.
//
// Spring s acts on the deformation d = q[j] - q[i] (i < 0: d = q[j], relative to the ground) and adds the
// force -r sigma(d) with r = e_j - e_i. The material states are the run's own (a run copies its model
// with fresh states, models/structure.hpp), so they are `mutable`: the step loop's model is const, and
// the kick that reads sigma is where the trial state is written.
#pragma once

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "raydamp/materials/bouc_wen_lanes.hpp"
#include "raydamp/materials/materials.hpp"
#include "raydamp/materials/phases.hpp"

namespace raydamp::materials {

// Whether a return map from c to t flowed plastically: the spring was yielding at that deformation, so its
// tangent is the post-yield one (b k; 0 for ElasticPlastic). Bouc-Wen has no elastic branch (never asked).
inline bool flowed(const ElasticPlastic::State& c, const ElasticPlastic::State& t) { return t.plastic != c.plastic; }
inline bool flowed(const Bilinear::State& c, const Bilinear::State& t) { return t.plastic != c.plastic; }
inline bool flowed(const BoucWen::State&, const BoucWen::State&) { return false; }

template <class Material>
struct SpringSet {
  using State = typename Material::State;
  std::vector<int> i, j;  // d = q[j] - q[i], or q[j] where i < 0
  std::vector<Material> material;
  mutable std::vector<State> committed, trial, saved;
  // Bouc-Wen's kicks take the springs' return maps in vectors (bouc_wen_lanes.hpp): their parameters, and
  // their deformations and forces passing through these, sized by add(), so a kick allocates nothing.
  bouc_wen_lanes::Params lane_params;
  mutable std::vector<double> lane_deformations, lane_forces;
  // Where kinks are located (materials/kinks.hpp): each spring's phase, and kicks that read its law.
  mutable std::vector<signed char> phase, saved_phase;
  // Whether each spring yielded at the last kick of the last committed step (a run without kink location):
  // the branch whose tangent a tangent-stiffness damping takes for the next step (models/structure_damping.hpp).
  mutable std::vector<signed char> yielding, saved_yielding;
  bool phased = false;

  std::size_t size() const { return j.size(); }

  void add(int from, int to, const Material& m) {
    i.push_back(from);
    j.push_back(to);
    material.push_back(m);
    committed.emplace_back();
    if constexpr (std::is_same_v<Material, BoucWen>) {
      lane_params.add(m);
      lane_deformations.resize(bouc_wen_lanes::Params::padded(j.size()));
      lane_forces.resize(lane_deformations.size());
    }
    trial.emplace_back();
    saved.emplace_back();
    phase.push_back(static_cast<signed char>(initial_phase(m)));
    saved_phase.push_back(phase.back());
    yielding.push_back(0);
    saved_yielding.push_back(0);
  }

  // Whether spring s is on a yielding branch: its phase where kinks are located, else its last step's flow.
  bool on_yield_branch(std::size_t s) const { return phased ? phase[s] != 0 : yielding[s] != 0; }

  template <class Vec>
  double deformation(const Vec& q, std::size_t s) const {
    return i[s] < 0 ? q[j[s]] : q[j[s]] - q[i[s]];
  }

  // g += r f for spring s: the transpose of deformation (its force on q[j], the opposite on q[i]).
  template <class Vec>
  void scatter(std::size_t s, double f, Vec& g) const {
    g[j[s]] += f;
    if (i[s] >= 0) g[i[s]] -= f;
  }

  // g += r sigma(d) for each spring (initial = true: r (sigma(d) - k d), what the springs add to a gradient
  // taken with K0, which holds their initial stiffness k r r^T). Writes the trial states.
  template <bool initial = false, class Vec>
  void add_forces(const Vec& q, Vec& g) const {
    if constexpr (std::is_same_v<Material, BoucWen>) {
      if (!phased) {
        for (std::size_t s = 0; s < j.size(); ++s) lane_deformations[s] = deformation(q, s);
        bouc_wen_lanes::forces(material.data(), lane_params, committed.data(), lane_deformations.data(), trial.data(),
                               lane_forces.data(), j.size());
        for (std::size_t s = 0; s < j.size(); ++s)
          scatter(s, initial ? lane_forces[s] - material[s].stiffness() * lane_deformations[s] : lane_forces[s], g);
        return;
      }
    }
    for (std::size_t s = 0; s < j.size(); ++s) {
      const double d = deformation(q, s);
      // Where kinks are located, each spring's phase law (phases.hpp), the states untouched.
      const double f = phased ? phase_force(material[s], committed[s], phase[s], d)
                              : material[s].force(committed[s], d, trial[s]);
      scatter(s, initial ? f - material[s].stiffness() * d : f, g);
    }
  }

  // sum of stored(d) - 1/2 k d^2 at the trial states from the committed ones (the trial states untouched).
  template <class Vec>
  double energy_correction(const Vec& q) const {
    double sum = 0.0;
    for (std::size_t s = 0; s < j.size(); ++s) {
      const double d = deformation(q, s);
      State t;
      material[s].force(committed[s], d, t);
      sum += material[s].stored(t, d) - 0.5 * material[s].stiffness() * d * d;
    }
    return sum;
  }

  // out += r (k_t - k) r^T v, k_t the committed state's tangent at q.
  template <class Vec>
  void add_tangent_correction(const Vec& q, const Vec& v, Vec& out) const {
    for (std::size_t s = 0; s < j.size(); ++s) {
      const double d = deformation(q, s);
      State t;
      material[s].force(committed[s], d, t);
      scatter(s, (material[s].tangent(t, d) - material[s].stiffness()) * deformation(v, s), out);
    }
  }

  // Each spring's elastic range from its committed state: the deformations at which it next yields
  // (materials.hpp), for a caller that locates kinks as events of the deformation.
  void elastic_ranges(double* lower, double* upper) const {
    for (std::size_t s = 0; s < j.size(); ++s) {
      const Range r = material[s].elastic_range(committed[s]);
      lower[s] = r.lower;
      upper[s] = r.upper;
    }
  }

  // The forces sigma(d) from the committed states (the trial states untouched).
  template <class Vec>
  void forces(const Vec& q, double* out) const {
    for (std::size_t s = 0; s < j.size(); ++s) {
      State t;
      out[s] = material[s].force(committed[s], deformation(q, s), t);
    }
  }

  void commit() const {
    if constexpr (!std::is_same_v<Material, BoucWen>)  // (never yielding: a loop of zeros, 3 ns of a 113 ns step)
      for (std::size_t s = 0; s < j.size(); ++s) yielding[s] = flowed(committed[s], trial[s]) ? 1 : 0;
    std::copy(trial.begin(), trial.end(), committed.begin());
  }
  void save() const {
    std::copy(committed.begin(), committed.end(), saved.begin());
    std::copy(phase.begin(), phase.end(), saved_phase.begin());
    std::copy(yielding.begin(), yielding.end(), saved_yielding.begin());
  }
  void restore() const {
    std::copy(saved.begin(), saved.end(), committed.begin());
    std::copy(saved.begin(), saved.end(), trial.begin());
    std::copy(saved_phase.begin(), saved_phase.end(), phase.begin());
    std::copy(saved_yielding.begin(), saved_yielding.end(), yielding.begin());
  }
  void reset() const {
    std::fill(committed.begin(), committed.end(), State{});
    std::fill(trial.begin(), trial.end(), State{});
    std::fill(yielding.begin(), yielding.end(), 0);
    for (std::size_t s = 0; s < j.size(); ++s) phase[s] = static_cast<signed char>(initial_phase(material[s]));
  }
};

// Every spring of a structure, by material kind. for_each(f) visits the sets in a fixed order, which is
// also the order of the springs' forces and states (springs of one kind in the order they were added).
struct Springs {
  SpringSet<ElasticPlastic> elastic_plastic;
  SpringSet<Bilinear> bilinear;
  SpringSet<BoucWen> bouc_wen;

  template <class F>
  void for_each(F&& f) const {
    f(elastic_plastic);
    f(bilinear);
    f(bouc_wen);
  }
  template <class F>
  void for_each(F&& f) {
    f(elastic_plastic);
    f(bilinear);
    f(bouc_wen);
  }

  std::size_t size() const { return elastic_plastic.size() + bilinear.size() + bouc_wen.size(); }
  bool empty() const { return size() == 0; }

  // Refuses (naming springs[s].dofs) a coordinate outside 0..n-1, or a spring from a coordinate to itself.
  void check(int n) const {
    std::size_t base = 0;
    for_each([&](const auto& set) {
      for (std::size_t s = 0; s < set.size(); ++s) {
        const std::string where = "springs[" + std::to_string(base + s) + "].dofs";
        if (set.j[s] < 0 || set.j[s] >= n || set.i[s] >= n)
          throw std::invalid_argument(where + ": a coordinate outside 0.." + std::to_string(n - 1));
        if (set.i[s] == set.j[s]) throw std::invalid_argument(where + ": the two coordinates are the same");
      }
      base += set.size();
    });
  }

  void commit() const {
    for_each([](const auto& set) { set.commit(); });
  }
  void save() const {
    for_each([](const auto& set) { set.save(); });
  }
  void restore() const {
    for_each([](const auto& set) { set.restore(); });
  }
  void reset() const {
    for_each([](const auto& set) { set.reset(); });
  }
  // Kicks read each spring's phase law: set on a structure whose step loop locates kinks (kinks.hpp).
  void set_phased(bool on) {
    for_each([on](auto& set) { set.phased = on; });
  }
  bool phased() const { return elastic_plastic.phased; }

  // Bit s set where spring s (Springs' order) is on a yielding branch (at most 64 springs: the caller checks).
  std::uint64_t yield_mask() const {
    std::uint64_t mask = 0;
    int bit = 0;
    for_each([&](const auto& set) {
      for (std::size_t s = 0; s < set.size(); ++s, ++bit)
        if (set.on_yield_branch(s)) mask |= std::uint64_t{1} << bit;
    });
    return mask;
  }
};

}  // namespace raydamp::materials
