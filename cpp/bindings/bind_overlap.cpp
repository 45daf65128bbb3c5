// Bindings for overlap: written by the issue that implements the algorithm.
#include "common.hpp"

namespace faultmesh::bindings {
void bind_overlap(py::module_& m) { (void)m; }
}  // namespace faultmesh::bindings
