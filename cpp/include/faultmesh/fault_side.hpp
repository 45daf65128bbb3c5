// faultmesh/fault_side.hpp -- which side of a fault surface a point lies on.
//
// The fault surface is a TIN that is a function over one coordinate plane:
// it is projected along the axis k (0 = x, 1 = y, 2 = z) onto the plane of
// the axes u = (k + 1) % 3 and v = (k + 2) % 3, where no two of its
// triangles overlap. Projecting along a coordinate axis copies coordinates,
// it never rounds them, so every decision below is exact on the input
// doubles:
//
//  * location: the triangle whose closed (u, v) projection contains the
//    point's projection, by the exact orient2d (AABB tree candidates, the
//    smallest containing triangle index wins, so a point on a shared edge or
//    vertex gets one deterministic triangle);
//  * side: the sign of the exact orient3d of the triangle's corners and the
//    point. A cyclic relabelling of the axes leaves orient3d unchanged, so
//    its sign says whether the point lies above (larger coordinate k) or
//    below the triangle's plane, once multiplied by the sign of the
//    triangle's (u, v) orientation. A point on a shared edge lies above both
//    planes or below both (the planes meet on the edge), so the
//    deterministic choice of triangle never changes the answer.
//
// Which side is the hanging wall: for a fault projected along z the block
// above it (by definition, for normal and reverse faults alike); in general
// the side the fault's upward normal points to. `hanging_sign` (+1 or -1)
// says whether that is the +k side; the caller knows it from the fault's
// orientation (+1 for k = 2).
//
// Beyond the surface. A point whose projection falls in no triangle, or in a
// triangle outside the fault's `extent` (an optional per-triangle mask: e.g.
// a skirt of triangles that continues the surface beyond its data), is
// beyond the fault's extent (side kBeyondFault). `extended` still tells the
// side relative to the surface continued past its edges: the located
// triangle's plane, or for a point in no triangle the plane of the triangle
// owning the nearest boundary edge (in the projection) -- the same
// continuation the surface-cutting baseline (cutting.hpp) uses.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace faultmesh {

// Side codes.
constexpr std::int8_t kHangingWall = 1;
constexpr std::int8_t kFootwall = -1;
constexpr std::int8_t kOnFault = 0;
constexpr std::int8_t kBeyondFault = 2;

struct FaultSideResult {
    // Per point: kHangingWall, kFootwall or kOnFault inside the fault's
    // extent, kBeyondFault beyond it.
    std::vector<std::int8_t> side;
    // Per point: the side relative to the surface continued past its edges
    // (never kBeyondFault; equal to `side` inside the extent).
    std::vector<std::int8_t> extended;
    // Per point: the triangle whose plane decided `extended` (the located
    // triangle, or the owner of the nearest boundary edge), and whether the
    // point was located in a triangle at all.
    std::vector<std::int64_t> triangle;
    std::vector<std::uint8_t> located;
};

namespace detail {
class ProjectedFault;
}

// The fault TIN of fault_side() set up once (projection, AABB tree, boundary
// edges) for many queries: a derivation asks for the sides of a few dozen
// points at a time, hundreds of times per fault, and setting up a tree of
// thousands of triangles per call was most of its time. It keeps its own
// copies of the vertices, triangles and extent; queries are const and may
// run concurrently. Checks and exceptions as fault_side().
class FaultSide {
public:
    FaultSide(const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
              std::size_t n_triangles, int axis, int hanging_sign, const std::uint8_t* extent = nullptr);
    ~FaultSide();
    FaultSide(FaultSide&&) noexcept;
    FaultSide& operator=(FaultSide&&) noexcept;
    FaultSide(const FaultSide&) = delete;
    FaultSide& operator=(const FaultSide&) = delete;

    // Sides of n_points points (x, y, z interleaved; coordinates checked).
    FaultSideResult sides(const double* points, std::size_t n_points) const;
    std::size_t n_triangles() const;

private:
    // `fn` names the caller in the messages of the input checks.
    FaultSide(const char* fn, const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
              std::size_t n_triangles, int axis, int hanging_sign, const std::uint8_t* extent);
    FaultSideResult query(const double* points, std::size_t n_points) const;
    friend FaultSideResult fault_side(const double*, std::size_t, const std::int64_t*, std::size_t, const double*,
                                      std::size_t, int, int, const std::uint8_t*);

    std::unique_ptr<detail::ProjectedFault> fault_;
    std::vector<std::uint8_t> extent_;  // empty: every triangle inside
    int hanging_sign_ = 1;
    int axis_ = 2;
};

// Sides of n_points points (x, y, z interleaved) relative to the fault TIN
// (n_vertices vertices x, y, z interleaved; n_triangles triangles, 3 vertex
// indices each, any orientation). `extent` is null (every triangle is inside
// the fault's extent) or one byte per triangle (non-zero = inside).
// Triangles whose projection has zero area (vertical in the projection)
// carry no side and are skipped. Throws std::invalid_argument for an axis
// other than 0, 1, 2, a hanging_sign other than +-1, an index out of range or
// a non-finite coordinate (naming the row), and GeometryError if no triangle
// has a non-zero projected area. Work: O(n_triangles log n_triangles) for the
// tree, then per point a tree walk; a point in no triangle also scans the
// boundary edges. (FaultSide(...).sides(...): the same, set up once.)
FaultSideResult fault_side(const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
                           std::size_t n_triangles, const double* points, std::size_t n_points, int axis,
                           int hanging_sign, const std::uint8_t* extent = nullptr);

}  // namespace faultmesh
