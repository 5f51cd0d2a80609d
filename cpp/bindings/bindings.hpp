// The pieces of the private _core module, one per concern.
#pragma once

#include <pybind11/pybind11.h>

namespace raydamp::bindings {
void bind_catalogue(pybind11::module_& m);
void bind_load(pybind11::module_& m);
void bind_models(pybind11::module_& m);
void bind_integrate(pybind11::module_& m);
void bind_system_scalar_mass(pybind11::module_& m);
void bind_system_dense_mass(pybind11::module_& m);
void bind_constrained_system(pybind11::module_& m);
void bind_chain(pybind11::module_& m);
void bind_linear_structure(pybind11::module_& m);
void bind_structure(pybind11::module_& m);
void bind_kepler(pybind11::module_& m);
void bind_events(pybind11::module_& m);
void bind_envelope(pybind11::module_& m);
}  // namespace raydamp::bindings
