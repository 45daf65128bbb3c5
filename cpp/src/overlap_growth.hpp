// Internal to the library (faultmesh::detail): the region R of overlap.hpp
// with its two exact predicates, and the growth of a removed set S. One
// implementation, used by overlapping_triangles (overlap.cpp), by
// triangles_touching_region and by the stitcher (stitch_steps.hpp: the overlap
// and growth steps). overlap.hpp defines the terms; this header says how the
// rules are selected.
//
// Growth rules. Each rule adds triangles to S; a rule is on or off (or picks
// a variant) in GrowthRules:
//   grow_touching        paper: a boundary edge of S that meets the closure
//                        of R pulls in the triangle across it (R strictly
//                        inside S; needed after the open-interior predicate,
//                        a no-op after the closed-contact one);
//   join_components      paper: S's edge-connected components are joined by
//                        shortest dual paths through kept triangles;
//   pinch                keep_largest_kept_fan (paper): around a vertex of
//                        S's boundary, S and the kept triangles must each be
//                        one fan -- the smaller kept fans join S;
//                        pull_star (stitcher): a vertex where S's boundary
//                        meets itself pulls in its whole star;
//   holes                absorb_kept_islands (paper, one O(m) pass): kept
//                        components that do not reach the mesh boundary join
//                        S (with allow_mesh_boundary: all but the largest);
//                        fill_inner_loops (stitcher, local): the triangles
//                        enclosed by an inner (clockwise) boundary loop of S
//                        join it;
//   clearance            stitcher: a vertex of S's boundary (off the mesh
//                        boundary) closer than this to R's drawn edges pulls
//                        in its star;
//   allow_mesh_boundary  S may reach the mesh boundary (a fault at the
//                        study-area boundary, paper F22); otherwise that is a
//                        GeometryError naming the vertex.
// The caller's knowledge of its triangles comes through GrowthHooks:
// verify (the stitcher checks a base triangle lazily, the first time it is
// used), frozen triangles that never join (the stitcher's earlier fault
// patches: they stay as holes of S) and atomic groups (the stitcher's earlier
// gaps: a gap joins whole or not at all; Grower::merged_groups() lists the
// groups swallowed).
//
// Schedule. A round applies three levels of rules in order -- level 1:
// grow_touching, join_components, pinch (each in turn); level 2: holes;
// level 3: clearance -- and ends at the first level that added triangles;
// then the atomic groups of the new members are closed. Growth ends with a
// round that adds nothing (the round count is reported). So pinches are
// resolved before holes are filled, and holes before the clearance grows S.
// pull_star, fill_inner_loops and clearance walk S's boundary as half-edges
// with S on the left: they need consistently oriented triangles; the paper's
// rules accept any orientation.
#pragma once

#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/overlap.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace faultmesh::detail {

// Twice the signed area of a ring of points, relative to its first point
// (less cancellation at large coordinates than the shoelace about 0).
inline double ring_area2(const std::vector<const double*>& pts) {
    double s = 0.0;
    const double* o = pts[0];
    for (std::size_t i = 1; i + 1 < pts.size(); ++i) {
        const double* p = pts[i];
        const double* q = pts[i + 1];
        s += (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]);
    }
    return s;
}

// The XY box of triangle (a, b, c).
inline Box2 triangle_box(const double* a, const double* b, const double* c) {
    return {std::min(a[0], std::min(b[0], c[0])), std::min(a[1], std::min(b[1], c[1])),
            std::max(a[0], std::max(b[0], c[0])), std::max(a[1], std::max(b[1], c[1]))};
}

struct Seg {
    double p[2], q[2];
};

// ------------------------------------------------------------------ the region
// R given by rings (overlap.hpp): the boundary dR (ring edges split at ring
// vertices, equal pieces cancelled in pairs) decides R's interior by parity;
// the pieces that cancelled and rings of a single point are kept as "drawn"
// (they bound nothing, but the closed-contact predicate counts contact with
// every drawn point of the rings).
class Region {
public:
    Region() = default;
    // Throws std::invalid_argument for bad ring offsets or a non-finite point
    // (messages of overlapping_triangles: the other callers check first).
    Region(const double* ring_xy, const std::int64_t* ring_offsets, std::size_t n_rings);

    bool empty() const { return edges_.empty(); }            // no interior
    bool nothing_drawn() const { return edges_.empty() && extra_.empty(); }
    const Box2& bounds() const { return bounds_; }            // box of dR
    const Box2& drawn_bounds() const { return drawn_bounds_; }  // box of every drawn point

    // The predicate of `which` for triangle (a, b, c): open_interior needs
    // a counter-clockwise triangle of non-zero area; closed_contact takes any.
    bool meets(const double* a, const double* b, const double* c, OverlapPredicate which) const {
        return which == OverlapPredicate::open_interior ? meets_open_triangle(a, b, c)
                                                        : meets_closed_triangle(a, b, c);
    }
    // Open interior (the paper's test): the open triangle meets R's interior.
    bool meets_open_triangle(const double* a, const double* b, const double* c) const;
    // Closed contact: the closed triangle meets R's interior, dR or any drawn
    // ring edge or point.
    bool meets_closed_triangle(const double* a, const double* b, const double* c) const;
    // The closed segment pq meets the closure of R (interior and dR).
    bool segment_meets_closure(const double* p, const double* q) const;
    // Parity (true = inside R) of the points just counter-clockwise of the
    // direction a -> b, arbitrarily close to a.
    bool wedge_parity(const double* a, const double* b) const;
    // XY distance from p to the nearest drawn edge or point, if below
    // `limit` (otherwise limit).
    double distance(const double* p, double limit) const;

private:
    std::vector<Seg> edges_;  // dR, each piece in the direction of the ring edge it came from
    std::vector<Seg> extra_;  // drawn, not boundary
    AabbTree tree_, extra_tree_;
    Box2 bounds_{}, drawn_bounds_{};
    // Horizontal slabs over [y0, y1] for the crossing count: an edge is listed
    // in every slab its closed y-range touches.
    double y0_ = 0, y1_ = 0, scale_ = 0;
    std::size_t nslab_ = 0;
    std::vector<std::uint32_t> slab_start_, slab_edges_;
    std::size_t slab_of(double y) const;
};

// ------------------------------------------------------------------ the removed set
// What the caller knows about its triangles beyond the mesh (default: nothing).
class GrowthHooks {
public:
    virtual ~GrowthHooks() = default;
    // Called before triangle t joins S; may throw (a lazily verified triangle).
    virtual void verify(std::int64_t /*t*/) {}
    // A frozen triangle never joins S.
    virtual bool frozen(std::int64_t /*t*/) const { return false; }
    // The atomic group of t, or -1; group(g) lists its triangles.
    virtual std::int64_t group_of(std::int64_t /*t*/) const { return -1; }
    virtual const std::vector<std::int64_t>& group(std::int64_t g) const;
};

// S: its members in the order they joined, and O(1) membership by stamped
// marks (a new stamp empties the set without clearing the marks: the stitcher
// keeps one mark array per layer and each stitch stays local).
class RemovedSet {
public:
    // marks: at least one entry per triangle; stamp: the value meaning "in S".
    RemovedSet(std::vector<std::uint32_t>& marks, std::uint32_t stamp, GrowthHooks* hooks = nullptr)
        : mark_(&marks), stamp_(stamp), hooks_(hooks ? hooks : &no_hooks()) {}
    bool contains(std::int64_t t) const {
        return t >= 0 && (*mark_)[static_cast<std::size_t>(t)] == stamp_;
    }
    // t joins S unless it is in S or frozen (verified first). True if it joined.
    bool add(std::int64_t t) {
        if (contains(t)) return false;
        hooks_->verify(t);
        if (hooks_->frozen(t)) return false;
        (*mark_)[static_cast<std::size_t>(t)] = stamp_;
        members_.push_back(t);
        return true;
    }
    const std::vector<std::int64_t>& members() const { return members_; }
    std::size_t size() const { return members_.size(); }
    GrowthHooks& hooks() const { return *hooks_; }

private:
    static GrowthHooks& no_hooks();  // stateless defaults
    std::vector<std::uint32_t>* mark_;
    std::uint32_t stamp_;
    GrowthHooks* hooks_;
    std::vector<std::int64_t> members_;
};

// ------------------------------------------------------------------ growth
enum class PinchRule { none, keep_largest_kept_fan, pull_star };
enum class HoleRule { none, absorb_kept_islands, fill_inner_loops };

struct GrowthRules {
    bool grow_touching = false;
    bool join_components = false;
    PinchRule pinch = PinchRule::none;
    HoleRule holes = HoleRule::none;
    bool allow_mesh_boundary = false;
    double clearance = 0.0;   // 0: off
    int max_rounds = 0;       // 0: no bound
    bool verify_disk = false;  // at the end: S is a disk (Euler characteristic 1), not the whole mesh
    // With PinchRule::pull_star: a pinch at a mesh-boundary vertex whose star
    // only frozen triangles keep out of S (a frozen piece that touches the
    // mesh boundary at that vertex alone, S on both sides of it) stays: S's
    // outline passes that vertex twice (Grower::kept_pinches). Off: an error.
    bool keep_frozen_pinches_on_mesh_boundary = false;
};

// The mesh the set grows in.
struct GrowthMesh {
    const double* xy = nullptr;  // vertex v at xy + stride * v (x, y first)
    std::size_t stride = 2;
    std::size_t n_vertices = 0;
    const std::int64_t* triangles = nullptr;  // 3 per triangle
    const std::int64_t* twins = nullptr;      // 3 per triangle (triangle_adjacency.hpp)
    std::size_t n_triangles = 0;
};

class Grower {
public:
    // `fn` starts the error messages.
    Grower(const GrowthMesh& mesh, RemovedSet& set, const Region& region, const GrowthRules& rules,
           std::string fn);

    // Close the atomic groups of members [from, end): their groups join whole.
    void close_groups(std::size_t from);
    // Grow until no rule adds anything; returns the number of rounds.
    int run();
    // Earlier groups that joined S, in the order they did.
    const std::vector<std::int64_t>& merged_groups() const { return merged_; }

    // S's boundary as half-edges (S on the left), in member order, with the
    // first boundary half-edge leaving each vertex and the further ones
    // (pinches). Recomputed when S has changed.
    struct Boundary {
        std::vector<std::int64_t> halfedges;
        std::unordered_map<std::int64_t, std::int64_t> leaving;
        std::vector<std::int64_t> pinches;
    };
    const Boundary& boundary();
    // The pinch vertices that stayed (GrowthRules::keep_frozen_pinches_on_mesh_boundary),
    // sorted, as of the last round.
    const std::vector<std::int64_t>& kept_pinches() const { return kept_pinches_; }

private:
    const double* pt(std::int64_t v) const { return m_.xy + m_.stride * static_cast<std::size_t>(v); }
    std::int64_t vtx(std::int64_t t, int c) const { return m_.triangles[3 * t + c]; }
    std::int64_t nb(std::int64_t t, int e) const {  // triangle across edge e of t, or -1
        const std::int64_t o = m_.twins[3 * t + e];
        return o < 0 ? -1 : o / 3;
    }
    bool in(std::int64_t t) const { return S_.contains(t); }

    // Fan walk around vertex v from triangle t0, first across t0's edge slot
    // `slot` (an edge of t0 at v), then across the other edge at v of each
    // triangle entered; f(u) for each one. Stops at the mesh boundary
    // (returns 0), back in t0 (1) or after max_steps triangles (2).
    template <class F>
    int walk_fan(std::int64_t v, std::int64_t t0, int slot, std::size_t max_steps, F&& f) const;

    // Rules (each returns true if S grew).
    bool grow_touching();
    bool join_components();
    bool keep_largest_kept_fans();
    bool pull_pinch_stars();
    bool absorb_kept_islands();
    bool fill_inner_loops();
    bool pull_clearance();
    void pull_star(std::int64_t h0);
    // The boundary half-edge of S that follows boundary half-edge h around
    // S: turning about h's head through S's triangles (at a pinch, the one
    // that bounds the same wedge of S as h).
    std::int64_t next_boundary_halfedge(std::int64_t h) const;
    bool star(std::int64_t v, std::int64_t t0, std::vector<std::int64_t>& fan, bool& cyclic) const;
    long euler() const;
    void check_mesh_boundary() const;
    bool apply(bool (Grower::*rule)());
    void verify() const;

    GrowthMesh m_;
    RemovedSet& S_;
    const Region& R_;
    GrowthRules rules_;
    std::string fn_;
    // O(m) topology of the paper's rules (only built when they are on).
    std::vector<std::uint32_t> degree_;
    std::vector<char> boundary_vertex_;
    std::vector<std::int64_t> merged_;
    std::unordered_set<std::int64_t> merged_set_;
    std::vector<std::int64_t> kept_pinches_;
    Boundary bnd_;
    std::size_t bnd_size_ = static_cast<std::size_t>(-1);
};

}  // namespace faultmesh::detail
