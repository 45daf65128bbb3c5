// Stitch step 4, contours: the gap polygons between D's boundary and the
// patch outline R, with the study-area boundary where the patch reaches it
// (stitch.hpp, step 4).
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/study_area.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include "stitch_steps.hpp"

#include <algorithm>
#include <map>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace faultmesh::detail {

namespace {

// Point in polygon (exact parity) for a ring of pointers; p must not be on it.
bool ring_contains(const std::vector<const double*>& ring, const double* p) {
    bool in = false;
    const std::size_t n = ring.size();
    for (std::size_t i = 0; i < n; ++i) {
        const double* u = ring[i];
        const double* v = ring[(i + 1) % n];
        const bool uy = u[1] > p[1], vy = v[1] > p[1];
        if (uy == vy) continue;
        const double o = orient2d(u, v, p);
        if (vy ? o > 0.0 : o < 0.0) in = !in;
    }
    return in;
}

}  // namespace

void build_gap_polygons(const StitcherState& s, StitchJob& job) {
    const std::string& fn = job.fn;
    const std::int64_t nV = job.n_layer_vertices;
    const std::int64_t pid = static_cast<std::int64_t>(s.patch_names.size());
    auto X = [&](std::int64_t g) { return job.X(g); };
    using GEdge = StitchJob::GapEdge;
    std::vector<GEdge>& gedges = job.gap_edges;
    std::map<double, std::vector<std::int64_t>> at_t;  // study-boundary position -> vertices
    std::vector<std::pair<double, int>> events;
    const double perim = s.study.perimeter();
    auto tpos = [&](std::size_t side, double sv) {
        return sv >= s.study.side_length(side) ? s.study.side_start(side + 1) : s.study.side_start(side) + sv;
    };
    auto key_of = [&](double t) { return t >= perim ? 0.0 : t; };
    std::unordered_set<std::uint64_t>& study_keys = job.study_keys;
    auto ekey = edge_key;
    std::unordered_map<std::uint64_t, std::int64_t>& dside = job.dside;
    {
        std::vector<StudyArea::Hit> ha, hb;
        for (std::int64_t h : job.boundary) {
            const std::int64_t a = s.tri[static_cast<std::size_t>(h)];
            const std::int64_t b = s.tri[static_cast<std::size_t>(next_halfedge(h))];
            const std::int64_t o = s.adj[static_cast<std::size_t>(h)];
            if (o >= 0) {
                const std::int64_t orow = o / 3;
                const std::int64_t tag =
                    s.kind[static_cast<std::size_t>(orow)] == static_cast<std::int8_t>(TriangleKind::patch)
                        ? s.owner[static_cast<std::size_t>(orow)]
                        : -1;
                gedges.push_back({a, b, tag});
                dside[ekey(a, b)] = o;
                continue;
            }
            s.study.locate(s.v(a), ha);
            s.study.locate(s.v(b), hb);
            bool ok = false;
            for (const auto& x : ha)
                for (const auto& y : hb)
                    if (!ok && x.side == y.side && x.s < y.s) {
                        ok = true;
                        const double t0 = tpos(x.side, x.s), t1 = tpos(y.side, y.s);
                        at_t[key_of(t0)].push_back(a);
                        at_t[key_of(t1)].push_back(b);
                        events.emplace_back(t0, +1);
                        events.emplace_back(t1, -1);
                    }
            if (!ok)
                throw GeometryError(fn + ": mesh boundary edge (" + std::to_string(a) + ", " +
                                    std::to_string(b) + ") near " + fmt_point(s.v(a)) +
                                    " does not run along the study-area boundary");
        }
        std::vector<StudyArea::Hit> hv;
        for (const auto& e : job.outline) {
            const std::int64_t ga = nV + e.a, gb = nV + e.b;
            // An outline vertex on the study boundary splits the boundary
            // piece D covers there (an event that changes no coverage): a
            // patch that touches the boundary at a vertex -- an end carried
            // onto two sides around a corner, its chord cutting the corner --
            // pinches the gap there into two rings, which the chaining below
            // keeps apart. Without the split the piece runs through the
            // vertex and the gap polygon crosses itself (sweep seeds 112,
            // 145, 183, 242, 271, 397).
            s.study.locate(job.X(ga), hv);
            for (const auto& h : hv) {
                const double t = tpos(h.side, h.s);
                at_t[key_of(t)].push_back(ga);
                events.emplace_back(t, 0);
            }
            if (!e.study) {
                gedges.push_back({gb, ga, pid});
                continue;
            }
            const double t0 = tpos(e.side, e.sa), t1 = tpos(e.side, e.sb);
            at_t[key_of(t0)].push_back(ga);
            at_t[key_of(t1)].push_back(gb);
            study_keys.insert(ekey(ga, gb));  // the patch's own boundary edge keeps no neighbour
            if (t0 < t1) {
                events.emplace_back(t0, -1);
                events.emplace_back(t1, +1);
            } else {
                events.emplace_back(t1, +1);
                events.emplace_back(t0, -1);
            }
        }
    }
    if (!events.empty()) {
        std::unordered_set<std::int64_t> chain_ends;
        for (const auto& e : gedges) {
            chain_ends.insert(e.a);
            chain_ends.insert(e.b);
        }
        auto pick = [&](double t) -> std::int64_t {
            auto it = at_t.find(key_of(t));
            if (it == at_t.end()) return -1;
            std::int64_t best = -1;
            int best_score = -1;
            for (std::int64_t vtx : it->second) {
                const int score = (chain_ends.count(vtx) ? 2 : 0) + (vtx >= nV ? 1 : 0);
                if (score > best_score) best = vtx, best_score = score;
            }
            return best;
        };
        std::sort(events.begin(), events.end());
        int cov = 0;
        std::size_t i = 0;
        while (i < events.size()) {
            const double t = events[i].first;
            while (i < events.size() && events[i].first == t) cov += events[i++].second;
            if (cov < 0 || cov > 1)
                throw GeometryError(fn + ": along the study-area boundary the patch is not inside the "
                                    "removed region (coverage " + std::to_string(cov) + " at arc length " +
                                    std::to_string(t) + ")");
            if (cov == 1 && i < events.size()) {
                const double t2 = events[i].first;
                const std::int64_t va = pick(t), vb = pick(t2);
                if (va < 0 || vb < 0 || va == vb)
                    throw GeometryError(fn + ": internal error: no vertex at a gap corner on the study "
                                        "boundary (arc length " + std::to_string(t) + ")");
                gedges.push_back({va, vb, -1});
                study_keys.insert(ekey(va, vb));
            }
        }
        if (cov != 0)
            throw GeometryError(fn + ": internal error: unbalanced coverage along the study boundary");
    }
    // Chain the gap edges into rings. A vertex with more than one outgoing
    // edge is a pinch of the gap (the patch outline touching the study
    // boundary or D's boundary at a vertex): each edge into it continues
    // with the outgoing edge first clockwise from the way back (the gap is
    // on the left of its edges, so that edge bounds the same wedge), which
    // keeps the two sides of the pinch in separate rings. Besides a patch
    // vertex only a pinch the grower kept may be one (an earlier patch piece
    // touching the study boundary at that vertex alone, D on both of its
    // sides: the same pinch its own gap had); elsewhere D's boundary never
    // touches itself (the grower pulls in the star of a pinch vertex), so a
    // layer vertex with two ways out is an error as before.
    std::vector<std::vector<std::int64_t>>& rings = job.rings;
    std::vector<double>& ring_area = job.ring_area;
    {
        std::unordered_map<std::int64_t, std::vector<std::size_t>> gout;
        std::unordered_map<std::int64_t, int> gin;
        for (std::size_t i = 0; i < gedges.size(); ++i) {
            gout[gedges[i].a].push_back(i);
            ++gin[gedges[i].b];
        }
        for (const auto& vo : gout) {
            const auto it = gin.find(vo.first);
            const int nin = it == gin.end() ? 0 : it->second;
            if (nin != static_cast<int>(vo.second.size()) ||
                (nin > 1 && vo.first < nV &&
                 !std::binary_search(job.kept_pinches.begin(), job.kept_pinches.end(), vo.first)))
                throw GeometryError(fn + ": the gap polygon touches itself at vertex " +
                                    fmt_point(X(vo.first)) +
                                    " (the fault patch is too close to another patch or to the boundary)");
        }
        // Clockwise angle from the ray v->u to the ray v->w, compared exactly:
        // (0, pi) right of v->u first, then the opposite direction, then
        // (pi, 2 pi), the direction of u itself last.
        auto half = [&](const double* v, const double* u, const double* w) {
            const double o = orient2d(v, u, w);
            if (o < 0.0) return 0;
            if (o > 0.0) return 2;
            // Collinear: same or opposite direction. The differences have
            // exact signs and the two products per axis the same sign, so
            // the sign of the sum is exact.
            const bool same = (w[0] - v[0]) * (u[0] - v[0]) + (w[1] - v[1]) * (u[1] - v[1]) > 0.0;
            return same ? 3 : 1;
        };
        auto next_of = [&](std::size_t in) -> std::size_t {
            const std::vector<std::size_t>& outs = gout.at(gedges[in].b);
            if (outs.size() == 1) return outs[0];
            const double* v = X(gedges[in].b);
            const double* u = X(gedges[in].a);
            std::size_t best = outs[0];
            for (std::size_t k = 1; k < outs.size(); ++k) {
                const double* w = X(gedges[outs[k]].b);
                const double* b = X(gedges[best].b);
                const int hw = half(v, u, w), hb = half(v, u, b);
                if (hw < hb || (hw == hb && orient2d(v, b, w) > 0.0))
                    best = outs[k];
            }
            return best;
        };
        std::vector<char> done(gedges.size(), 0);
        for (std::size_t i0 = 0; i0 < gedges.size(); ++i0) {
            if (done[i0]) continue;
            std::vector<std::int64_t> ring;
            std::size_t i = i0;
            while (!done[i]) {
                done[i] = 1;
                ring.push_back(static_cast<std::int64_t>(i));
                if (!gout.count(gedges[i].b))
                    throw GeometryError(fn + ": internal error: the gap boundary is open at vertex " +
                                        fmt_point(X(gedges[i].b)));
                i = next_of(i);
            }
            if (i != i0) throw GeometryError(fn + ": internal error: the gap boundary is not a loop");
            std::vector<const double*> pts;
            for (std::int64_t e : ring) pts.push_back(X(gedges[static_cast<std::size_t>(e)].a));
            const double a2 = ring_area2(pts);
            if (a2 == 0.0)
                throw GeometryError(fn + ": a gap ring has zero area near " + fmt_point(pts[0]));
            ring_area.push_back(a2);
            rings.push_back(std::move(ring));
        }
    }
    std::vector<std::size_t>& outers = job.outers;
    for (std::size_t r = 0; r < rings.size(); ++r)
        if (ring_area[r] > 0.0) outers.push_back(r);
    std::vector<std::vector<std::size_t>>& holes_of = job.holes_of;
    holes_of.assign(rings.size(), {});
    auto ring_pts = [&](std::size_t r) {
        std::vector<const double*> pts;
        for (std::int64_t e : rings[r]) pts.push_back(X(gedges[static_cast<std::size_t>(e)].a));
        return pts;
    };
    for (std::size_t r = 0; r < rings.size(); ++r) {
        if (ring_area[r] > 0.0) continue;
        const double* p = X(gedges[static_cast<std::size_t>(rings[r][0])].a);
        std::size_t best = rings.size();
        for (std::size_t o : outers)
            if (ring_contains(ring_pts(o), p) && (best == rings.size() || ring_area[o] < ring_area[best]))
                best = o;
        if (best == rings.size())
            throw GeometryError(fn + ": a hole of the gap near " + fmt_point(p) +
                                " lies in no outer ring");
        holes_of[best].push_back(r);
    }
}

}  // namespace faultmesh::detail
