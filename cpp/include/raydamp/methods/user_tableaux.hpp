// Butcher tableaux a user brings (integrate(..., tableau={"A": ..., "b": ..., "c": ...})).
// Each is validated like ours (row sums, consistency; its order computed from the order
// conditions) and kept under a name derived from its coefficients, so the rest of raydamp
// (the catalogue, the step loop, ensembles) meets only tableau names, ours or a user's.
#pragma once

#include <cstdint>
#include <cstring>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/methods/butcher_tableau.hpp"

namespace raydamp {

namespace detail {

// The one store of user tableaux: a deque, so a reference handed out stays valid while
// others are added (runs on other threads hold references to theirs).
struct UserTableaux {
  std::mutex lock;
  std::deque<ButcherTableau> tables;
};

inline UserTableaux& user_tableaux() {
  static UserTableaux store;
  return store;
}

inline bool same_coefficients(const ButcherTableau& x, const ButcherTableau& y) {
  if (x.stages() != y.stages()) return false;
  for (int i = 0; i < x.stages(); ++i) {
    if (x.b(i) != y.b(i) || x.c(i) != y.c(i)) return false;
    for (int j = 0; j < x.stages(); ++j)
      if (x.a(i, j) != y.a(i, j)) return false;
  }
  return true;
}

// FNV-1a over the coefficients' bytes: equal tables get equal names, in every process.
inline std::string coefficient_name(const ButcherTableau& tab) {
  std::uint64_t hash = 14695981039346656037ull;
  auto mix = [&](double value) {
    if (value == 0.0) value = 0.0;  // -0.0 and 0.0 are the same coefficient
    unsigned char bytes[sizeof value];
    std::memcpy(bytes, &value, sizeof value);
    for (unsigned char byte : bytes) hash = (hash ^ byte) * 1099511628211ull;
  };
  mix(tab.stages());
  for (int i = 0; i < tab.stages(); ++i) {
    mix(tab.b(i));
    mix(tab.c(i));
    for (int j = 0; j < tab.stages(); ++j) mix(tab.a(i, j));
  }
  static const char* digits = "0123456789abcdef";
  std::string name = "custom-";
  for (int shift = 60; shift >= 0; shift -= 4) name += digits[(hash >> shift) & 0xf];
  return name;
}

}  // namespace detail

// More distinct user tableaux than this in one process is a program generating them in a loop.
inline constexpr std::size_t max_user_tableaux = 4096;

// Validates (a, b, c) and returns the stored tableau, named "custom-<16 hex digits>".
// Throws std::invalid_argument saying what is wrong ("tableau: row 1 of a does not sum to c[1]").
inline const ButcherTableau& define_tableau(std::vector<std::vector<double>> a, std::vector<double> b,
                                            std::vector<double> c) {
  ButcherTableau tab("", std::move(a), std::move(b), std::move(c));
  tab.rename(detail::coefficient_name(tab));
  auto& store = detail::user_tableaux();
  std::lock_guard<std::mutex> guard(store.lock);
  for (const ButcherTableau& known : store.tables)
    if (known.name() == tab.name()) {
      if (!detail::same_coefficients(known, tab))
        throw std::logic_error("tableau: two different tableaux hash to " + tab.name());
      return known;
    }
  if (store.tables.size() >= max_user_tableaux)
    throw std::invalid_argument("tableau: more than " + std::to_string(max_user_tableaux) +
                                " different user tableaux in one process");
  store.tables.push_back(std::move(tab));
  return store.tables.back();
}

// Ours by name, else a user's defined earlier in this process.
inline const ButcherTableau& tableau_named(const std::string& name) {
  if (name.rfind("custom-", 0) == 0) {
    auto& store = detail::user_tableaux();
    std::lock_guard<std::mutex> guard(store.lock);
    for (const ButcherTableau& known : store.tables)
      if (known.name() == name) return known;
    throw std::invalid_argument("tableau: no user tableau named '" + name +
                                "' in this process; pass the tableau itself ({\"A\": ..., \"b\": ..., \"c\": ...})");
  }
  return builtin_tableau(name);
}

}  // namespace raydamp
