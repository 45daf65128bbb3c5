// Stitch step 1, outline: the patch oriented, its boundary loops, the
// checks on them and the region R (stitch.hpp, step 1).
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/boundary.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include "stitch_steps.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>
#include <utility>

namespace faultmesh::detail {

StitchJob::StitchJob(StitcherState& s, const double* patch_vertices, std::size_t n_patch_vertices,
                     std::vector<std::int64_t> patch_triangles, std::string name)
    : pv(patch_vertices), npv(n_patch_vertices), ptri(std::move(patch_triangles)), npt(ptri.size() / 3),
      patch_name(std::move(name)), fn("stitch: layer '" + s.name + "', patch '" + patch_name + "'"),
      hooks(s), n_layer_vertices(static_cast<std::int64_t>(s.xyz.size() / 3)), s_(s) {}

const double* StitchJob::X(std::int64_t g) const {
    return g < n_layer_vertices ? s_.v(g) : P(g - n_layer_vertices);
}

void outline_patch(const StitcherState& s, StitchJob& job) {
    const double* pv = job.pv;
    const std::size_t npv = job.npv, npt = job.npt;
    std::vector<std::int64_t>& ptri = job.ptri;
    const std::string& fn = job.fn;
    auto P = [&](std::int64_t i) { return pv + 3 * i; };
    // Each edge-connected component of the patch is oriented on its own so
    // that its signed XY area is positive (its outer outline CCW): the pieces
    // of a fault group may come lofted in opposite directions.
    {
        std::vector<std::int64_t> parent(npt);
        for (std::size_t t = 0; t < npt; ++t) parent[t] = static_cast<std::int64_t>(t);
        auto find = [&](std::int64_t x) {
            while (parent[static_cast<std::size_t>(x)] != x) {
                parent[static_cast<std::size_t>(x)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
                x = parent[static_cast<std::size_t>(x)];
            }
            return x;
        };
        // Edge-connected: triangles on the two sides of an edge (any
        // orientation: the pieces are not oriented yet).
        AdjacencyLabels labels;
        labels.edge_word = "patch edge";
        const std::vector<std::int64_t> twin =
            halfedge_twins(ptri.data(), npt, npv, EdgeOrientation::any, fn, labels);
        for (std::size_t h = 0; h < 3 * npt; ++h) {
            const std::int64_t o = twin[h];
            if (o < static_cast<std::int64_t>(h)) continue;  // each edge once (and not the boundary)
            const std::int64_t x = find(static_cast<std::int64_t>(h / 3)), y = find(o / 3);
            if (x != y) parent[static_cast<std::size_t>(x)] = y;
        }
        std::unordered_map<std::int64_t, double> sum;
        for (std::size_t t = 0; t < npt; ++t)
            sum[find(static_cast<std::int64_t>(t))] +=
                orient2d(P(ptri[3 * t]), P(ptri[3 * t + 1]), P(ptri[3 * t + 2]));
        for (const auto& cs : sum)
            if (cs.second == 0.0)
                throw GeometryError(fn + ": a piece of the patch has zero signed area in XY");
        for (std::size_t t = 0; t < npt; ++t)
            if (sum[find(static_cast<std::int64_t>(t))] < 0.0) {
                std::swap(ptri[3 * t + 1], ptri[3 * t + 2]);
                job.report.patch_flipped = true;
            }
    }
    BoundaryContours bc = boundary_contours(ptri.data(), npt, npv);
    if (!bc.nonmanifold_edges.empty())
        throw GeometryError(fn + ": patch edge (" + std::to_string(bc.nonmanifold_edges[0]) + ", " +
                            std::to_string(bc.nonmanifold_edges[1]) + ") is used by more than two triangles");
    if (!bc.inconsistent_edges.empty())
        throw GeometryError(fn + ": patch edge (" + std::to_string(bc.inconsistent_edges[0]) + ", " +
                            std::to_string(bc.inconsistent_edges[1]) +
                            ") is used twice in the same direction (inconsistent orientation)");
    if (!bc.pinch_vertices.empty())
        throw GeometryError(fn + ": patch vertex " + std::to_string(bc.pinch_vertices[0]) + " " +
                            fmt_point(P(bc.pinch_vertices[0])) +
                            " is on the patch outline more than once (pinch)");
    if (!bc.open_chains.empty() || bc.loops.empty())
        throw GeometryError(fn + ": the patch outline does not form closed loops");
    for (std::size_t i = 0; i < npv; ++i)
        if (!s.study.contains(P(static_cast<std::int64_t>(i))))
            throw GeometryError(fn + ": patch vertex " + std::to_string(i) + " " +
                                fmt_point(P(static_cast<std::int64_t>(i))) +
                                " lies outside the study area");

    // Outline edges, classified: on the study boundary (same side) or not.
    std::unordered_map<std::int64_t, std::vector<StudyArea::Hit>> hits;
    job.outline = classify_outline(&s.study, pv, 3, bc.loops, &hits);
    const std::vector<OutlineEdge>& oedges = job.outline;
    std::vector<double> ring_xy;
    std::vector<std::int64_t> ring_off{0};
    for (const auto& loop : bc.loops) {
        for (std::int64_t vtx : loop) {
            ring_xy.push_back(P(vtx)[0]);
            ring_xy.push_back(P(vtx)[1]);
        }
        ring_off.push_back(static_cast<std::int64_t>(ring_xy.size() / 2));
    }
    {
        // The patch must stay in the study area: its vertices do (above),
        // so an outline edge leaves the area iff a side crosses it properly
        // (exact orientations). A side an end point lies on (within the
        // study area's tolerance) is skipped: crossing it there is rounding.
        // Such an edge is a fault that runs out of the area and back in
        // between two traces -- across the notch of a non-convex study area
        // (sweep seeds 418, 454) -- and the gap polygon would cross itself.
        std::vector<std::size_t> cand;
        auto on_side = [&](std::int64_t v, std::size_t k) {
            auto h = hits.find(v);
            return h != hits.end() && std::any_of(h->second.begin(), h->second.end(),
                                                  [&](const StudyArea::Hit& x) { return x.side == k; });
        };
        for (const OutlineEdge& e : oedges) {
            if (e.study) continue;
            const double *pa = P(e.a), *pb = P(e.b);
            const double mid[2] = {0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])};
            // A filter only (box distance): the half length, with a margin
            // for the rounding of the midpoint.
            const double r = 0.5 * std::hypot(pb[0] - pa[0], pb[1] - pa[1]) * (1.0 + 1e-9) +
                             s.study.tolerance();
            s.study.sides_near(mid, r, cand);
            for (std::size_t k : cand) {
                if (on_side(e.a, k) || on_side(e.b, k)) continue;
                const double *c = s.study.corner(k), *d = s.study.corner(k + 1);
                const double o1 = orient2d(pa, pb, c), o2 = orient2d(pa, pb, d);
                const double o3 = orient2d(c, d, pa), o4 = orient2d(c, d, pb);
                if (((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0)) &&
                    ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0)))
                    throw GeometryError(
                        fn + ": the patch leaves the study area: its outline edge from " + fmt_point(pa) +
                        " to " + fmt_point(pb) + " crosses the study-area side from " + fmt_point(c) +
                        " to " + fmt_point(d) +
                        " (the fault runs out of the study area and back in between two of its traces, "
                        "e.g. across a notch of a non-convex study area; the stitcher does not clip: "
                        "clip the patch first (clip_to_study_area, StudyArea.clip_surface in Python) "
                        "as the builder does)");
            }
        }
    }
    // Simplicity of the outline away from the study boundary.
    {
        const auto meet = meeting_outline_edges(pv, npv, 3, oedges, true);
        if (!meet.empty()) {
            const OutlineEdge &e = oedges[meet[0].first], &f = oedges[meet[0].second];
            throw GeometryError(fn + ": the patch outline is not simple in XY: edges (" + std::to_string(e.a) +
                                ", " + std::to_string(e.b) + ") and (" + std::to_string(f.a) + ", " +
                                std::to_string(f.b) + ") meet near " + fmt_point(P(e.a)) +
                                " (a reverse fault must end at a pinch-out tip, a zero-throw trace or the "
                                "study-area boundary)");
        }
    }
    // The region R is what the outline encloses: the patch must cover it
    // once, counted with orientation, everywhere (a fold: footwall +, strip
    // -, hanging wall +). A sheet reaching past the others lies outside R
    // and the gap would be laid over it (sweep seed 24: "new triangles: edge
    // ... is used by 4 triangles").
    {
        const std::vector<std::int64_t> bad = triangles_not_covered_once(pv, npv, 3, ptri.data(), npt, &s.study);
        if (!bad.empty()) {
            const std::int64_t* t = ptri.data() + 3 * bad[0];
            const double *a = P(t[0]), *b = P(t[1]), *c = P(t[2]);
            const double q[2] = {(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0};
            throw GeometryError(
                fn + ": the patch does not cover its XY image once, counted with orientation: patch triangle " +
                std::to_string(bad[0]) + " (vertices " + std::to_string(t[0]) + ", " + std::to_string(t[1]) +
                ", " + std::to_string(t[2]) + ", centroid " + fmt_point(q) + ") reaches out of the patch outline " +
                "or lies over another sheet (" + std::to_string(bad.size()) + " triangle(s)): a folded patch " +
                "whose sheets end at different places");
        }
    }
    job.region = Region(ring_xy.data(), ring_off.data(), ring_off.size() - 1);
}

std::vector<OutlineEdge> classify_outline(const StudyArea* study, const double* vertices, std::size_t stride,
                                          const std::vector<std::vector<std::int64_t>>& loops,
                                          std::unordered_map<std::int64_t, std::vector<StudyArea::Hit>>* hits) {
    auto P = [&](std::int64_t i) { return vertices + stride * static_cast<std::size_t>(i); };
    std::unordered_map<std::int64_t, std::vector<StudyArea::Hit>> own;
    auto& at = hits != nullptr ? *hits : own;
    std::vector<OutlineEdge> out;
    std::vector<StudyArea::Hit> tmp;
    if (study != nullptr)
        for (const auto& loop : loops)
            for (std::int64_t vtx : loop) {
                study->locate(P(vtx), tmp);
                if (!tmp.empty()) at[vtx] = tmp;
            }
    for (const auto& loop : loops)
        for (std::size_t i = 0; i < loop.size(); ++i) {
            const std::int64_t a = loop[i], b = loop[(i + 1) % loop.size()];
            OutlineEdge e{a, b, false, 0, 0.0, 0.0};
            auto ia = at.find(a), ib = at.find(b);
            // An edge of length 0 in XY at a point of the study boundary (a
            // vertical fault's footwall and hanging-wall cutoffs carried onto
            // the boundary: two vertices at one XY, their elevations apart by
            // the throw) runs along its side too, from that point to itself:
            // classified as an edge inside the area, it went into the gap
            // polygon as a gap edge there and the gap touched itself at the
            // layer vertex of that point (fuzz
            // test_vertical_fault_carried_onto_the_boundary_builds).
            StudyArea::Hit ha, hb;
            if (ia != at.end() && ib != at.end() &&
                StudyArea::along_one_side(ia->second, ib->second, same_point(P(a), P(b)), &ha, &hb)) {
                e.study = true;
                e.side = ha.side;
                e.sa = ha.s;
                e.sb = hb.s;
            }
            out.push_back(e);
        }
    return out;
}

std::vector<std::pair<std::size_t, std::size_t>> meeting_outline_edges(const double* vertices,
                                                                       std::size_t n_vertices,
                                                                       std::size_t stride,
                                                                       const std::vector<OutlineEdge>& edges,
                                                                       bool first_only) {
    auto P = [&](std::int64_t i) { return vertices + stride * static_cast<std::size_t>(i); };
    std::vector<std::pair<std::size_t, std::size_t>> out;
    if (edges.empty()) return out;
    std::vector<std::int64_t> seg;
    seg.reserve(2 * edges.size());
    for (const auto& e : edges) {
        seg.push_back(e.a);
        seg.push_back(e.b);
    }
    const AabbTree et = AabbTree::from_segments(vertices, n_vertices, stride, seg.data(), edges.size());
    std::vector<std::int64_t> near;
    for (std::size_t i = 0; i < edges.size(); ++i) {
        const OutlineEdge& e = edges[i];
        near.clear();
        et.query(et.box(i), near);
        for (std::int64_t j64 : near) {
            const std::size_t j = static_cast<std::size_t>(j64);
            if (j <= i) continue;
            const OutlineEdge& f = edges[j];
            if (e.study && f.study) continue;
            std::int64_t shared = -1, ea = -1, fb = -1;
            if (e.a == f.a) shared = e.a, ea = e.b, fb = f.b;
            else if (e.a == f.b) shared = e.a, ea = e.b, fb = f.a;
            else if (e.b == f.a) shared = e.b, ea = e.a, fb = f.b;
            else if (e.b == f.b) shared = e.b, ea = e.a, fb = f.a;
            bool meet;
            if (shared >= 0) {
                // Adjacent edges may only share their common vertex: they
                // meet elsewhere iff they fold back onto each other
                // (collinear, the same way from it).
                const double *o = P(shared), *p = P(ea), *q = P(fb);
                meet = orient2d(o, p, q) == 0.0 &&
                       (p[0] - o[0]) * (q[0] - o[0]) + (p[1] - o[1]) * (q[1] - o[1]) > 0.0;
            } else {
                meet = segments_meet(P(e.a), P(e.b), P(f.a), P(f.b));
            }
            if (meet) {
                out.emplace_back(i, j);
                if (first_only) return out;
            }
        }
    }
    return out;
}

}  // namespace faultmesh::detail
