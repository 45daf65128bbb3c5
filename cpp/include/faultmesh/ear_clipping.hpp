// faultmesh/ear_clipping.hpp -- triangulation of polygons with holes by ear
// clipping (paper section 2.6; Eberly, "Triangulation by Ear Clipping", 2008),
// with a quality ear order and an optional constrained-Delaunay refinement.
//
// Pipeline:
//  1. Rings are read as vertex loops. Consecutive duplicate points (and a
//     closing point equal to the first) are dropped; the outer ring is made
//     counter-clockwise and the holes clockwise, whatever their input order.
//  2. Holes are joined to the outer ring by bridges between mutually visible
//     vertices (paper 2.6.1/2.6.2): two coincident, opposite edges make one
//     weakly simple polygon. BridgeMethod::extreme_point first tries the
//     paper's preference (min/max X/Y vertices of the hole and of the outer
//     polygon, sliding a few vertices along both rings), then falls back to
//     Eberly's ray method (Appendix). BridgeMethod::eberly uses Eberly only.
//     Holes are joined in order of decreasing maximum x (Eberly). Every
//     visibility decision uses the exact orient2d.
//  3. Ear clipping on a doubly linked list, with a uniform grid over the
//     reflex vertices for the "no vertex inside the ear" test.
//     EarOrder::plain clips ears in Eberly's order (walk the ring, clip the
//     first ear found). EarOrder::quality keeps the ears in a priority queue
//     keyed by the ear's minimum angle (a cheap, monotone proxy of it) and
//     always clips the best ear first.
//  4. refine = true: Lawson flips with the exact incircle test until every
//     edge that is not a polygon edge is locally Delaunay. The polygon edges
//     (ring edges) are constrained; no vertex is added. The result is the
//     constrained Delaunay triangulation (CDT) of the polygon. Exactly
//     cocircular quadrilaterals are decided by the symbolic perturbation CGAL
//     uses (points ordered lexicographically by (x, y)), so the result is
//     unique and equals CGAL's Constrained_Delaunay_triangulation_2.
//
// Triangle count: a valid polygon (see check_polygon) with n vertices (after
// dropping consecutive duplicates, counted per ring occurrence) and h holes
// gives exactly n + 2h - 2 triangles, none of zero area.
//
// Invalid input (self-intersecting rings, holes outside the outer ring, holes
// overlapping each other, degenerate rings): by default a best-effort
// triangulation without crash -- every triangle has vertices of the input,
// the loop always terminates, but the triangles may not cover the region
// exactly. The fallbacks (none of which runs on valid input): when ring
// vertices coincide, the tips of zero-width spikes (a ring running out and
// straight back) are dropped before holes are joined; a hole that no
// visible bridge reaches is left out if it lies wholly outside the region
// (e.g. inside another hole), else bridged anyway to Eberly's candidate, and
// the ear order then defers ears whose diagonal crosses an edge; opposite
// coincident edge pairs (rings touching along edges) are cut out; a loop of
// zero area (edges cancelling in pairs, exact test) is dropped; and when no
// ear is left: vertices bounding no area are dropped, a local twist of a
// self-crossing ring is cut off, the loop is split along an inside diagonal,
// and only then a vertex is removed anyway. On mapbox/earcut's test fixtures
// this keeps the area deviation within earcut's own listed errors (all
// three modes). With EarClipOptions::strict = true the input is
// checked first (check_polygon) and a GeometryError names the ring and vertex
// of the first defect found. Malformed arguments (negative or decreasing
// offsets, indices out of range, non-finite coordinates) always throw
// std::invalid_argument.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace faultmesh {

enum class BridgeMethod {
    extreme_point,  // the paper's extreme-point preference, Eberly as the fallback
    eberly,         // Eberly's ray method only (Appendix of the paper)
};

enum class EarOrder {
    plain,    // Eberly's order: walk the ring, clip the first ear found (the paper's)
    quality,  // priority queue: clip the ear with the largest minimum angle first
};

struct EarClipOptions {
    bool refine = true;  // constrained-Delaunay Lawson flips after clipping
    EarOrder order = EarOrder::quality;
    BridgeMethod bridge = BridgeMethod::extreme_point;
    bool strict = false;  // check validity first; GeometryError on invalid input
    // Plain order only: on input that looks valid (no coincident ring
    // vertices, every hole bridged), a joined loop of at least split_min
    // vertices is split along a diagonal inside the polygon into two parts
    // of 40-60% each, clipped concurrently (0, or below 4: never split).
    // If no such diagonal is found among a few candidates, or a part needs
    // the fallbacks of invalid input, the loop is clipped whole.
    std::size_t split_min = 4096;
    // 0: the second part on another thread when the machine has more than
    // one core; 1: both parts on the calling thread. The triangles are the
    // same either way.
    int threads = 0;
};

// Triangulate a polygon with holes given as coordinates.
//   xy           : interleaved x, y of all rings concatenated (outer first, then holes)
//   ring_offsets : n_rings + 1 non-decreasing offsets into the points, ring_offsets[0] == 0
// Returns 3 indices per triangle into the concatenated points, counter-clockwise.
// A polygon with fewer than 3 distinct non-collinear outer vertices gives no triangles.
std::vector<std::int64_t> triangulate_polygon(const double* xy, const std::int64_t* ring_offsets,
                                              std::size_t n_rings,
                                              const EarClipOptions& options = {});

// Same, with rings given as vertex-index loops into a shared point array
// (what stitching has: boundary loops of a TIN). xy has n_points points;
// ring_vertices[ring_offsets[r] .. ring_offsets[r+1]) is ring r. Returns
// indices into xy. Two different indices may carry identical coordinates
// (touching rings); an index may appear in several rings.
std::vector<std::int64_t> triangulate_polygon_indexed(const double* xy, std::size_t n_points,
                                                      const std::int64_t* ring_vertices,
                                                      const std::int64_t* ring_offsets,
                                                      std::size_t n_rings,
                                                      const EarClipOptions& options = {});

// The hole joining alone (paper 2.6.1/2.6.2). Returns one closed loop of
// vertex indices (into xy; the first vertex is not repeated at the end),
// counter-clockwise, in which every bridge endpoint appears twice, plus the
// bridges themselves as (outer-side vertex, hole vertex) pairs in the order
// they were made. A hole that touches the outer list at a point is joined
// there without a bridge; that pair has both ends at the same position. Rings that cannot be bridged (e.g. a hole outside the
// outer ring) are left out and listed in `skipped_rings`.
struct JoinedPolygon {
    std::vector<std::int64_t> loop;
    std::vector<std::int64_t> bridges;        // 2 per bridge: outer-side vertex, hole vertex
    std::vector<std::int64_t> skipped_rings;  // ring numbers (1 = first hole) left out
};
JoinedPolygon join_holes(const double* xy, std::size_t n_points, const std::int64_t* ring_vertices,
                         const std::int64_t* ring_offsets, std::size_t n_rings,
                         BridgeMethod method = BridgeMethod::extreme_point);

// Validity of a polygon with holes, as used by `strict` and by the tests to
// decide which polygons must give exactly n + 2h - 2 triangles. Valid means:
// every ring has at least 3 vertices (after dropping consecutive duplicates)
// and non-zero area; the rings are strictly simple and disjoint: two edges
// meet only if they are consecutive edges of one ring, at their common
// vertex (so touching rings, pinched rings and vertices on edges are invalid:
// they are triangulated, but their triangle count is not n + 2h - 2); every
// hole lies inside the outer ring and outside every other hole. ring_vertices may be null
// (rings are then the concatenated points, as in triangulate_polygon).
struct PolygonCheck {
    bool valid = true;
    std::int64_t ring = -1;    // ring of the first defect found (0 = outer)
    std::int64_t vertex = -1;  // index into xy of a vertex at that defect
    std::string message;       // empty if valid
};
PolygonCheck check_polygon(const double* xy, std::size_t n_points, const std::int64_t* ring_vertices,
                           const std::int64_t* ring_offsets, std::size_t n_rings);

}  // namespace faultmesh
