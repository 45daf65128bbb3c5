// A triangulated surface clipped to the study area: see study_area.hpp
// (clip_to_study_area).
#include <faultmesh/ear_clipping.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/study_area.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace faultmesh {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A point of a triangle's boundary walk: an output vertex with its
// coordinates and, if it lies on the study-area boundary, its arc position
// (NaN otherwise).
struct WalkPoint {
    std::int64_t id;
    double x, y, z;
    double arc;
};

std::string fmt_xy(double x, double y) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "(%.10g, %.10g)", x, y);
    return buf;
}

}  // namespace

ClippedSurface clip_to_study_area(const StudyArea& area, const double* vertices, std::size_t n_vertices,
                                  const std::int64_t* triangles, std::size_t n_triangles,
                                  const std::string& what) {
    const std::string fn = "clip_to_study_area: " + what;
    if ((vertices == nullptr && n_vertices) || (triangles == nullptr && n_triangles))
        throw std::invalid_argument(fn + ": null array");
    for (std::size_t i = 0; i < 3 * n_triangles; ++i)
        if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= n_vertices)
            throw std::invalid_argument(fn + ": triangle " + std::to_string(i / 3) + " has vertex index " +
                                        std::to_string(triangles[i]) + " out of range [0, " +
                                        std::to_string(n_vertices) + ")");
    check_coordinates(vertices, n_vertices, 3, 2, "clip_to_study_area", "vertices");

    std::vector<double> V(vertices, vertices + 3 * n_vertices);
    std::vector<std::int64_t> T;
    T.reserve(3 * n_triangles);
    ClippedSurface out;

    // Per input vertex, lazily: the sides it lies on (StudyArea::locate).
    std::vector<std::vector<StudyArea::Hit>> hits(n_vertices);
    std::vector<char> located(n_vertices, 0);
    auto hits_of = [&](std::int64_t v) -> const std::vector<StudyArea::Hit>& {
        if (!located[static_cast<std::size_t>(v)]) {
            area.locate(vertices + 3 * v, hits[static_cast<std::size_t>(v)]);
            located[static_cast<std::size_t>(v)] = 1;
        }
        return hits[static_cast<std::size_t>(v)];
    };
    auto on_side = [&](std::int64_t v, std::size_t k) {
        for (const auto& h : hits_of(v))
            if (h.side == k) return true;
        return false;
    };
    auto arc_of = [&](std::int64_t v) {
        const auto& h = hits_of(v);
        return h.empty() ? kNaN : area.arc_position(h[0]);
    };
    auto add_vertex = [&](double x, double y, double z) {
        V.push_back(x);
        V.push_back(y);
        V.push_back(z);
        return static_cast<std::int64_t>(V.size() / 3 - 1);
    };
    // New vertices on an edge, shared by the edge's two triangles: key
    // (lower vertex, higher vertex, side k) for a crossing, (.., -1 - c) for
    // corner c on the open edge.
    std::map<std::tuple<std::int64_t, std::int64_t, std::int64_t>, std::int64_t> edge_points;
    const double per = area.perimeter();
    const std::size_t n_corners = area.n_sides();

    std::vector<std::size_t> cand, corners;
    std::vector<std::pair<double, WalkPoint>> events;
    std::vector<WalkPoint> pts;
    std::vector<char> inside, used;
    std::vector<WalkPoint> loop;
    std::vector<std::vector<WalkPoint>> loops;
    std::vector<double> xy;
    std::vector<std::pair<double, std::size_t>> passed;

    for (std::size_t t = 0; t < n_triangles; ++t) {
        const std::int64_t* tri = triangles + 3 * t;
        std::int64_t v[3] = {tri[0], tri[1], tri[2]};
        const double* p[3] = {vertices + 3 * v[0], vertices + 3 * v[1], vertices + 3 * v[2]};
        auto keep_whole = [&] { T.insert(T.end(), tri, tri + 3); };
        // Sides that may meet the triangle: those whose box comes within the
        // tolerance of the triangle's box (a square query around its centre).
        double x0 = std::min({p[0][0], p[1][0], p[2][0]}), x1 = std::max({p[0][0], p[1][0], p[2][0]});
        double y0 = std::min({p[0][1], p[1][1], p[2][1]}), y1 = std::max({p[0][1], p[1][1], p[2][1]});
        const double centre[2] = {0.5 * (x0 + x1), 0.5 * (y0 + y1)};
        // Half the larger box extent, widened by the tolerance and by a
        // relative 1e-9 against the rounding of the centre.
        const double r = 0.5 * std::max(x1 - x0, y1 - y0) * (1.0 + 1e-9) + area.tolerance();
        area.sides_near(centre, r, cand);
        if (cand.empty()) {
            // No side near: wholly inside or wholly outside.
            if (area.contains(p[0])) keep_whole();
            else ++out.n_dropped;
            continue;
        }
        double o = orient2d(p[0], p[1], p[2]);
        if (o == 0.0) {
            // No XY area (a vertical triangle): nothing to cut in XY; kept
            // if its three vertices are in the area.
            if (area.contains(p[0]) && area.contains(p[1]) && area.contains(p[2])) keep_whole();
            else ++out.n_dropped;
            continue;
        }
        // The walk runs counter-clockwise; a CW triangle (a folded sheet)
        // is walked reversed and its pieces are reversed back.
        const bool flip = o < 0.0;
        if (flip) {
            std::swap(v[1], v[2]);
            std::swap(p[1], p[2]);
            o = -o;
        }
        corners.clear();
        for (std::size_t k : cand) {
            corners.push_back(k);
            corners.push_back((k + 1) % n_corners);
        }
        std::sort(corners.begin(), corners.end());
        corners.erase(std::unique(corners.begin(), corners.end()), corners.end());

        // The boundary of the triangle as a cyclic walk: each vertex, then
        // the points where sides cross the edge that starts there, in order.
        pts.clear();
        bool any_event = false;
        for (int j = 0; j < 3; ++j) {
            const std::int64_t a = v[j], b = v[(j + 1) % 3];
            const std::int64_t lo = std::min(a, b), hi = std::max(a, b);
            const double *pl = vertices + 3 * lo, *ph = vertices + 3 * hi;
            pts.push_back({a, p[j][0], p[j][1], p[j][2], arc_of(a)});
            events.clear();
            for (std::size_t k : cand) {
                // An end of the edge on side k meets it there: rounding, not a crossing.
                if (on_side(lo, k) || on_side(hi, k)) continue;
                const double *c = area.corner(k), *d = area.corner(k + 1);
                const double o1 = orient2d(pl, ph, c), o2 = orient2d(pl, ph, d);
                const double o3 = orient2d(c, d, pl), o4 = orient2d(c, d, ph);
                if (!(((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0)) &&
                      ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0))))
                    continue;
                const double u = o3 / (o3 - o4);  // along lo -> hi
                const auto key = std::make_tuple(lo, hi, static_cast<std::int64_t>(k));
                auto it = edge_points.find(key);
                std::int64_t id;
                if (it == edge_points.end()) {
                    double q[2];
                    area.place(k, area.side_length(k) * (o1 / (o1 - o2)), q);
                    id = add_vertex(q[0], q[1], pl[2] + u * (ph[2] - pl[2]));
                    edge_points.emplace(key, id);
                } else {
                    id = it->second;
                }
                const double* q = V.data() + 3 * id;
                std::vector<StudyArea::Hit> h;
                area.locate(q, h);
                const double arc = h.empty() ? kNaN : area.arc_position(h[0]);
                events.push_back({a == lo ? u : 1.0 - u, {id, q[0], q[1], q[2], arc}});
            }
            for (std::size_t c : corners) {
                const double* q = area.corner(c);
                if (orient2d(pl, ph, q) != 0.0 || !strictly_between(pl, ph, q)) continue;
                const std::size_t ax = pl[0] != ph[0] ? 0 : 1;
                const double u = (q[ax] - pl[ax]) / (ph[ax] - pl[ax]);
                const auto key = std::make_tuple(lo, hi, -1 - static_cast<std::int64_t>(c));
                auto it = edge_points.find(key);
                std::int64_t id;
                if (it == edge_points.end()) {
                    id = add_vertex(q[0], q[1], pl[2] + u * (ph[2] - pl[2]));
                    edge_points.emplace(key, id);
                } else {
                    id = it->second;
                }
                events.push_back({a == lo ? u : 1.0 - u, {id, q[0], q[1], V[3 * id + 2], area.side_start(c)}});
            }
            std::sort(events.begin(), events.end(),
                      [](const auto& x, const auto& y) { return x.first < y.first; });
            for (const auto& e : events) pts.push_back(e.second);
            any_event |= !events.empty();
        }
        // Each piece of the walk (pts[i] -> pts[i + 1]) lies wholly inside or
        // wholly outside the area (every crossing is a walk point): its
        // midpoint decides (a piece along a side is on the boundary: inside).
        const std::size_t n = pts.size();
        inside.assign(n, 0);
        std::size_t n_inside = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const WalkPoint &a = pts[i], &b = pts[(i + 1) % n];
            const double m[2] = {0.5 * (a.x + b.x), 0.5 * (a.y + b.y)};
            inside[i] = area.contains(m) ? 1 : 0;
            n_inside += inside[i];
        }
        // Corners strictly inside the triangle.
        auto corner_inside = [&](std::size_t c) {
            const double* q = area.corner(c);
            return orient2d(p[0], p[1], q) > 0.0 && orient2d(p[1], p[2], q) > 0.0 &&
                   orient2d(p[2], p[0], q) > 0.0;
        };
        const bool corner_in = std::any_of(corners.begin(), corners.end(), corner_inside);
        auto fail = [&](const std::string& why) {
            throw GeometryError(fn + ": triangle " + std::to_string(t) + " (vertices " + std::to_string(tri[0]) +
                                ", " + std::to_string(tri[1]) + ", " + std::to_string(tri[2]) + " near " +
                                fmt_xy(centre[0], centre[1]) + "): " + why);
        };
        if (n_inside == 0) {
            ++out.n_dropped;
            continue;
        }
        if (n_inside == n && !any_event) {
            if (corner_in)
                fail("a corner of the study area lies inside it but no side crosses its edges "
                     "(the boundary enters it through a vertex)");
            keep_whole();
            continue;
        }
        // The kept part: the inside pieces of the triangle's boundary, joined
        // by the study-area boundary (counter-clockwise, like the walk) from
        // each point where the walk leaves the area to the next point where
        // it comes back in.
        used.assign(n, 0);
        loops.clear();
        for (std::size_t start = 0; start < n; ++start) {
            if (!inside[start] || used[start]) continue;
            loop.clear();
            std::size_t cur = start;
            for (;;) {
                if (used[cur]) fail("its boundary walk returns to a piece already used");
                used[cur] = 1;
                loop.push_back(pts[cur]);
                const std::size_t nx = (cur + 1) % n;
                if (inside[nx]) {
                    if (nx == start) break;
                    cur = nx;
                    continue;
                }
                const WalkPoint& leave = pts[nx];
                if (std::isnan(leave.arc))
                    fail("its edge leaves the study area at " + fmt_xy(leave.x, leave.y) +
                         ", not on the boundary");
                loop.push_back(leave);
                // The next point where the walk comes back in, forward along
                // the study-area boundary.
                std::size_t best = n;
                double bestd = std::numeric_limits<double>::infinity();
                for (std::size_t j = 0; j < n; ++j) {
                    if (!inside[j] || inside[(j + n - 1) % n] || std::isnan(pts[j].arc)) continue;
                    double d = pts[j].arc - leave.arc;
                    if (d < 0.0) d += per;
                    if (d < bestd) bestd = d, best = j;
                }
                if (best == n) fail("the study-area boundary from " + fmt_xy(leave.x, leave.y) +
                                    " does not come back into it");
                // The corners passed on the way, with the triangle's z there.
                passed.clear();
                for (std::size_t c = 0; c < n_corners; ++c) {
                    double d = area.side_start(c) - leave.arc;
                    if (d < 0.0) d += per;
                    if (d > 0.0 && d < bestd) passed.push_back({d, c});
                }
                std::sort(passed.begin(), passed.end());
                for (const auto& pc : passed) {
                    const double* q = area.corner(pc.second);
                    // Barycentric weights in XY (o > 0: the CCW area).
                    const double w0 = orient2d(p[1], p[2], q) / o, w1 = orient2d(p[2], p[0], q) / o;
                    const double z = w0 * p[0][2] + w1 * p[1][2] + (1.0 - w0 - w1) * p[2][2];
                    loop.push_back({add_vertex(q[0], q[1], z), q[0], q[1], z, area.side_start(pc.second)});
                }
                if (best == start) break;
                cur = best;
            }
            loops.push_back(loop);
        }
        ++out.n_cut;
        for (auto& lp : loops) {
            // Consecutive repeats (a leave point that is the next walk point).
            std::vector<WalkPoint> ring;
            for (const auto& w : lp)
                if (ring.empty() || ring.back().id != w.id) ring.push_back(w);
            while (ring.size() > 1 && ring.front().id == ring.back().id) ring.pop_back();
            if (ring.size() < 3) continue;
            xy.clear();
            for (const auto& w : ring) {
                xy.push_back(w.x);
                xy.push_back(w.y);
            }
            const std::int64_t off[2] = {0, static_cast<std::int64_t>(ring.size())};
            const std::vector<std::int64_t> tr = triangulate_polygon(xy.data(), off, 1);
            for (std::size_t i = 0; i < tr.size(); i += 3) {
                const std::int64_t a = ring[static_cast<std::size_t>(tr[i])].id;
                const std::int64_t b = ring[static_cast<std::size_t>(tr[i + 1])].id;
                const std::int64_t c = ring[static_cast<std::size_t>(tr[i + 2])].id;
                T.push_back(a);
                if (flip) {
                    T.push_back(c);
                    T.push_back(b);
                } else {
                    T.push_back(b);
                    T.push_back(c);
                }
            }
        }
    }

    // Compact: only the vertices of kept triangles.
    const std::size_t nv = V.size() / 3;
    std::vector<std::int64_t> remap(nv, -1);
    for (std::int64_t i : T) remap[static_cast<std::size_t>(i)] = 0;
    std::int64_t next = 0;
    for (std::size_t i = 0; i < nv; ++i)
        if (remap[i] == 0) {
            remap[i] = next++;
            out.vertices.insert(out.vertices.end(), V.begin() + 3 * static_cast<std::ptrdiff_t>(i),
                                V.begin() + 3 * static_cast<std::ptrdiff_t>(i) + 3);
            out.vertex_of.push_back(i < n_vertices ? static_cast<std::int64_t>(i) : -1);
        }
    out.triangles.reserve(T.size());
    for (std::int64_t i : T) out.triangles.push_back(remap[static_cast<std::size_t>(i)]);
    return out;
}

}  // namespace faultmesh
