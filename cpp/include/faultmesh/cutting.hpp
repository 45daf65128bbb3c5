// faultmesh/cutting.hpp -- the surface-cutting baseline of the paper's
// comparison (section 4.1.1, Tables 1 and 2): a continuous layer TIN is cut
// along its intersection line with a fault surface, the cut triangles are
// re-triangulated with the intersection line as a constraint, and the
// hanging-wall side of the line is moved by the fault's displacement (the
// GeoSIS / GOCAD-style "cut, then slide" workflow the paper compares against).
// It is a baseline for comparison, not the modelling method of faultmesh.
//
// Sides. The layer is a height field z = L(x, y); the fault surface F is a
// triangulated surface that is a height field over its XY projection (any
// dipping, non-overturned fault; a vertical fault has no projection and is
// not cut). A layer vertex u is on the hanging wall iff it lies strictly
// above the fault: d(u) = u.z - F(u.x, u.y) > 0 (by definition the hanging
// wall is the block above a dipping fault, for normal and reverse faults
// alike); d(u) <= 0 is the footwall, so a vertex exactly on the fault is a
// footwall vertex -- one fixed tie rule, so the topology below is decided by
// the vertex signs alone and is always consistent. F(x, y) is linear
// interpolation in the fault triangle containing (x, y) (point location with
// the AABB tree and the exact orient2d); outside F's projection it is the
// plane of the fault triangle owning the nearest boundary edge of F, so
// vertices a little beyond the fault's upper and lower edges still get the
// right side.
//
// Intersection line. A layer edge whose end points have different sides is
// crossed by the fault; its crossing point is the root of
// z_edge(t) - F(xy(t)) on the edge (Illinois regula falsi on the piecewise
// linear function, bracketed by the end-point signs), moved at least
// min_edge_fraction of the edge length away from both end points so that no
// zero-length edge is created. Its z is the layer's (the point lies on the
// layer). A crossing is active iff its point lies in F's closed XY
// projection (on the layer's boundary edges: or within CutOptions::extension
// of it): beyond the fault's lateral ends (tips) the extended planes give
// signs but the layer is not cut. A layer triangle with both of its
// sign-change edges active is cut (the affected set R); the line through it
// is the segment between its two crossing points. Consecutive cut triangles
// share a crossing edge, so the segments form chains: the intersection
// polylines, with one point on every layer edge the fault crosses (the
// layer-resolution intersection line of the cutting methods; bends of the
// exact curve inside a layer triangle are not represented).
//
// Chain ends. A chain ends on a layer boundary edge (the fault reaches the
// study-area boundary, paper F22) or on an edge whose other triangle is not
// cut (the fault's tip). At a tip the end point is one vertex shared by both
// walls (zero displacement) and the uncut triangle beyond it is split in two
// at that point so that the mesh stays conforming (no T-junction). Every
// other line point is two vertices with the same XY: a footwall copy at the
// layer's z and a hanging-wall copy at z + displacement * w, where the taper
// weight w is min(1, s / taper_length) for the XY arc length s to the
// nearest tip of its chain (w = 1 without a tip or with taper_length <= 0).
//
// Re-triangulation. Each edge-connected component of R must be a topological
// disk (one boundary loop; pinch vertices are fine). Its boundary loop and
// the chains that cross it split it into faces; every face is a simple
// polygon whose vertices are R's boundary vertices and the line copies of its
// own wall, and is triangulated by triangulate_polygon (ear clipping, and with
// EarClipOptions::refine the constrained-Delaunay flips: the result is the
// CDT of the face, the intersection line being a constraint). Only the
// triangles whose XY box meets the fault's XY box are examined and only their
// vertices classified; the whole-mesh work is one scan of the triangles'
// boxes and the copy into the result (a baseline, not tuned for scale).
//
// Errors: std::invalid_argument for indices out of range or non-finite
// coordinates (naming the argument and row); GeometryError for a layer
// triangle near the fault that is not counter-clockwise, a non-manifold layer
// edge, an intersection line that closes on itself, or a cut region that
// encloses uncut triangles (the line winds around them).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <faultmesh/ear_clipping.hpp>

namespace faultmesh {

struct CutOptions {
    // Added to z of every hanging-wall copy of a line point (times its taper
    // weight): negative moves the hanging wall down (a normal fault's throw),
    // positive up (reverse).
    double displacement = 0.0;
    // Length (XY, model units) over which the displacement grows from 0 at a
    // tip to its full value; <= 0: full displacement at every non-tip point.
    double taper_length = 0.0;
    // Crossing points are kept at least this fraction of the edge length away
    // from the edge's end points (1e-3: the point moves by at most 0.1 % of
    // the edge, and no edge shorter than that is created).
    double min_edge_fraction = 1e-3;
    // A crossing point on a boundary edge of the layer (the study-area
    // boundary) that lies outside the fault's XY projection but within this
    // XY distance of it is active too (the fault continued by the planes of
    // its boundary triangles): a fault surface that ends just short of the
    // study-area boundary, or does not reach the layer's depth there, still
    // cuts the layer up to the boundary. Line ends inside the layer (tips)
    // are not affected. 0: the projection only.
    double extension = 0.0;
    // How each face is triangulated (default: quality ear order + CDT flips).
    EarClipOptions triangulation{};
};

struct CutResult {
    // 3 per vertex: the input vertices unchanged, then the new line vertices.
    std::vector<double> vertices;
    // 3 per triangle, counter-clockwise: the kept input triangles in input
    // order, then the n_created new ones (the last n_created rows).
    std::vector<std::int64_t> triangles;
    std::size_t n_created = 0;
    // Sorted input rows that were replaced: the cut triangles and the tip
    // triangles split in two.
    std::vector<std::int64_t> removed;
    // Sorted input rows of the tip triangles (a subset of removed).
    std::vector<std::int64_t> split;
    // The intersection polylines (CSR): chain c is positions
    // line_offsets[c] .. line_offsets[c+1] of the arrays below, oriented so
    // that the hanging wall is on the left in XY.
    std::vector<std::int64_t> line_offsets;
    std::vector<std::int64_t> footwall_line;  // vertex of the footwall copy
    std::vector<std::int64_t> hanging_line;   // vertex of the hanging-wall copy (== footwall at a tip)
    std::vector<double> line_weight;          // taper weight of the point
    // Diagnostics: layer triangles examined (XY box meets the fault's) and
    // layer vertices whose side was computed.
    std::size_t n_examined_triangles = 0;
    std::size_t n_classified_vertices = 0;
};

// Cut one layer TIN by one fault surface (see above).
//   layer_xyz : n_layer_vertices points, x y z interleaved
//   layer_triangles : n_layer_triangles x 3 vertex indices, counter-clockwise in XY
//   fault_xyz, fault_triangles : the fault surface, any orientation
// A fault that does not cross the layer gives the input back unchanged.
CutResult cut_layer(const double* layer_xyz, std::size_t n_layer_vertices,
                    const std::int64_t* layer_triangles, std::size_t n_layer_triangles,
                    const double* fault_xyz, std::size_t n_fault_vertices,
                    const std::int64_t* fault_triangles, std::size_t n_fault_triangles,
                    const CutOptions& options = {});

}  // namespace faultmesh
