// Compiled systems with a diagonal or full constant SPD mass matrix.
#include "bind_system.hpp"

namespace raydamp::bindings {

void bind_system_dense_mass(py::module_& m) {
  bind_system_kind<DenseMass, IsotropicDamping>(m, "System_dense_isotropic");
  bind_system_kind<DenseMass, ConstantDamping>(m, "System_dense_constant");
  bind_system_kind<DenseMass, DamperDamping>(m, "System_dense_dampers");
}

}  // namespace raydamp::bindings
