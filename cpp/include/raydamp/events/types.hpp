// What a run is asked about events and dense output (EventSet, in RunSpec) and what it gives back
// (EventLog, DenseRecord, in RunResult). The step loop's observer of them is events/watcher.hpp.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "raydamp/system/compiled_function.hpp"

namespace raydamp {

// One input of an event function, read at a step end or on the step's interpolant: the time, q_i,
// p_i, or their time derivatives v_i = (M^{-1} p)_i and f_i = pdot_i (the force at the state).
struct EventSlot {
  enum class Kind { t, q, p, v, f };
  Kind kind = Kind::t;
  int index = 0;
};

// One event: which zeros of its g count, and what they do.
struct EventFunction {
  // {direction, terminal, name}: what every event has; the optional parts below are set by name.
  EventFunction(int direction_ = 0, bool terminal_ = false, std::string name_ = {})
      : direction(direction_), terminal(terminal_), name(std::move(name_)) {}
  int direction = 0;     // +1: g rising through 0, -1: falling, 0: both
  bool terminal = false;  // the run ends at the first such crossing
  std::string name;
  // Where g is affine in t, q and p: g = constant + sum of coefficient * input over terms (each input t,
  // q_i or p_i), and dg/dt = the sum over the inputs' rates (1, v_i, f_i). The loop then evaluates it
  // without the compiled call, and on the step's interpolant g is the cubic Hermite of its values and
  // rates at the step's ends, which bounds it without evaluating it inside the step.
  struct Term {
    EventSlot::Kind kind = EventSlot::Kind::t;
    int index = 0;
    double coefficient = 0.0;
  };
  bool affine = false;
  double constant = 0.0;
  std::vector<Term> terms;
  // Each crossing landed on g = 0 by Hénon's step (events/henon.hpp), not read off the interpolant.
  bool henon = false;
};

// Every event's g(t, q, p) in one function compiled from their expressions (one call per step end,
// however many events): fn(out, in) with in the slots' values in order and out = (g_0, dg_0/dt, g_1,
// dg_1/dt, ...), each rate by the chain rule on the slots' derivatives (python/raydamp/run/events.py).
struct EventSet {
  CompiledFunction fn;
  std::vector<EventSlot> slots;
  std::vector<EventFunction> events;
  bool empty() const { return events.empty(); }
  bool all_affine() const {
    for (const EventFunction& e : events)
      if (!e.affine) return false;
    return !events.empty();
  }
  // Whether any g reads p (then the force at every step end is computed, for p's interpolant).
  bool reads_momenta() const {
    for (const EventSlot& s : slots)
      if (s.kind == EventSlot::Kind::p || s.kind == EventSlot::Kind::f) return true;
    return false;
  }
};

// Every crossing found, in time order: which event, when, its direction, and (q, p) there on the
// step's interpolant (all n coordinates, row-major).
struct EventLog {
  int n = 0;
  std::vector<int> event, direction;
  std::vector<double> t, q, p;
  long size() const { return static_cast<long>(t.size()); }
};

// What dense output needs at every step end: t, q, p, v = M^{-1} p and f = pdot (row-major, n each).
struct DenseRecord {
  int n = 0;
  std::vector<double> t, q, p, v, f;
  long rows() const { return static_cast<long>(t.size()); }
};

}  // namespace raydamp
