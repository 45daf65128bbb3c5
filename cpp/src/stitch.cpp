// Stitching fault patches into a layer TIN: the set-up of the layer, the
// sequence of steps of one stitch (stitch_steps.hpp, one file per phase) and
// the export. See stitch.hpp for the algorithm.
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/boundary.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/layer_tin.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/stitch.hpp>
#include <faultmesh/study_area.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include "edge_key.hpp"
#include "stitch_steps.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

namespace faultmesh {

namespace detail {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string fmt_point(const double* p) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "(%.10g, %.10g)", p[0], p[1]);
    return buf;
}

void StitcherState::ensure(std::int64_t r) {
    if (static_cast<std::size_t>(r) >= n_base || checked[static_cast<std::size_t>(r)]) return;
    const std::int64_t* t = &tri[3 * static_cast<std::size_t>(r)];
    if (orient2d(v(t[0]), v(t[1]), v(t[2])) <= 0.0)
        throw GeometryError("LayerStitcher('" + name + "'): triangle row " + std::to_string(r) +
                            " is clockwise or degenerate in XY; the layer mesh must be a "
                            "counter-clockwise TIN");
    for (int k = 0; k < 3; ++k) {
        const std::int64_t h = 3 * r + k, o = adj[static_cast<std::size_t>(h)];
        if (o < 0) continue;
        if (adj[static_cast<std::size_t>(o)] != h || tri[static_cast<std::size_t>(o)] != t[(k + 1) % 3] ||
            tri[static_cast<std::size_t>(next_halfedge(o))] != t[k])
            throw std::invalid_argument("LayerStitcher('" + name + "'): halfedges[" + std::to_string(h) +
                                        "] = " + std::to_string(o) + " is not the opposite half-edge");
    }
    checked[static_cast<std::size_t>(r)] = 1;
}

std::uint32_t StitcherState::new_stamp() {
    if (++stamp == 0) {  // wrapped: clear once
        std::fill(in_d.begin(), in_d.end(), 0);
        stamp = 1;
    }
    return stamp;
}

StitcherState& state_of(LayerStitcher& st) { return *st.s_; }

}  // namespace detail

using detail::StitcherState;

// ---------------------------------------------------------------- ctor
namespace {

// Room for the patches and gaps to come: appending must not reallocate (and
// copy) the whole mesh at the first stitch.
std::size_t spare_of(std::size_t n) { return n / 4 + 1024; }

}  // namespace

namespace detail {

// The set-up shared by the constructors: s.xyz and s.tri hold the mesh (with
// spare capacity); s.adj its half-edges, or is empty (then built here).
// boundary_xy: the study area, or null for the mesh's outer boundary loop.
void set_up_stitcher(StitcherState& s, std::size_t n_vertices, std::size_t n_triangles, bool have_halfedges,
                     const double* boundary_xy, std::size_t n_boundary, const StitchOptions& options) {
    const std::string fn = "LayerStitcher('" + s.name + "')";
    const std::size_t spare_t = spare_of(n_triangles);
    // Eager checks are sequential scans only. What needs random access (the
    // orientation of a triangle, the symmetry of given half-edges) is checked
    // lazily, for each triangle the first time a stitch touches it
    // (StitcherState::ensure): a stitch never relies on an unchecked triangle,
    // and the set-up stays O(mesh) with a small constant.
    for (std::size_t t = 0; t < n_triangles; ++t) {
        const std::int64_t* r = &s.tri[3 * t];
        for (int k = 0; k < 3; ++k)
            if (r[k] < 0 || static_cast<std::size_t>(r[k]) >= n_vertices)
                throw std::invalid_argument(fn + ": triangles row " + std::to_string(t) + " has vertex index " +
                                            std::to_string(r[k]) + " outside [0, " +
                                            std::to_string(n_vertices) + ")");
    }
    // x and y within the coordinate limit of predicates.hpp; z only finite.
    for (std::size_t i = 0; i < 3 * n_vertices; ++i)
        if (i % 3 == 2 ? !std::isfinite(s.xyz[i]) : !coordinate_in_range(s.xyz[i]))
            throw_coordinate_error(fn, "vertices row " + std::to_string(i / 3), static_cast<int>(i % 3), s.xyz[i]);
    if (have_halfedges) {
        const std::int64_t nh = static_cast<std::int64_t>(3 * n_triangles);
        for (std::size_t h = 0; h < 3 * n_triangles; ++h)
            if (s.adj[h] < -1 || s.adj[h] >= nh)
                throw std::invalid_argument(fn + ": halfedges[" + std::to_string(h) + "] = " +
                                            std::to_string(s.adj[h]) + " is outside [-1, " + std::to_string(nh) +
                                            ")");
    } else {
        s.adj = halfedge_twins(s.tri.data(), n_triangles, n_vertices, EdgeOrientation::consistent, fn);
    }
    s.adj.reserve(3 * (n_triangles + spare_t));
    s.kind.reserve(n_triangles + spare_t);
    s.kind.assign(n_triangles, static_cast<std::int8_t>(TriangleKind::layer));
    s.owner.reserve(n_triangles + spare_t);
    s.owner.assign(n_triangles, -1);
    s.alive.reserve(n_triangles + spare_t);
    s.alive.assign(n_triangles, 1);
    s.checked.assign(n_triangles, 0);
    s.in_d.reserve(n_triangles + spare_t);
    s.n_live = n_triangles;
    s.n_base = n_triangles;
    // Stage 1 index: an AABB tree over blocks of kBlock consecutive triangles
    // (a Delaunay TIN's rows are spatially coherent: Hilbert-ordered
    // insertion), 1/kBlock of the tree build of one box per triangle; a
    // query then tests the boxes of the block's triangles.
    {
        const std::size_t nb = (n_triangles + detail::kBlock - 1) / detail::kBlock;
        std::vector<Box2> boxes(nb, Box2{detail::kInf, detail::kInf, -detail::kInf, -detail::kInf});
        for (std::size_t t = 0; t < n_triangles; ++t) {
            const std::int64_t* r = &s.tri[3 * t];
            Box2& b = boxes[t / detail::kBlock];
            for (int k = 0; k < 3; ++k) {
                const double* p = s.v(r[k]);
                b.xmin = std::min(b.xmin, p[0]);
                b.ymin = std::min(b.ymin, p[1]);
                b.xmax = std::max(b.xmax, p[0]);
                b.ymax = std::max(b.ymax, p[1]);
            }
        }
        s.base = AabbTree(boxes);
    }
    s.grow_markers();

    std::vector<double> bpts;
    if (boundary_xy && n_boundary) {
        // Named here as the stitcher's argument (StudyArea checks it too).
        check_coordinates(boundary_xy, n_boundary, 2, 2, fn.c_str(), "boundary");
        bpts.assign(boundary_xy, boundary_xy + 2 * n_boundary);
    } else {
        // The mesh's own outer boundary: the boundary loop of largest area.
        std::vector<std::int64_t> nxt(n_vertices, -1);
        std::vector<std::int64_t> starts;
        for (std::size_t h = 0; h < s.adj.size(); ++h)
            if (s.adj[h] == -1) {
                nxt[static_cast<std::size_t>(s.tri[h])] = s.tri[next_halfedge(static_cast<std::int64_t>(h))];
                starts.push_back(s.tri[h]);
            }
        double best = 0.0;
        std::vector<char> done(n_vertices, 0);
        for (std::int64_t st : starts) {
            if (done[static_cast<std::size_t>(st)]) continue;
            std::vector<const double*> ring;
            std::vector<double> pts;
            std::int64_t v = st;
            while (v >= 0 && !done[static_cast<std::size_t>(v)]) {
                done[static_cast<std::size_t>(v)] = 1;
                ring.push_back(s.v(v));
                pts.push_back(s.v(v)[0]);
                pts.push_back(s.v(v)[1]);
                v = nxt[static_cast<std::size_t>(v)];
            }
            if (ring.size() < 3) continue;
            const double a = detail::ring_area2(ring);
            if (a > best) {
                best = a;
                bpts = pts;
            }
        }
        if (bpts.empty()) throw GeometryError(fn + ": the mesh has no outer boundary loop");
    }
    s.study = StudyArea(bpts.data(), bpts.size() / 2, options.boundary_tolerance);
}

}  // namespace detail

LayerStitcher::LayerStitcher(const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
                             std::size_t n_triangles, const double* boundary_xy, std::size_t n_boundary,
                             const std::int64_t* halfedges, std::string name, const StitchOptions& options)
    : s_(std::make_unique<StitcherState>()) {
    StitcherState& s = *s_;
    s.name = std::move(name);
    s.opt = options;
    const std::string fn = "LayerStitcher('" + s.name + "')";
    if (n_triangles == 0) throw std::invalid_argument(fn + ": the mesh has no triangles");
    if ((vertices == nullptr && n_vertices) || triangles == nullptr) throw std::invalid_argument(fn + ": null array");
    s.xyz.reserve(3 * (n_vertices + spare_of(n_vertices)));
    s.xyz.assign(vertices, vertices + 3 * n_vertices);
    s.measured.assign(n_vertices, 1);  // the caller's vertices are its data
    s.tri.reserve(3 * (n_triangles + spare_of(n_triangles)));
    s.tri.assign(triangles, triangles + 3 * n_triangles);
    if (halfedges) {
        s.adj.reserve(3 * (n_triangles + spare_of(n_triangles)));
        s.adj.assign(halfedges, halfedges + 3 * n_triangles);
    }
    detail::set_up_stitcher(s, n_vertices, n_triangles, halfedges != nullptr, boundary_xy, n_boundary, options);
}

LayerStitcher::LayerStitcher(const LayerTin& layer, const StitchOptions& options)
    : s_(std::make_unique<StitcherState>()) {
    StitcherState& s = *s_;
    s.name = layer.name();
    s.opt = options;
    // The layer's mesh inside the study area, made with the spare room and
    // moved in: no copy of the arrays.
    const std::size_t nv = layer.n_vertices();
    LayerTinMesh m = layer.mesh(spare_of(nv), spare_of(2 * nv));
    const std::size_t n_vertices = m.vertices.size() / 3, n_triangles = m.triangles.size() / 3;
    if (n_triangles == 0) throw std::invalid_argument("LayerStitcher('" + s.name + "'): the mesh has no triangles");
    s.xyz = std::move(m.vertices);
    s.tri = std::move(m.triangles);
    s.adj = std::move(m.halfedges);
    s.measured = std::move(m.measured);
    const std::vector<double>& ring = layer.area().ring();
    detail::set_up_stitcher(s, n_vertices, n_triangles, true, ring.data(), ring.size() / 2, options);
}

LayerStitcher::~LayerStitcher() = default;
LayerStitcher::LayerStitcher(LayerStitcher&&) noexcept = default;
LayerStitcher& LayerStitcher::operator=(LayerStitcher&&) noexcept = default;

std::size_t LayerStitcher::n_vertices() const { return s_->xyz.size() / 3; }
std::size_t LayerStitcher::n_triangles() const { return s_->n_tri(); }
std::size_t LayerStitcher::n_live_triangles() const { return s_->n_live; }
const std::string& LayerStitcher::name() const { return s_->name; }
const std::vector<std::string>& LayerStitcher::patch_names() const { return s_->patch_names; }

// ---------------------------------------------------------------- stitch
StitchReport LayerStitcher::stitch(const double* pv, std::size_t npv, const std::int64_t* pt,
                                   std::size_t npt, const std::string& patch_name) {
    StitcherState& s = *s_;
    const std::string fn = "stitch: layer '" + s.name + "', patch '" + patch_name + "'";
    if (npt == 0) throw std::invalid_argument(fn + ": the patch has no triangles");
    if (pv == nullptr || pt == nullptr) throw std::invalid_argument(fn + ": null array");
    // All three coordinates: z enters the degeneracy test below.
    for (std::size_t i = 0; i < 3 * npv; ++i)
        if (!coordinate_in_range(pv[i]))
            throw_coordinate_error(fn, "patch_vertices row " + std::to_string(i / 3), static_cast<int>(i % 3), pv[i]);
    std::vector<std::int64_t> ptri(pt, pt + 3 * npt);
    for (std::size_t t = 0; t < npt; ++t)
        for (int k = 0; k < 3; ++k) {
            const std::int64_t i = ptri[3 * t + k];
            if (i < 0 || static_cast<std::size_t>(i) >= npv)
                throw std::invalid_argument(fn + ": patch_triangles row " + std::to_string(t) +
                                            " has vertex index " + std::to_string(i) + " outside [0, " +
                                            std::to_string(npv) + ")");
            // Checked here so that the message names the patch (the outline
            // extraction below would report it as boundary_contours').
            if (i == ptri[3 * t + (k + 1) % 3])
                throw std::invalid_argument(fn + ": patch_triangles row " + std::to_string(t) + " repeats vertex " +
                                            std::to_string(i));
        }
    auto P = [&](std::int64_t i) { return pv + 3 * i; };
    // A triangle whose vertices are collinear in 3D would end up in the layer
    // as a zero-area triangle (fuzzing: a tip point on the line of its trace).
    // Exact: the 3D cross product vanishes iff its three components -- the
    // orientations of the xy, yz and zx projections -- are all zero.
    for (std::size_t t = 0; t < npt; ++t) {
        const double* a = P(ptri[3 * t]);
        const double* b = P(ptri[3 * t + 1]);
        const double* c = P(ptri[3 * t + 2]);
        bool flat = orient2d(a, b, c) == 0.0;
        for (int k = 1; flat && k < 3; ++k) {
            const double pa[2] = {a[k], a[(k + 1) % 3]}, pb[2] = {b[k], b[(k + 1) % 3]}, pc[2] = {c[k], c[(k + 1) % 3]};
            flat = orient2d(pa, pb, pc) == 0.0;
        }
        if (flat)
            throw GeometryError(fn + ": patch_triangles row " + std::to_string(t) +
                                " is degenerate (its vertices are collinear in 3D)");
    }

    detail::StitchJob job(s, pv, npv, std::move(ptri), patch_name);
    detail::outline_patch(s, job);       // 1. outline
    detail::find_overlap(s, job);        // 2. overlap
    detail::grow_removed_set(s, job);    // 3. growth
    detail::build_gap_polygons(s, job);  // 4. contours
    detail::clip_gap_polygons(s, job);   // 5. bridging + clipping
    detail::link_new_triangles(s, job);  // 6. merge: local adjacency (the last step that may throw)
    return detail::commit(s, job);       // 6. merge: commit
}

// ---------------------------------------------------------------- export
StitchedMesh LayerStitcher::mesh() const {
    const StitcherState& s = *s_;
    StitchedMesh m;
    const std::size_t nv = s.xyz.size() / 3, nt = s.n_tri();
    m.vertex_map.assign(nv, -1);
    m.triangle_map.assign(nt, -1);
    std::int64_t next_v = 0, next_t = 0;
    for (std::size_t r = 0; r < nt; ++r) {
        if (!s.alive[r]) continue;
        m.triangle_map[r] = next_t++;
        for (int k = 0; k < 3; ++k) {
            const std::size_t vtx = static_cast<std::size_t>(s.tri[3 * r + k]);
            if (m.vertex_map[vtx] < 0) m.vertex_map[vtx] = next_v++;
        }
    }
    // Keep the original vertex order (stable): renumber by increasing old index.
    next_v = 0;
    for (std::size_t i = 0; i < nv; ++i)
        if (m.vertex_map[i] >= 0) m.vertex_map[i] = next_v++;
    m.vertices.reserve(3 * static_cast<std::size_t>(next_v));
    for (std::size_t i = 0; i < nv; ++i)
        if (m.vertex_map[i] >= 0) m.vertices.insert(m.vertices.end(), &s.xyz[3 * i], &s.xyz[3 * i] + 3);
    m.triangles.reserve(3 * static_cast<std::size_t>(next_t));
    m.kinds.reserve(static_cast<std::size_t>(next_t));
    m.owners.reserve(static_cast<std::size_t>(next_t));
    for (std::size_t r = 0; r < nt; ++r) {
        if (!s.alive[r]) continue;
        for (int k = 0; k < 3; ++k) m.triangles.push_back(m.vertex_map[static_cast<std::size_t>(s.tri[3 * r + k])]);
        m.kinds.push_back(s.kind[r]);
        m.owners.push_back(s.owner[r]);
    }
    return m;
}

StitchResult stitch(const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
                    std::size_t n_triangles, const double* patch_vertices, std::size_t n_patch_vertices,
                    const std::int64_t* patch_triangles, std::size_t n_patch_triangles,
                    const double* boundary_xy, std::size_t n_boundary, const StitchOptions& options) {
    LayerStitcher st(vertices, n_vertices, triangles, n_triangles, boundary_xy, n_boundary, nullptr,
                     "layer", options);
    StitchResult res;
    res.report = st.stitch(patch_vertices, n_patch_vertices, patch_triangles, n_patch_triangles, "patch");
    res.mesh = st.mesh();
    for (std::size_t r = 0; r < res.mesh.kinds.size(); ++r)
        if (res.mesh.kinds[r] == static_cast<std::int8_t>(TriangleKind::gap))
            res.gap_rows.push_back(static_cast<std::int64_t>(r));
    return res;
}

TouchingRegion::TouchingRegion(const double* ring_xy, const std::int64_t* ring_offsets, std::size_t n_rings) {
    const char* fn = "triangles_touching_region";
    if (n_rings == 0) return;
    if (ring_offsets[0] != 0) throw std::invalid_argument(std::string(fn) + ": ring_offsets[0] must be 0");
    for (std::size_t r = 0; r < n_rings; ++r)
        if (ring_offsets[r + 1] < ring_offsets[r])
            throw std::invalid_argument(std::string(fn) + ": ring_offsets must be non-decreasing");
    const std::size_t np = static_cast<std::size_t>(ring_offsets[n_rings]);
    xy_.assign(ring_xy, ring_xy + 2 * np);
    for (std::size_t i = 0; i < xy_.size(); ++i)
        if (!coordinate_in_range(xy_[i]))
            throw_coordinate_error(fn, "ring point " + std::to_string(i / 2), static_cast<int>(i % 2), xy_[i]);
    offsets_.assign(ring_offsets, ring_offsets + n_rings + 1);
    region_ = std::make_unique<detail::Region>(xy_.data(), offsets_.data(), n_rings);
}

TouchingRegion::~TouchingRegion() = default;
TouchingRegion::TouchingRegion(TouchingRegion&&) noexcept = default;
TouchingRegion& TouchingRegion::operator=(TouchingRegion&&) noexcept = default;

namespace {
// Every index of the triangles within [0, n_vertices) and the x, y of every
// vertex they use within the coordinate limit of predicates.hpp; errors name
// `fn`, the triangles row and the vertices row.
void check_used_vertices(const char* fn, const double* vertices, std::size_t n_vertices, std::size_t stride,
                         const std::int64_t* triangles, std::size_t n_triangles) {
    for (std::size_t t = 0; t < n_triangles; ++t) {
        const std::int64_t* r = triangles + 3 * t;
        for (int k = 0; k < 3; ++k)
            if (r[k] < 0 || static_cast<std::size_t>(r[k]) >= n_vertices)
                throw std::invalid_argument(std::string(fn) + ": triangles row " + std::to_string(t) +
                                            " has vertex index " + std::to_string(r[k]) + " outside [0, " +
                                            std::to_string(n_vertices) + ")");
        for (int k = 0; k < 3; ++k) {
            const double* p = vertices + stride * static_cast<std::size_t>(r[k]);
            for (int c = 0; c < 2; ++c)
                if (!coordinate_in_range(p[c]))
                    throw_coordinate_error(fn, "vertices row " + std::to_string(r[k]) + " (used by triangles row " +
                                                   std::to_string(t) + ")",
                                           c, p[c]);
        }
    }
}
}  // namespace

std::vector<std::int64_t> TouchingRegion::touching(const double* vertices, std::size_t n_vertices,
                                                   std::size_t stride, const std::int64_t* triangles,
                                                   std::size_t n_triangles) const {
    const char* fn = "triangles_touching_region";
    if (stride != 2 && stride != 3) throw std::invalid_argument(std::string(fn) + ": stride must be 2 or 3");
    std::vector<std::int64_t> out;
    if (!region_) return out;
    check_used_vertices(fn, vertices, n_vertices, stride, triangles, n_triangles);
    for (std::size_t t = 0; t < n_triangles; ++t) {
        const std::int64_t* r = triangles + 3 * t;
        const double* a = vertices + stride * static_cast<std::size_t>(r[0]);
        const double* b = vertices + stride * static_cast<std::size_t>(r[1]);
        const double* c = vertices + stride * static_cast<std::size_t>(r[2]);
        if (region_->meets_closed_triangle(a, b, c)) out.push_back(static_cast<std::int64_t>(t));
    }
    return out;
}

std::vector<std::int64_t> triangles_touching_region(const double* vertices, std::size_t n_vertices,
                                                    std::size_t stride, const std::int64_t* triangles,
                                                    std::size_t n_triangles, const double* ring_xy,
                                                    const std::int64_t* ring_offsets, std::size_t n_rings) {
    if (stride != 2 && stride != 3)
        throw std::invalid_argument("triangles_touching_region: stride must be 2 or 3");
    return TouchingRegion(ring_xy, ring_offsets, n_rings).touching(vertices, n_vertices, stride, triangles,
                                                                   n_triangles);
}

std::vector<std::int64_t> triangles_not_covered_once(const double* vertices, std::size_t n_vertices,
                                                     std::size_t stride, const std::int64_t* triangles,
                                                     std::size_t n_triangles, const StudyArea* study,
                                                     bool outline) {
    const char* fn = "triangles_not_covered_once";
    if (stride != 2 && stride != 3) throw std::invalid_argument(std::string(fn) + ": stride must be 2 or 3");
    if (n_triangles == 0) return {};
    // Edges are keyed by their two vertex indices in 32 bits each.
    if (n_vertices > 0xffffffffULL) throw std::invalid_argument(std::string(fn) + ": more than 2^32 - 1 vertices");
    // Checked here to name this function and its arguments (from_triangles
    // checks the same, naming itself).
    check_used_vertices(fn, vertices, n_vertices, stride, triangles, n_triangles);
    auto V = [&](std::int64_t i) { return vertices + stride * static_cast<std::size_t>(i); };
    const AabbTree tree = AabbTree::from_triangles(vertices, n_vertices, stride, triangles, n_triangles);
    std::vector<int> o(n_triangles);
    for (std::size_t t = 0; t < n_triangles; ++t)
        o[t] = orient2d_sign(V(triangles[3 * t]), V(triangles[3 * t + 1]), V(triangles[3 * t + 2]));
    // Pieces: triangles joined across shared edges (any orientation).
    std::vector<std::size_t> parent(n_triangles);
    for (std::size_t t = 0; t < n_triangles; ++t) parent[t] = t;
    auto find = [&](std::size_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    // Edge -> (first triangle, uses): outline edges are used once.
    std::unordered_map<std::uint64_t, std::pair<std::size_t, int>> uses;
    uses.reserve(3 * n_triangles);
    for (std::size_t t = 0; t < n_triangles; ++t)
        for (int k = 0; k < 3; ++k) {
            const std::int64_t a = triangles[3 * t + k], b = triangles[3 * t + (k + 1) % 3];
            const std::uint64_t key = detail::undirected_edge_key(a, b);
            auto [it, fresh] = uses.emplace(key, std::make_pair(t, 1));
            if (!fresh) {
                parent[find(t)] = find(it->second.first);
                ++it->second.second;
            }
        }
    std::unordered_map<std::size_t, double> area;
    for (std::size_t t = 0; t < n_triangles; ++t)
        area[find(t)] += orient2d(V(triangles[3 * t]), V(triangles[3 * t + 1]), V(triangles[3 * t + 2]));
    std::vector<int> sign(n_triangles);
    for (std::size_t t = 0; t < n_triangles; ++t) sign[t] = area[find(t)] < 0.0 ? -o[t] : o[t];

    std::vector<char> bad(n_triangles, 0);
    for (std::size_t t = 0; t < n_triangles; ++t) {
        const double *a = V(triangles[3 * t]), *b = V(triangles[3 * t + 1]), *c = V(triangles[3 * t + 2]);
        const double q[2] = {(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0};
        int cover = 0;
        tree.visit(Box2{q[0], q[1], q[0], q[1]}, [&](std::int64_t j) {
            const int oj = o[static_cast<std::size_t>(j)];
            if (oj == 0) return;
            for (int k = 0; k < 3; ++k) {
                const double* u = V(triangles[3 * j + k]);
                const double* v = V(triangles[3 * j + (k + 1) % 3]);
                int w = orient2d_sign(u, v, q);
                // Simulation of simplicity: q + (eps, eps^2) is left of u -> v
                // iff -(v - u)_y > 0, or (v - u)_x > 0 for a horizontal edge
                // (the sign of a difference of two doubles is exact).
                if (w == 0) w = v[1] != u[1] ? (v[1] < u[1] ? 1 : -1) : (v[0] > u[0] ? 1 : -1);
                if (w != oj) return;
            }
            cover += sign[static_cast<std::size_t>(j)];
        });
        if (cover != 1) bad[t] = 1;
    }
    // Outline edges entering a triangle's open interior.
    if (outline) {
        std::vector<StudyArea::Hit> ha, hb;
        for (const auto& kv : uses) {
            if (kv.second.second != 1) continue;
            const std::int64_t ia = static_cast<std::int64_t>(kv.first >> 32);
            const std::int64_t ib = static_cast<std::int64_t>(kv.first & 0xffffffffULL);
            const double *p = V(ia), *q = V(ib);
            if (same_point(p, q)) continue;  // no line: it enters nothing it does not end in
            if (study != nullptr) {
                study->locate(p, ha);
                study->locate(q, hb);
                if (StudyArea::along_one_side(ha, hb, false)) continue;
            }
            const Box2 box{std::min(p[0], q[0]), std::min(p[1], q[1]), std::max(p[0], q[0]), std::max(p[1], q[1])};
            tree.visit(box, [&](std::int64_t j) {
                const std::size_t u = static_cast<std::size_t>(j);
                if (o[u] == 0 || bad[u]) return;
                const double *a = V(triangles[3 * j]), *b = V(triangles[3 * j + 1]), *c = V(triangles[3 * j + 2]);
                if (o[u] > 0 ? segment_meets_open_triangle(p, q, a, b, c) : segment_meets_open_triangle(p, q, a, c, b))
                    bad[u] = 1;
            });
        }
    }
    std::vector<std::int64_t> out;
    for (std::size_t t = 0; t < n_triangles; ++t)
        if (bad[t]) out.push_back(static_cast<std::int64_t>(t));
    return out;
}

std::vector<std::int64_t> triangles_at_outline_crossings(const double* vertices, std::size_t n_vertices,
                                                         std::size_t stride, const std::int64_t* triangles,
                                                         std::size_t n_triangles, const StudyArea* study) {
    const char* fn = "triangles_at_outline_crossings";
    if (stride != 2 && stride != 3) throw std::invalid_argument(std::string(fn) + ": stride must be 2 or 3");
    if (n_triangles == 0) return {};
    // Edges are keyed by their two vertex indices in 32 bits each.
    if (n_vertices > 0xffffffffULL) throw std::invalid_argument(std::string(fn) + ": more than 2^32 - 1 vertices");
    check_used_vertices(fn, vertices, n_vertices, stride, triangles, n_triangles);
    BoundaryContours bc;
    try {
        bc = boundary_contours(triangles, n_triangles, n_vertices);
    } catch (const std::invalid_argument& e) {  // a row that repeats a vertex: named as this function's
        throw std::invalid_argument(std::string(fn) + ": " + e.what());
    }
    const std::vector<detail::OutlineEdge> edges = detail::classify_outline(study, vertices, stride, bc.loops);
    const auto meet = detail::meeting_outline_edges(vertices, n_vertices, stride, edges, false);
    if (meet.empty()) return {};
    // The triangle of an outline edge: the one triangle that uses it.
    std::unordered_map<std::uint64_t, std::int64_t> row;
    row.reserve(3 * n_triangles);
    for (std::size_t t = 0; t < n_triangles; ++t)
        for (int k = 0; k < 3; ++k)
            row.emplace(detail::undirected_edge_key(triangles[3 * t + k], triangles[3 * t + (k + 1) % 3]),
                        static_cast<std::int64_t>(t));
    std::vector<std::int64_t> out;
    for (const auto& m : meet)
        for (const std::size_t i : {m.first, m.second})
            out.push_back(row.at(detail::undirected_edge_key(edges[i].a, edges[i].b)));
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

}  // namespace faultmesh
