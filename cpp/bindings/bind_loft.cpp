// Bindings for loft: written by the issue that implements the algorithm.
#include "common.hpp"

namespace faultmesh::bindings {
void bind_loft(py::module_& m) { (void)m; }
}  // namespace faultmesh::bindings
