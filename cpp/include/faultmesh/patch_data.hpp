// faultmesh/patch_data.hpp -- a layer's data honoured inside a fault patch.
//
// A fault's layer patch (faults.py: the loft of the section polylines) takes
// the place of the continuous layer TIN around the fault, and with it every
// datum of the layer that lies under the patch. Between two sections the
// loft is straight, so a datum there -- a borehole top, a horizon pick on a
// section the fault's own sections do not share -- no longer shapes the
// layer. Here each such datum becomes a vertex of the patch at its measured
// elevation, the way the TIN would have honoured it.
//
// Which sheet. A patch may fold over itself in XY (a reverse fault repeats
// the layer: footwall sheet, the strip on the fault, hanging-wall sheet), so
// a datum is placed in the triangle, among those whose closed XY projection
// holds it (exact orient2d against each edge; a datum within a micrometre
// outside an edge lies on it, as build.ON_OUTLINE has it), whose elevation
// at the datum's XY is nearest to the datum's (within a micrometre of that,
// one sheet: the triangle that takes it inside, else on an edge, then the
// lowest row).
// It is placed only if that distance is at most `max_dz`: farther, it is no
// point of this patch (e.g. a datum of another fault block) and the patch is
// left as it is there.
//
// How. Each triangle that receives data is triangulated again on its own:
// its three edges are constrained, the data inserted and flipped to the
// constrained Delaunay triangulation (gap_points.hpp), so the triangles
// around it are untouched and the patch stays conforming. New triangles keep
// the orientation (in XY) of the triangle they replace. A datum on or within
// a hundredth of the triangle's height of one of its edges goes onto that
// edge, at its projection (moved at most that far in XY), with the z that
// makes its sheet pass through the datum at the datum's own XY (on a steep
// ramp the move would otherwise cost the slope times it; where a neighbour
// on the edge is as near, its own z; where other data placed in the
// triangle stand between the new vertex and that XY, the edges between are
// flipped first, one after another, if that gives the vertex at least half
// the weight there; if not, a patch vertex of the triangle holding the XY
// that weighs half there takes the datum's z instead):
// every triangle with the edge -- on both sheets where the edge is a fold --
// is fanned from its third corner through the edge's new points (picks on a
// seismic line lie on the edges of a patch whose sections a derivation put
// on that line). A datum as near another datum placed in the same triangle
// or on the same edge (the earlier row wins) is not placed: it would make a
// sliver (patch_data.cpp, kMinShare). Nor is a datum within a hundredth of
// two edges (near a corner), or of one edge where it projects within a
// hundredth of that edge's length of its end, but the corner takes the
// first such datum:
// its z becomes the one that puts the sheet through the datum at the
// datum's own XY (its XY stays; `triangle` is -1 for that datum).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace faultmesh {

// A point within this distance (m, XY) outside a patch's outline lies on it:
// a micrometre, below any survey's precision and above the nanometre to
// which derive places the cutoffs (and the rounding of coordinates of 1e7 m,
// 2e-9 m). Which side of the outline a pick on it falls on is otherwise
// decided by the outline's last bits (random ground 2 as v2: picks on a
// seismic line where the derivation put an end section fell inside or
// outside F3's patch for cutoffs moved by 1e-10 m). The one value for the
// placement here, the build's footprint test (faultmesh.ON_OUTLINE,
// build.ON_OUTLINE) and the data fit's reach (report.DATA_REACH).
inline constexpr double kOnOutline = 1e-6;

struct PatchDataResult {
    std::vector<double> vertices;          // 3 per vertex: the patch's, then the placed data
    std::vector<std::int64_t> triangles;   // 3 per triangle: the patch's (rows kept), then new ones
    std::vector<std::int64_t> placed;      // per new vertex: the row of its datum
    // Per datum: the patch triangle (input row) it was placed in or on an
    // edge of, or -1 (not under the patch, near a vertex -- which may have
    // taken its z --, beyond max_dz, a duplicate).
    std::vector<std::int64_t> triangle;
};

// vertices: n_vertices x (x, y, z); triangles: 3 indices each; points:
// n_points x (x, y, z). max_dz >= 0 (may be +inf). Throws
// std::invalid_argument naming the argument and row for an index out of
// range, a coordinate outside the range of predicates.hpp, or a bad max_dz.
PatchDataResult insert_patch_data(const double* vertices, std::size_t n_vertices,
                                  const std::int64_t* triangles, std::size_t n_triangles,
                                  const double* points, std::size_t n_points, double max_dz);

}  // namespace faultmesh
