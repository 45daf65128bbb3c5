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

namespace faultmesh {

class GeometryError : public std::runtime_error {
public:
    explicit GeometryError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace faultmesh
