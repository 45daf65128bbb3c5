// Private engine of delaunay.cpp and tin.cpp: incremental Bowyer-Watson
// Delaunay triangulation on half-edge arrays.
//
// Representation (struct of arrays, 32-bit indices):
//   xy  -- vertex coordinates in the engine's own order (the insertion order,
//          so that vertices inserted one after another sit side by side in
//          memory); a duplicate point keeps its slot but is never referenced.
//   tv  -- 3 vertex ids per triangle slot, counter-clockwise.
//   th  -- th[e] = the opposite half-edge of half-edge e = 3t + i, which runs
//          tv[e] -> tv[next(e)].
// The convex hull is closed by the infinite vertex kInf: every hull edge a->b
// has a ghost triangle (b, a, kInf) across it, so every half-edge has a twin
// and the triangulation is a triangulated sphere. No numeric super-triangle
// exists, so hull triangles are exactly those of the point set.
//
// Insertion of p (Bowyer-Watson): walk to the triangle that contains p (or to
// the ghost whose hull edge sees p), then grow the cavity of triangles in
// conflict with p by a depth-first search over the adjacency and replace it by
// the star of p. A triangle is in conflict if p is inside its circumcircle
// under CGAL's symbolic perturbation (incircle_perturbed); a ghost (x, y, inf)
// if p is strictly outside its hull edge x->y, or on it strictly between x and
// y. This is the conflict test of a genuine (perturbed) Delaunay triangulation,
// so the cavity is a topological disk whose vertices all lie on its boundary:
// its dual graph is a tree. The DFS therefore never meets a triangle twice and,
// visiting each triangle's edges in counter-clockwise order, lists the cavity
// boundary in counter-clockwise order -- consecutive new triangles are then
// neighbours, and a cavity of k boundary edges (k - 2 triangles) is replaced by
// k triangles reusing its k - 2 slots plus 2 appended ones: no free list, no
// per-triangle allocation.
#pragma once

#include <faultmesh/predicates.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace faultmesh::detail {

constexpr std::int32_t kInf = -1;  // the infinite vertex

inline std::int32_t next_he(std::int32_t e) { return (e % 3 == 2) ? e - 2 : e + 1; }
inline std::int32_t prev_he(std::int32_t e) { return (e % 3 == 0) ? e + 2 : e - 1; }

// The conflict test of the cavity: faultmesh::incircle_perturbed (predicates.hpp).
inline bool incircle_perturbed(const double* p0, const double* p1, const double* p2, const double* p) {
    return faultmesh::incircle_perturbed(p0, p1, p2, p) > 0;
}

// A growable int32 buffer without per-push capacity bookkeeping of
// std::vector (the hot loop pushes ~20 entries per inserted point).
class IntStack {
public:
    void clear() { n_ = 0; }
    std::size_t size() const { return n_; }
    bool empty() const { return n_ == 0; }
    std::int32_t operator[](std::size_t i) const { return d_[i]; }
    std::int32_t back() const { return d_[n_ - 1]; }
    std::int32_t pop() { return d_[--n_]; }
    void push(std::int32_t v) {
        if (n_ == d_.size()) d_.resize(d_.empty() ? 64 : 2 * d_.size());
        d_[n_++] = v;
    }

private:
    std::vector<std::int32_t> d_;
    std::size_t n_ = 0;
};

class DelaunayCore {
public:
    std::vector<double> xy;        // 2 per vertex id
    std::vector<std::int32_t> tv;  // 3 per triangle slot (size = 3 * capacity)
    std::vector<std::int32_t> th;  // 3 per triangle slot (size = 3 * capacity)
    std::int32_t hint = 0;         // a finite triangle near the last insertion

    std::size_t n_slots() const { return nslots_; }
    bool is_ghost(std::int32_t t) const {
        const std::int32_t* v = &tv[3 * static_cast<std::size_t>(t)];
        return v[0] == kInf || v[1] == kInf || v[2] == kInf;
    }
    const double* pt(std::int32_t v) const { return &xy[2 * static_cast<std::size_t>(v)]; }

    // Makes room for n vertices in total without reallocation during insertion.
    void reserve_vertices(std::size_t n) {
        // Geometric growth: a Tin grown one point per insert() must not copy
        // its coordinates on every call.
        if (xy.capacity() < 2 * n) xy.reserve(std::max(2 * n, xy.capacity() + xy.capacity() / 2));
        // A triangulated sphere with n + 1 vertices has 2n - 2 triangles.
        ensure_slots(2 * n + 2);
    }

    // First triangle: a, b, c distinct, non-collinear vertex ids.
    void init(std::int32_t a, std::int32_t b, std::int32_t c) {
        if (orient2d(pt(a), pt(b), pt(c)) < 0) std::swap(b, c);
        ensure_slots(4);
        const std::int32_t v0[12] = {a, b, c, b, a, kInf, c, b, kInf, a, c, kInf};
        //                            T0        G0 (ab)    G1 (bc)    G2 (ca)
        const std::int32_t h0[12] = {3, 6, 9, 0, 11, 7, 1, 5, 10, 2, 8, 4};
        for (int i = 0; i < 12; ++i) {
            tv[i] = v0[i];
            th[i] = h0[i];
        }
        nslots_ = 4;
        hint = 0;
    }

    // Triangle slot that contains p (closed), walking from the finite
    // triangle `start`; a ghost slot if p is strictly outside the hull.
    // This is the visibility walk, which terminates in a Delaunay
    // triangulation; it crosses an edge only if p is strictly beyond it.
    std::int32_t locate(const double* p, std::int32_t start) const {
        const std::int32_t* V = tv.data();
        const std::int32_t* H = th.data();
        const double* X = xy.data();
        std::int32_t t = start;
        std::int32_t entry = -1;
        // The walk cannot cycle in a Delaunay triangulation (Edelsbrunner's
        // acyclicity of the in-front relation); the step limit only turns a
        // broken invariant into a slow scan instead of a hang.
        std::size_t steps = 0;
        const std::size_t max_steps = nslots_ + 8;
        for (;;) {
            if (++steps > max_steps) return locate_scan(p);
            const std::int32_t base = 3 * t;
            std::int32_t cross = -1;
            for (int i = 0; i < 3; ++i) {
                const std::int32_t e = base + i;
                if (e == entry) continue;
                const std::int32_t a = V[e], b = V[i == 2 ? base : e + 1];
                if (orient2d(X + 2 * a, X + 2 * b, p) < 0.0) {
                    cross = e;
                    break;
                }
            }
            if (cross < 0) return t;
            entry = H[cross];
            t = entry / 3;
            const std::int32_t* v = V + 3 * t;
            if (v[0] == kInf || v[1] == kInf || v[2] == kInf) return t;
        }
    }

    // Linear-time location: a finite triangle containing p, else a ghost
    // whose hull edge p is strictly beyond.
    std::int32_t locate_scan(const double* p) const {
        std::int32_t ghost = -1;
        for (std::size_t t = 0; t < nslots_; ++t) {
            const std::int32_t* v = &tv[3 * t];
            if (v[0] == kInf || v[1] == kInf || v[2] == kInf) {
                if (ghost < 0) {
                    const int i = v[0] == kInf ? 1 : (v[1] == kInf ? 2 : 0);
                    if (orient2d(pt(v[i]), pt(v[(i + 1) % 3]), p) > 0.0) ghost = static_cast<std::int32_t>(t);
                }
                continue;
            }
            if (orient2d(pt(v[0]), pt(v[1]), p) >= 0.0 && orient2d(pt(v[1]), pt(v[2]), p) >= 0.0 &&
                orient2d(pt(v[2]), pt(v[0]), p) >= 0.0)
                return static_cast<std::int32_t>(t);
        }
        return ghost;
    }

    // Is triangle slot t in conflict with p?
    bool conflict(std::int32_t t, const double* p) const {
        const std::int32_t* v = &tv[3 * static_cast<std::size_t>(t)];
        const std::int32_t a = v[0], b = v[1], c = v[2];
        if (a != kInf && b != kInf && c != kInf) return incircle_perturbed(pt(a), pt(b), pt(c), p);
        // Ghost (x, y, inf): hull edge x -> y with the outside on its left.
        std::int32_t x, y;
        if (a == kInf) {
            x = b;
            y = c;
        } else if (b == kInf) {
            x = c;
            y = a;
        } else {
            x = a;
            y = b;
        }
        const double* px = pt(x);
        const double* py = pt(y);
        const double o = orient2d(px, py, p);
        if (o > 0.0) return true;
        if (o < 0.0) return false;
        // On the hull line: in conflict only strictly between x and y (p then
        // splits the hull edge); beyond either end the hull edge stays.
        return lex_less(px, p) ? lex_less(p, py) : lex_less(py, p);
    }

    // Inserts vertex id v (coordinates already in xy). Returns -1 if v became
    // a vertex, or the id of the existing vertex with the same coordinates.
    std::int32_t insert(std::int32_t v) {
        const double* p = pt(v);
        const std::int32_t t0 = locate(p, hint);
        {
            const std::int32_t* tri = &tv[3 * static_cast<std::size_t>(t0)];
            for (int i = 0; i < 3; ++i) {
                const std::int32_t w = tri[i];
                if (w != kInf && xy[2 * w] == p[0] && xy[2 * w + 1] == p[1]) return w;
            }
        }
        dig_cavity(t0, p);
        fill_star(v);
        return -1;
    }

private:
    std::size_t nslots_ = 0;
    IntStack cav_;     // cavity triangle slots
    IntStack bnd_a_;   // cavity boundary, CCW: start vertex of each edge
    IntStack bnd_tw_;  // the surviving twin half-edge outside each boundary edge
    IntStack stack_;

    void ensure_slots(std::size_t slots) {
        if (tv.size() >= 3 * slots) return;
        const std::size_t cap = std::max(3 * slots, tv.size() + tv.size() / 2);
        tv.resize(cap);
        th.resize(cap);
    }

    void dig_cavity(std::int32_t t0, const double* p) {
        cav_.clear();
        bnd_a_.clear();
        bnd_tw_.clear();
        stack_.clear();
        cav_.push(t0);
        stack_.push(3 * t0 + 2);
        stack_.push(3 * t0 + 1);
        stack_.push(3 * t0);
        const std::int32_t* H = th.data();
        while (!stack_.empty()) {
            const std::int32_t e = stack_.pop();
            const std::int32_t tw = H[e];
            const std::int32_t nb = tw / 3;
            if (conflict(nb, p)) {
                cav_.push(nb);
                // Children in counter-clockwise order after the entry edge.
                stack_.push(prev_he(tw));
                stack_.push(next_he(tw));
            } else {
                bnd_a_.push(tv[e]);
                bnd_tw_.push(tw);
            }
        }
    }

    void fill_star(std::int32_t v) {
        const std::size_t k = bnd_a_.size();
        // k boundary edges, k - 2 cavity triangles: 2 new slots.
        ensure_slots(nslots_ + 2);
        const std::int32_t s = static_cast<std::int32_t>(nslots_);
        nslots_ += 2;
        cav_.push(s);
        cav_.push(s + 1);
        std::int32_t* V = tv.data();
        std::int32_t* H = th.data();
        std::int32_t finite = -1;
        for (std::size_t i = 0; i < k; ++i) {
            const std::int32_t nt = cav_[i];
            const std::size_t inext = (i + 1 == k) ? 0 : i + 1;
            const std::size_t iprev = (i == 0) ? k - 1 : i - 1;
            const std::int32_t a = bnd_a_[i], b = bnd_a_[inext];
            const std::int32_t base = 3 * nt;
            V[base] = a;
            V[base + 1] = b;
            V[base + 2] = v;
            const std::int32_t tw = bnd_tw_[i];
            H[base] = tw;
            H[tw] = base;
            H[base + 1] = 3 * cav_[inext] + 2;
            H[base + 2] = 3 * cav_[iprev] + 1;
            if (a != kInf && b != kInf) finite = nt;
        }
        hint = finite;
    }
};

// Throws std::invalid_argument naming `fn`, the argument `what` and the row if
// a coordinate (x or y) of one of the n points (stride doubles each) is NaN,
// infinite or beyond faultmesh::kMaxCoordinate (predicates.hpp).
void check_finite_xy(const double* pts, std::size_t stride, std::size_t n, const char* fn,
                     const char* what);

// Largest number of points the 32-bit half-edge arrays can index (6 half-edges
// per point must fit in int32).
constexpr std::size_t kMaxPoints = 300000000;

// Triangulates n points (stride doubles each, x and y first) from scratch
// into `core` (which must be empty). Vertex ids are assigned in insertion
// (BRIO) order: input_of_id[id] is the input index of id, dup_of[id] is -1
// for a vertex or the id of the earlier-inserted vertex it duplicates.
// Validates the input (non-finite -> std::invalid_argument; fewer than 3
// distinct points or all collinear -> GeometryError, messages prefixed `fn`).
void build_core(DelaunayCore& core, const double* pts, std::size_t stride, std::size_t n,
                const char* fn, std::vector<std::uint32_t>& input_of_id,
                std::vector<std::int32_t>& dup_of);

// Inserts n more points into a built core, in BRIO order. The new ids are
// first .. first + n - 1 (first = the id count before the call); for each,
// input_of_id[id - first] is its row in pts and dup_of[id - first] is -1 or
// the id of the vertex it duplicates (an earlier or a new one). The points
// must already be validated.
void insert_batch(DelaunayCore& core, const double* pts, std::size_t stride, std::size_t n,
                  std::vector<std::uint32_t>& input_of_id, std::vector<std::int32_t>& dup_of);

// compact[slot] = index of the slot among the finite triangles, or -1 for a
// ghost; returns the number of finite triangles.
std::size_t compact_slots(const DelaunayCore& core, std::vector<std::int32_t>& compact);

// The finite triangles in compacted order as vertex_of_id[id] triples, and
// their half-edge twins (-1 across the hull); either output may be null.
void export_mesh(const DelaunayCore& core, const std::vector<std::int32_t>& compact, std::size_t m,
                 const std::int64_t* vertex_of_id, std::vector<std::int64_t>* triangles,
                 std::vector<std::int64_t>* halfedges);
void export_mesh(const DelaunayCore& core, const std::vector<std::int32_t>& compact, std::size_t m,
                 const std::uint32_t* vertex_of_id, std::vector<std::int64_t>* triangles,
                 std::vector<std::int64_t>* halfedges);

}  // namespace faultmesh::detail
