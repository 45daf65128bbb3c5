// Bindings for ear_clipping: written by the issue that implements the algorithm.
#include "common.hpp"

namespace faultmesh::bindings {
void bind_ear_clipping(py::module_& m) { (void)m; }
}  // namespace faultmesh::bindings
