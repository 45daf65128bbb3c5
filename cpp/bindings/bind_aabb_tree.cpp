// Bindings for aabb_tree: written by the issue that implements the algorithm.
#include "common.hpp"

namespace faultmesh::bindings {
void bind_aabb_tree(py::module_& m) { (void)m; }
}  // namespace faultmesh::bindings
