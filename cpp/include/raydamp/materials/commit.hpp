// The step loop's hooks for a model with hysteretic materials (models/structure.hpp): each commits the
// material states once per full step, and a checkpoint keeps them, so a replayed block starts from the
// states of its start. For every other model they are empty and compile away.
#pragma once

#include <type_traits>
#include <utility>

#include "raydamp/methods/splitting.hpp"

namespace raydamp {

template <class Model, class = void>
struct has_materials : std::false_type {};
template <class Model>
struct has_materials<Model, std::void_t<decltype(std::declval<const Model&>().springs.commit())>>
    : std::true_type {};
template <class Model>
inline constexpr bool has_materials_v = has_materials<Model>::value;

// After the last kick of a step: its trial states become the committed ones.
template <class Model>
inline void commit_materials(const Model& model) {
  if constexpr (has_materials_v<Model>) model.springs.commit();
}
template <class Model>
inline void save_materials(const Model& model) {
  if constexpr (has_materials_v<Model>) model.springs.save();
}
template <class Model>
inline void restore_materials(const Model& model) {
  if constexpr (has_materials_v<Model>) model.springs.restore();
}

// Whether a table's end sub-flows are kicks (baoab, rksb): merged across steps, the step's last kick is
// then the joint with the next step's first, and the commit follows the joint, not the body.
template <class Method>
constexpr bool kicks_at_ends() {
  return Method::stages[0].flow == Flow::kick;
}

}  // namespace raydamp
