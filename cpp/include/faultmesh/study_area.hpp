// faultmesh/study_area.hpp -- the study-area polygon and points on its boundary.
//
// Every part of the model meets the study-area boundary: the layer TINs end
// on it, a fault that runs across the area (the paper's F22) has its patch
// ends on it, data written by a surveyor lie on it up to rounding. They must
// all agree on which points lie on the boundary and where. StudyArea is the
// one place that decides it:
//
//  * locate(p): the sides p lies on. A point counts as on a side when it is
//    exactly on it (orient2d == 0 inside the side's box) or within the
//    tolerance of it. The tolerance covers the rounding of points that were
//    constructed on a side (place(), ray_hit(), a surveyor's point snapped
//    onto the side by the loader): such a point is within a few ulps of the
//    largest coordinate of the exact side. The default, 64 ulps of the
//    largest |coordinate| (64 eps max|c|), accepts them with a wide margin
//    while a point 1e-7 m off at UTM magnitudes (7e6 m: tolerance 1e-7) is
//    already outside -- far below any survey precision.
//  * place(side, s): the point at arc length s along a side, the corners
//    exactly at s = 0 and s = length, and the constant coordinate exact on
//    axis-parallel sides (a + u (b - a) with b - a = 0 in that coordinate).
//    Points the builder makes on the boundary (ends of traces carried to the
//    boundary, densified sides) are made here, never by p + t d.
//  * ray_hit(p, d): where the ray from p along d first meets the boundary;
//    which sides it crosses is decided by exact orientations of the side's
//    ends against the ray's line, and the hit is placed with place().
//  * contains(p): inside or on the boundary (exact winding, or locate()).
//
// The ring is stored counter-clockwise; side i runs from corner i to corner
// i + 1 (mod k). Arc positions run from corner 0 along the sides.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <faultmesh/aabb_tree.hpp>

namespace faultmesh {

class StudyArea {
public:
    struct Hit {
        std::size_t side = 0;
        double s = 0.0;  // arc length along the side, in [0, side_length(side)]
    };
    struct RayHit {
        double t = 0.0;  // p + t d is the hit; infinity when the ray misses
        std::size_t side = 0;
        double s = 0.0;
    };
    struct Nearest {
        bool found = false;  // a side within the search distance
        std::size_t side = 0;
        double s = 0.0;
        double distance = 0.0;
    };

    StudyArea() = default;
    // xy: k points (x, y) of a simple polygon, either orientation, closing
    // point optional, consecutive repeats dropped. tolerance < 0: the default
    // (64 eps max|coordinate|). Throws std::invalid_argument for fewer than
    // 3 distinct points or non-finite coordinates, GeometryError for zero area.
    StudyArea(const double* xy, std::size_t k, double tolerance = -1.0);

    std::size_t n_sides() const { return len_.size(); }
    const std::vector<double>& ring() const { return xy_; }  // CCW, 2 per corner
    const double* corner(std::size_t i) const { return xy_.data() + 2 * (i % n_sides()); }
    double side_length(std::size_t i) const { return len_[i]; }
    double perimeter() const { return cum_.back(); }
    // Arc length from corner 0 to corner i (i = n_sides() gives the perimeter).
    double side_start(std::size_t i) const { return cum_[i]; }
    double tolerance() const { return tol_; }

    // Arc position of a hit along the whole boundary, in [0, perimeter).
    double arc_position(const Hit& h) const;
    // Every side that p lies on (see the file comment); a corner gives both
    // of its sides, with s snapped to the corner.
    void locate(const double* p, std::vector<Hit>& out) const;
    bool on_boundary(const double* p) const;
    // Whether an edge whose ends have the hits ha and hb (locate) runs along
    // one side: both ends on a common side at different positions, or both
    // one XY point on it (same_xy: a vertical fault's cutoffs carried onto
    // the boundary, two vertices at one XY). The first such side's hits in
    // *on_a and *on_b. The stitcher's outline edges "on the study boundary",
    // which a folded patch carried onto it may overlap.
    static bool along_one_side(const std::vector<Hit>& ha, const std::vector<Hit>& hb, bool same_xy,
                               Hit* on_a = nullptr, Hit* on_b = nullptr);
    // Inside or on the boundary.
    bool contains(const double* p) const;
    // The point at arc length s along side (clamped to the side), in out[0..1].
    void place(std::size_t side, double s, double* out) const;
    // The nearest boundary point within max_distance of p (found = false if none).
    Nearest nearest(const double* p, double max_distance) const;
    // The first boundary point on the ray p + t d, t >= 0. A point on the
    // boundary (locate) gives t = 0 at its own position.
    RayHit ray_hit(const double* p, const double* d) const;
    // The sides whose box comes within r of p (candidates for distance tests).
    void sides_near(const double* p, double r, std::vector<std::size_t>& out) const;

private:
    std::vector<double> xy_;
    std::vector<double> len_;
    std::vector<double> cum_;
    std::vector<std::int64_t> seg_;
    double tol_ = 0.0;
    AabbTree tree_;
    // A coarse grid over the ring's box: cells no side comes within the
    // tolerance of are wholly inside (2) or wholly outside (1) -- decided once
    // at the cell's centre -- so most points are classified without touching
    // a side; 0: a side passes near, the exact tests decide.
    double gx0_ = 0.0, gy0_ = 0.0, gx1_ = 0.0, gy1_ = 0.0, gcw_ = 1.0, gch_ = 1.0;
    long gnx_ = 0, gny_ = 0;
    std::vector<std::uint8_t> cell_;
    int cell_class(const double* p) const;
    bool inside_strictly(const double* p) const;
};

// A triangulated surface (a fault's patch in one layer, possibly folded in
// XY: a reverse fault's strip runs backwards) clipped to the study area in
// XY, triangle by triangle: the part of each triangle inside the closed
// study area is kept, exactly where the boundary cuts it.
//  * Triangles wholly inside (no side meets them) are kept as they are;
//    wholly outside ones are dropped.
//  * A triangle a side crosses is cut: its boundary is split at the proper
//    crossings of its edges with the sides (exact orientations; a side that
//    an edge's end lies on -- StudyArea::locate -- does not cross that edge
//    there) and at the corners lying inside its open edges; the pieces of
//    its boundary inside the area, joined by the pieces of the study-area
//    boundary inside the triangle (with the corners there), form the
//    polygon(s) of the kept part, ear-clipped (ear_clipping.hpp).
//  * New vertices: a crossing is placed ON its side (StudyArea::place, so
//    that locate finds it) and shared by the two triangles of the edge (the
//    result stays conforming); its z is interpolated along the edge. A
//    corner inside a triangle gets the triangle's z there (one vertex per
//    triangle: the sheets of a folded patch each get their own).
// The kept triangles keep the input orientation (CW triangles of a folded
// sheet stay CW). Vertices no kept triangle uses are dropped.
// `what` names the surface in errors (GeometryError for a cut that the
// exact tests find inconsistent, naming the triangle).
struct ClippedSurface {
    std::vector<double> vertices;          // 3 per vertex
    std::vector<std::int64_t> triangles;   // 3 per triangle
    std::vector<std::int64_t> vertex_of;   // per output vertex: input vertex, or -1 for a new one
    std::size_t n_cut = 0;                 // input triangles cut (neither kept whole nor dropped)
    std::size_t n_dropped = 0;             // input triangles wholly outside
};
ClippedSurface clip_to_study_area(const StudyArea& area, const double* vertices, std::size_t n_vertices,
                                  const std::int64_t* triangles, std::size_t n_triangles,
                                  const std::string& what = "surface");

}  // namespace faultmesh
