// Bindings for delaunay: written by the issue that implements the algorithm.
#include "common.hpp"

namespace faultmesh::bindings {
void bind_delaunay(py::module_& m) { (void)m; }
}  // namespace faultmesh::bindings
