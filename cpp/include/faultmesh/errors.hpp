// faultmesh/errors.hpp -- the two kinds of failure the library reports.
//
// std::invalid_argument : the caller's input is malformed (wrong shape, NaN,
//                         index out of range). Python sees ValueError.
// faultmesh::GeometryError : the input is well-formed but the geometry does not
//                         allow the operation (all points collinear, a polygon
//                         that cannot be triangulated, overlapping fault
//                         patches). Python sees faultmesh.GeometryError, a
//                         subclass of ValueError.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>

namespace faultmesh {

class GeometryError : public std::runtime_error {
public:
    explicit GeometryError(const std::string& what) : std::runtime_error(what) {}
};

// Two fault patches stitched into one layer overlap (or touch) in XY: the
// faults' zones overlap, which only modelling them together (one group, a
// T- or X-crossing) or separating them resolves. Names what overlaps.
class PatchOverlapError : public GeometryError {
public:
    PatchOverlapError(const std::string& what, std::string layer_name, std::string patch_name,
                      std::string other_name)
        : GeometryError(what), layer(std::move(layer_name)), patch(std::move(patch_name)),
          other(std::move(other_name)) {}
    std::string layer, patch, other;
};

}  // namespace faultmesh
