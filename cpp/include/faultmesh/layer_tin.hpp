// faultmesh/layer_tin.hpp -- the continuous stratum TIN of one layer over the
// whole study area (docs/design.md §4.4; paper 2.3), and the
// layer-crossing repair between two of them (paper 3.2, Figure 6).
//
// A LayerTin is the Delaunay TIN (tin.hpp) of the layer's data points plus
// vertices on the study-area boundary, so that the layer covers the whole
// study area and its outer boundary IS the study-area polygon:
//
//  * Data points outside the study area are not used (counted); points on
//    its boundary (StudyArea::locate) become boundary vertices with their z.
//  * Each side is densified at about the data spacing (points placed on the
//    side by StudyArea::place). Their z comes from an inverse-distance
//    weighted local plane fit to the nearest data points (the regional dip
//    is carried to the boundary), clamped to the data range widened by half
//    of it plus 1 m, so an extrapolation never runs away. Along each
//    principal axis of the neighbours' spread, the fit's slope is followed
//    for three standard deviations of that spread and past them gives way,
//    in proportion to the distance, to the layer's regional slope (the
//    least-squares plane of all its data, cell-declustered at the boundary
//    spacing): a clump of picks along a line far from the boundary (a
//    fault's step across it) does not set the slope across the line a
//    kilometre out, nor do collinear neighbours. A layer whose data all lie
//    on one line has no regional slope: collinear neighbours then give
//    their inverse-distance weighted mean.
//  * Protection: a boundary piece (two consecutive boundary vertices) whose
//    closed diametral disk holds another vertex is split at its middle
//    (placed on its side; a piece at a corner whose sides meet at less than
//    90 degrees at a power of two from that corner, so that the splitting
//    ends), until none does; each split point has the pieces it may lie in
//    tested again. A segment whose closed diametral
//    disk holds no other point is an edge of every Delaunay triangulation of
//    the points, so every piece is a TIN edge, even for a non-convex area;
//    the triangles outside the polygon (its notches) are then left out of
//    mesh(). insert() keeps the protection for the new points.
//
// repair_crossings(upper, lower) makes lower lie nowhere above upper:
//  * rule 1: a lower vertex above the upper surface takes its elevation;
//  * rule 1b (Figure 6b, "supplementing drilling data"): where an upper
//    vertex lies below the lower surface, lower receives a point there at
//    the upper elevation;
//  * rule 2: a lower edge that rises above the upper surface between its
//    ends -- found at its crossings with the upper TIN's edges, where the
//    difference of two piecewise-linear surfaces along a segment can peak --
//    gets its midpoint inserted (at the lower of the two elevations); after
//    `midpoint_rounds` rounds the crossing point of largest violation itself
//    (on the upper edge, at the upper elevation), which ends the halving
//    where the upper surface is convex across an edge.
//  Repeated until nothing changes. Each round after the first looks only at
//  what the previous round changed (the edges of inserted or lowered
//  vertices: a Delaunay insertion only creates edges at the new vertex).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <faultmesh/study_area.hpp>
#include <faultmesh/tin.hpp>

namespace faultmesh {

struct LayerTinOptions {
    // Boundary vertex spacing; <= 0: sqrt(study area / number of data points),
    // clamped to [perimeter / 4000, perimeter / 12].
    double spacing = 0.0;
    // Nearest data points of the boundary plane fits.
    int plane_fit_neighbours = 12;
};

struct LayerTinMesh {
    std::vector<double> vertices;         // 3 per vertex (current elevations)
    std::vector<std::int64_t> triangles;  // 3 per triangle, CCW, inside the study area
    std::vector<std::int64_t> halfedges;  // opposite half-edge within the mesh or -1
    std::vector<std::int64_t> tin_vertex; // mesh vertex -> LayerTin vertex
    std::vector<char> measured;           // per mesh vertex: LayerTin::measured()
};

namespace detail {
struct LayerTinState;
}

class LayerTin {
public:
    // data: n points (x, y, z). Throws std::invalid_argument for a non-finite
    // value (naming the point) and GeometryError when no data point lies in
    // the study area.
    LayerTin(std::string name, const double* data, std::size_t n, const StudyArea& area,
             const LayerTinOptions& options = {});
    ~LayerTin();
    LayerTin(LayerTin&&) noexcept;
    LayerTin& operator=(LayerTin&&) noexcept;
    LayerTin(const LayerTin&);
    LayerTin& operator=(const LayerTin&);

    const std::string& name() const;
    const StudyArea& area() const;
    double spacing() const;
    std::size_t n_data() const;          // data points used (inside or on the study area)
    std::size_t n_outside() const;       // data points dropped (outside the study area)
    std::size_t n_boundary_data() const; // data points that became boundary vertices
    std::size_t n_vertices() const;
    // Vertices that came from the triangulation shared with other layers
    // (build_layer_tins); 0 for a LayerTin built alone.
    std::size_t n_shared() const;
    const Tin& tin() const;
    // Current elevations of the TIN vertices (the repair changes them).
    std::vector<double> z() const;
    // Boundary vertices in order (counter-clockwise along the study area).
    std::vector<std::int64_t> boundary_vertices() const;
    // Per vertex: 1 where the vertex is a data point at its measured z (in
    // the study area or on its boundary), 0 where the TIN made it or set its
    // z -- the boundary densification (z extrapolated), the protection's
    // splits, points added by insert() (the repair's rule 1b and rule 2
    // points, hole fill points) and vertices whose z set_z() or insert()
    // changed (the repair's rule 1). The stitcher puts back only these
    // into a gap (stitch.hpp, step 5).
    std::vector<char> measured() const;

    // Inserts points (x, y, z), keeping the boundary protected. A point at the
    // XY of an existing vertex gives that vertex its z; so does a point on
    // the boundary within 1e-9 of the perimeter of a boundary vertex (or of
    // an earlier point of the call) along its side. Returns the number of
    // new vertices. as_data: the points are data (measured(), and the
    // stitcher puts them back into a gap), e.g. data left out of the TIN
    // for a fault patch that in the end does not cover them; n_data()
    // counts those of the constructor only.
    std::size_t insert(const double* xyz, std::size_t n, bool as_data = false);
    // Sets the elevation of vertices.
    void set_z(const std::int64_t* vertices, const double* z, std::size_t n);
    // z at n points (x, y interleaved), NaN outside the TIN's hull; a point
    // on the study-area boundary (StudyArea::locate), also one that rounding
    // puts a hair outside the hull, gets the elevation of the boundary piece
    // it lies on (linear along the side).
    std::vector<double> interpolate(const double* xy, std::size_t n) const;
    // The triangles inside the study area, compacted; the arrays reserve room
    // for spare_vertices and spare_triangles more (a stitcher appends).
    LayerTinMesh mesh(std::size_t spare_vertices = 0, std::size_t spare_triangles = 0) const;

private:
    explicit LayerTin(std::unique_ptr<detail::LayerTinState> s);
    std::unique_ptr<detail::LayerTinState> s_;
    friend struct RepairCounts repair_crossings(const LayerTin&, LayerTin&, const struct RepairOptions&);
    friend bool layers_apart(const LayerTin&, const LayerTin&, const struct RepairOptions&);
    friend std::vector<LayerTin> build_layer_tins(const std::vector<struct LayerTinInput>&, const StudyArea&,
                                                  const LayerTinOptions&, unsigned);
};

// One layer's data for build_layer_tins: n points (x, y, z) at data, read
// during the call only.
struct LayerTinInput {
    std::string name;
    const double* data = nullptr;
    std::size_t n = 0;
};

// The LayerTins of several layers over one study area (step 2 for a whole
// stack), each exactly as the constructor would build it alone (the same
// vertices, elevations and triangles; only the vertex numbering may differ),
// and the same errors. Layers measured at the same places -- the tops of one
// set of boreholes, horizons picked on one seismic grid -- share most of
// their XY points, and a Delaunay triangulation depends on XY alone: the
// interior points that all of them have are triangulated once, and each such
// layer's TIN is a copy of that triangulation with its own elevations and its
// other points (boundary vertices, points only it has) inserted. Layers that
// share less than three quarters of their points are built alone.
// threads > 1: the layers are sorted out and set up on up to that many
// threads (the result does not depend on it; an error is the one of the
// first failing layer, as with one thread).
std::vector<LayerTin> build_layer_tins(const std::vector<LayerTinInput>& layers, const StudyArea& area,
                                       const LayerTinOptions& options = {}, unsigned threads = 1);

struct RepairOptions {
    // Rounds before the repair gives up (GeometryError): the guard against a
    // repair that never ends (the insertion budget below bounds its points).
    // A round after the first looks only at what the last one changed, so a
    // long tail costs little: stress ground 69 (a reverse fault of 106 m over
    // layers 3.7-13 m thick) ends its L6/L7 repair in 85 rounds, 1 s, 31.7k
    // points (its other pairs 14-38 rounds; stress grounds 20, 27, 30 and 44
    // at most 22).
    int max_rounds = 200;
    int midpoint_rounds = 8;
    // Elevations are compared after interpolation, which errs by a few ulps
    // of |z|; < 0: 1e-9 of the elevation scale (1e-6 m at 1 km), far above
    // that rounding and far below any geological thickness.
    double tolerance = -1.0;
    // The repair refuses the pair (GeometryError) when, before it, the lower
    // layer's data points (at their measured z) lie above the upper surface
    // at more than this share of them: the layers are in the wrong order
    // (two layers the wrong way round lie so at all their data but where
    // they touch). Layers that cross only where one carries a fault's offset
    // that the other does not stay under it: the stress grounds whose
    // repairs converge have 6-35 % of the lower layer's vertices above the
    // upper (35 %: a reverse fault of 99 m over layers 5 and 8 m thick).
    double max_above_fraction = 0.5;
    // The repair gives up (GeometryError) when it has inserted more than this
    // many points per vertex the two layers have (the lower at the start, the
    // upper as it is; and more than 10000): a runaway refinement. Layers that
    // cross where one carries a fault's offset and the other does not need
    // up to 14.4 (the stress grounds that build: 1.6 for thin layers under a
    // throw of 74 m, 6.7 and 14.4 where the upper layers' data show no
    // offset); a wrong order about 80, which max_above_fraction refuses
    // first.
    double max_inserted_per_vertex = 32.0;
};

struct RepairCounts {
    std::int64_t rule1 = 0;           // lower vertices lowered
    std::int64_t rule1b = 0;          // points supplemented under upper vertices
    std::int64_t rule2 = 0;           // edge midpoints inserted
    std::int64_t rule2_crossing = 0;  // crossing points inserted
    std::int64_t rounds = 0;
    std::int64_t data_above = 0;      // lower data points above the upper surface before the repair
    double max_lowered = 0.0;         // the largest lowering of a lower vertex by rule 1 (m)
    // The largest lowering of a lower data point (m): the most by which the
    // repaired layer misses one of its data (each of the data_above is moved
    // down onto the upper surface).
    double max_data_lowered = 0.0;
};

// Make `lower` lie nowhere above `upper` (see the file comment). Throws
// GeometryError if crossings remain after max_rounds rounds or the insertion
// budget is spent.
RepairCounts repair_crossings(const LayerTin& upper, LayerTin& lower, const RepairOptions& options = {});

// The repair's first test alone: true when lower lies below upper by more
// than the tolerance everywhere, as their per-cell elevation bounds show
// (then repair_crossings changes nothing). Reads both layers only.
bool layers_apart(const LayerTin& upper, const LayerTin& lower, const RepairOptions& options = {});

// repair_crossings down a stack (stack[i] over stack[i + 1]), with the same
// result as pair after pair: the first test of every pair runs at once, on
// up to `threads` threads, and the full repair, top down, only where a pair
// is not apart or its upper layer was just changed.
std::vector<RepairCounts> repair_stack(const std::vector<LayerTin*>& stack, const RepairOptions& options = {},
                                       unsigned threads = 1);

}  // namespace faultmesh
