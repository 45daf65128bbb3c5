// faultmesh/overlap.hpp -- overlap detection between a layer TIN and a region
// R in XY (paper section 2.4), and growth of the removed set into a
// topological disk (docs/design.md §4.7, steps 2 and 3).
//
// The region R is given as closed rings (interleaved x, y; ring r is the
// points ring_offsets[r] .. ring_offsets[r+1]; the first point is not
// repeated, a repeated closing point is ignored, as are consecutive duplicate
// points). Its interior is defined by the even-odd (parity) rule, so "outer +
// holes" and "several outers" both work whatever the rings' orientations.
// Ring edges are normalised first: every edge is split at the ring vertices
// lying in its relative interior and equal edges cancel in pairs (an edge
// traversed twice, e.g. two outers sharing a side or a slit, is not a
// boundary). What is left is the boundary dR; R's interior R° is the open set
// of points off dR with odd crossing parity, plus the points of cancelled
// edges between two odd sides.
//
// Two predicates decide whether a triangle overlaps R (OverlapPredicate):
//
// open_interior (the paper's test, the default): a triangle overlaps R iff
// its open interior meets R° -- touching R only along an edge or at a vertex
// does not count. Stage 1 takes the AABB-tree candidates (triangle box meets
// the rings' box); stage 2 decides each candidate exactly with orient2d only
// (no constructed points):
//   (a) some edge of dR meets the open triangle (segment/triangle test), or
//   (b) otherwise the triangle's interior lies in one face of the arrangement
//       of dR; its parity is the parity of the wedge of the triangle at a
//       vertex v: a PNPoly crossing count with the half-open rule for the
//       point just above the +x ray from v, corrected by the number of dR
//       edges leaving v between the +x direction and the triangle's wedge.
//       This is exact also when every vertex of the triangle lies on dR
//       (triangles whose vertices are the region's own vertices).
// Degenerate (zero-area) triangles have no interior and never overlap.
//
// closed_contact (the stitcher's test, triangles_touching_region): a
// triangle overlaps R iff the CLOSED triangle (any orientation; a degenerate
// one is the union of its edges) meets the closed region: R°, dR and every
// drawn ring edge or point (a cancelled edge or a one-point ring counts too).
// A removed set made of these triangles contains R strictly: no edge of its
// boundary touches R (a triangle across such an edge would touch R too),
// except along the mesh boundary.
//
// grow_to_disk: the removed set S is grown by neighbouring triangles until it
// is a topological disk that strictly contains R:
//   * no edge of S's boundary (closed segment) meets the closure of R
//     (a region vertex on S's boundary forces growth);
//   * S is edge-connected (components are joined by shortest dual paths);
//   * no island: every component of the kept triangles reaches the mesh
//     boundary (enclosed kept components are absorbed);
//   * no pinch vertex: around every vertex, S and the kept triangles are
//     each at most one fan (the smaller gaps are absorbed).
// The loop repeats until nothing changes; the result is then verified
// (Euler characteristic 1, one boundary loop) and a GeometryError is thrown
// if it cannot be a disk (e.g. R surrounds a hole of the mesh).
// If S would reach the mesh boundary (paper: fault F22 at the study-area
// boundary) a strict disk is impossible: a GeometryError is thrown unless
// allow_mesh_boundary is set, in which case S may contain mesh-boundary
// edges and vertices, R may touch S's boundary only along the mesh boundary,
// and the kept triangles must stay one edge-connected, pinch-free piece
// (kept components other than the largest are absorbed).
// These are the paper's growth rules of the library's one grower
// (cpp/src/overlap_growth.hpp); the stitcher runs the same grower with its
// own rules (stitch.hpp, step 3).
//
// The mesh must be manifold for grow_to_disk (every edge in at most two
// triangles, triangles of any orientation); otherwise a GeometryError names
// the edge (triangle_adjacency.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <faultmesh/aabb_tree.hpp>

namespace faultmesh {

enum class OverlapPredicate {
    open_interior,   // the open triangle meets R's interior (paper 2.4)
    closed_contact,  // the closed triangle meets the closed region (stitcher)
};

struct OverlapOptions {
    bool grow_to_disk = false;
    bool allow_mesh_boundary = false;
    OverlapPredicate predicate = OverlapPredicate::open_interior;
};

// Sorted indices of the triangles that overlap R by options.predicate (grown
// into a disk when options.grow_to_disk).
//   vertices  : n_vertices points, `stride` doubles each (2 or 3; z ignored)
//   triangles : n_triangles x 3 vertex indices (any orientation)
// Throws std::invalid_argument for indices out of range, non-finite
// coordinates of used vertices, bad ring offsets; GeometryError as above.
std::vector<std::int64_t> overlapping_triangles(const double* vertices, std::size_t n_vertices,
                                                std::size_t stride, const std::int64_t* triangles,
                                                std::size_t n_triangles, const double* ring_xy,
                                                const std::int64_t* ring_offsets,
                                                std::size_t n_rings,
                                                const OverlapOptions& options = {});

// Same with a prebuilt tree over the same triangles (AabbTree::from_triangles),
// for many regions against one layer.
std::vector<std::int64_t> overlapping_triangles(const AabbTree& tree, const double* vertices,
                                                std::size_t n_vertices, std::size_t stride,
                                                const std::int64_t* triangles,
                                                std::size_t n_triangles, const double* ring_xy,
                                                const std::int64_t* ring_offsets,
                                                std::size_t n_rings,
                                                const OverlapOptions& options = {});

// The exact stage-2 predicate for one triangle, by brute force over all ring
// edges (no tree, O(ring edges)); used by the tests as the reference and
// usable on its own. True iff the open triangle (a, b, c) meets R°.
bool triangle_overlaps_region(const double* a, const double* b, const double* c,
                              const double* ring_xy, const std::int64_t* ring_offsets,
                              std::size_t n_rings);

}  // namespace faultmesh
