// The study-area polygon: see study_area.hpp.
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/study_area.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace faultmesh {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

StudyArea::StudyArea(const double* pts, std::size_t k, double tolerance) {
    if (pts == nullptr && k) throw std::invalid_argument("StudyArea: null boundary array");
    // The coordinate limit of predicates.hpp: the corners enter orient2d.
    check_coordinates(pts, k, 2, 2, "StudyArea", "boundary");
    // Drop consecutive repeats and a repeated closing point.
    std::vector<double> q;
    q.reserve(2 * k);
    for (std::size_t i = 0; i < k; ++i) {
        const double x = pts[2 * i], y = pts[2 * i + 1];
        if (!q.empty() && q[q.size() - 2] == x && q[q.size() - 1] == y) continue;
        q.push_back(x);
        q.push_back(y);
    }
    while (q.size() >= 4 && q[0] == q[q.size() - 2] && q[1] == q[q.size() - 1]) q.resize(q.size() - 2);
    if (q.size() < 6)
        throw std::invalid_argument("StudyArea: the boundary needs at least 3 distinct points, got " +
                                    std::to_string(q.size() / 2));
    const std::size_t n = q.size() / 2;
    // Orientation: the turn at the lexicographically smallest corner (a
    // convex corner of any simple polygon), decided exactly.
    std::size_t lo = 0;
    for (std::size_t i = 1; i < n; ++i)
        if (q[2 * i] < q[2 * lo] || (q[2 * i] == q[2 * lo] && q[2 * i + 1] < q[2 * lo + 1])) lo = i;
    const double turn = orient2d(&q[2 * ((lo + n - 1) % n)], &q[2 * lo], &q[2 * ((lo + 1) % n)]);
    if (turn == 0.0) {
        // A collinear lowest corner happens only for a degenerate ring.
        double a2 = 0.0;
        for (std::size_t i = 1; i + 1 < n; ++i)
            a2 += orient2d(&q[0], &q[2 * i], &q[2 * (i + 1)]);
        if (a2 == 0.0) throw GeometryError("StudyArea: the boundary polygon has zero area");
    }
    if (turn < 0.0) {
        std::vector<double> r;
        r.reserve(q.size());
        for (std::size_t i = n; i-- > 0;) {
            r.push_back(q[2 * i]);
            r.push_back(q[2 * i + 1]);
        }
        q.swap(r);
    }
    xy_ = std::move(q);
    len_.assign(n, 0.0);
    cum_.assign(n + 1, 0.0);
    double scale = 1.0;
    for (double v : xy_) scale = std::max(scale, std::fabs(v));
    for (std::size_t i = 0; i < n; ++i) {
        const double* a = corner(i);
        const double* b = corner(i + 1);
        len_[i] = std::hypot(b[0] - a[0], b[1] - a[1]);
        cum_[i + 1] = cum_[i] + len_[i];
        seg_.push_back(static_cast<std::int64_t>(i));
        seg_.push_back(static_cast<std::int64_t>((i + 1) % n));
    }
    // See the file comment: constructed boundary points are within a few ulps
    // of the largest coordinate; 64 eps max|c| accepts them with a margin.
    tol_ = tolerance >= 0.0 ? tolerance : 64.0 * std::numeric_limits<double>::epsilon() * scale;
    tree_ = AabbTree::from_segments(xy_.data(), n, 2, seg_.data(), n);

    // The classification grid (see the header): about 4 cells per side,
    // between 16 x 16 and 256 x 256.
    double x0 = kInf, y0 = kInf, x1 = -kInf, y1 = -kInf;
    for (std::size_t i = 0; i < n; ++i) {
        x0 = std::min(x0, xy_[2 * i]), x1 = std::max(x1, xy_[2 * i]);
        y0 = std::min(y0, xy_[2 * i + 1]), y1 = std::max(y1, xy_[2 * i + 1]);
    }
    const long g = std::min(256L, std::max(16L, static_cast<long>(4 * n)));
    gnx_ = gny_ = g;
    gx0_ = x0, gy0_ = y0, gx1_ = x1, gy1_ = y1;
    gcw_ = std::max((x1 - x0) / static_cast<double>(g), 1e-300);
    gch_ = std::max((y1 - y0) / static_cast<double>(g), 1e-300);
    cell_.assign(static_cast<std::size_t>(g * g), 0);
    std::vector<char> near(static_cast<std::size_t>(g * g), 0);
    auto cx = [&](double x) { return std::min(g - 1, std::max(0L, static_cast<long>(std::floor((x - gx0_) / gcw_)))); };
    auto cy = [&](double y) { return std::min(g - 1, std::max(0L, static_cast<long>(std::floor((y - gy0_) / gch_)))); };
    // Mark the cells each side may pass within the tolerance of: the boxes of
    // short pieces of the side (a piece spans at most half a cell), widened by
    // the tolerance plus one cell (conservative against rounding).
    for (std::size_t i = 0; i < n; ++i) {
        const double* a = corner(i);
        const double* b = corner(i + 1);
        const double span = std::max(std::fabs(b[0] - a[0]) / gcw_, std::fabs(b[1] - a[1]) / gch_);
        const long pieces = std::max(1L, static_cast<long>(std::ceil(2.0 * span)));
        for (long k = 0; k < pieces; ++k) {
            const double u0 = static_cast<double>(k) / static_cast<double>(pieces);
            const double u1 = static_cast<double>(k + 1) / static_cast<double>(pieces);
            const double xa = a[0] + u0 * (b[0] - a[0]), xb = a[0] + u1 * (b[0] - a[0]);
            const double ya = a[1] + u0 * (b[1] - a[1]), yb = a[1] + u1 * (b[1] - a[1]);
            const long i0 = cx(std::min(xa, xb) - tol_) - 1, i1 = cx(std::max(xa, xb) + tol_) + 1;
            const long j0 = cy(std::min(ya, yb) - tol_) - 1, j1 = cy(std::max(ya, yb) + tol_) + 1;
            for (long j = std::max(0L, j0); j <= std::min(g - 1, j1); ++j)
                for (long ii = std::max(0L, i0); ii <= std::min(g - 1, i1); ++ii)
                    near[static_cast<std::size_t>(j * g + ii)] = 1;
        }
    }
    for (long j = 0; j < g; ++j)
        for (long ii = 0; ii < g; ++ii) {
            const std::size_t c = static_cast<std::size_t>(j * g + ii);
            if (near[c]) continue;
            const double centre[2] = {gx0_ + (static_cast<double>(ii) + 0.5) * gcw_,
                                      gy0_ + (static_cast<double>(j) + 0.5) * gch_};
            cell_[c] = inside_strictly(centre) ? 2 : 1;
        }
}

int StudyArea::cell_class(const double* p) const {
    if (cell_.empty() || !(p[0] == p[0]) || !(p[1] == p[1])) return 0;
    // Farther than the tolerance beyond the ring's box: outside.
    if (p[0] < gx0_ - tol_ || p[0] > gx1_ + tol_ || p[1] < gy0_ - tol_ || p[1] > gy1_ + tol_) return 1;
    const long i = std::min(gnx_ - 1, std::max(0L, static_cast<long>((p[0] - gx0_) / gcw_)));
    const long j = std::min(gny_ - 1, std::max(0L, static_cast<long>((p[1] - gy0_) / gch_)));
    return cell_[static_cast<std::size_t>(j * gnx_ + i)];
}

double StudyArea::arc_position(const Hit& h) const {
    double t = h.s >= len_[h.side] ? cum_[h.side + 1] : cum_[h.side] + h.s;
    if (t >= perimeter()) t = 0.0;
    return t;
}

void StudyArea::locate(const double* p, std::vector<Hit>& out) const {
    out.clear();
    if (cell_class(p) != 0) return;  // no side within the tolerance
    const Box2 q{p[0] - tol_, p[1] - tol_, p[0] + tol_, p[1] + tol_};
    tree_.visit(q, [&](std::int64_t e) {
        const std::size_t i = static_cast<std::size_t>(e);
        const double* a = corner(i);
        const double* b = corner(i + 1);
        const double dx = b[0] - a[0], dy = b[1] - a[1];
        const double L = len_[i];
        double s = ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / L;
        if (!on_segment(a, b, p)) {
            double c[2];
            place(i, s, c);
            if (std::hypot(p[0] - c[0], p[1] - c[1]) > tol_) return;
        }
        // Within the tolerance of a corner the point IS the corner, so that
        // every description of a corner gives the same arc position.
        if (s <= tol_ || (p[0] == a[0] && p[1] == a[1])) s = 0.0;
        if (s >= L - tol_ || (p[0] == b[0] && p[1] == b[1])) s = L;
        out.push_back({i, s});
    });
}

bool StudyArea::on_boundary(const double* p) const {
    std::vector<Hit> hits;
    locate(p, hits);
    return !hits.empty();
}

bool StudyArea::along_one_side(const std::vector<Hit>& ha, const std::vector<Hit>& hb, bool same_xy, Hit* on_a,
                               Hit* on_b) {
    for (const Hit& x : ha)
        for (const Hit& y : hb)
            if (x.side == y.side && (x.s != y.s || same_xy)) {
                if (on_a != nullptr) *on_a = x;
                if (on_b != nullptr) *on_b = y;
                return true;
            }
    return false;
}

bool StudyArea::inside_strictly(const double* p) const {
    // Parity of the crossings of the ray to +x, exact (orient2d).
    bool in = false;
    tree_.visit(Box2{p[0], p[1], kInf, p[1]}, [&](std::int64_t e) {
        const double* u = corner(static_cast<std::size_t>(e));
        const double* v = corner(static_cast<std::size_t>(e) + 1);
        const bool uy = u[1] > p[1], vy = v[1] > p[1];
        if (uy == vy) return;
        const double o = orient2d(u, v, p);
        if (vy ? o > 0.0 : o < 0.0) in = !in;
    });
    return in;
}

bool StudyArea::contains(const double* p) const {
    const int c = cell_class(p);
    if (c != 0) return c == 2;
    return on_boundary(p) || inside_strictly(p);
}

void StudyArea::place(std::size_t side, double s, double* out) const {
    const double* a = corner(side);
    const double* b = corner(side + 1);
    const double L = len_[side];
    if (!(s > 0.0)) {
        out[0] = a[0], out[1] = a[1];
        return;
    }
    if (s >= L) {
        out[0] = b[0], out[1] = b[1];
        return;
    }
    const double u = s / L;
    // a + u (b - a) per coordinate: exact where b - a is 0 (axis-parallel
    // sides); kept inside the side's box against rounding.
    for (int k = 0; k < 2; ++k) {
        const double v = a[k] + u * (b[k] - a[k]);
        out[k] = std::min(std::max(v, std::min(a[k], b[k])), std::max(a[k], b[k]));
    }
}

StudyArea::Nearest StudyArea::nearest(const double* p, double max_distance) const {
    Nearest best;
    best.distance = max_distance;
    const Box2 q{p[0] - max_distance, p[1] - max_distance, p[0] + max_distance, p[1] + max_distance};
    tree_.visit(q, [&](std::int64_t e) {
        const std::size_t i = static_cast<std::size_t>(e);
        const double* a = corner(i);
        const double* b = corner(i + 1);
        const double dx = b[0] - a[0], dy = b[1] - a[1];
        const double L = len_[i];
        const double s = std::min(L, std::max(0.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / L));
        double c[2];
        place(i, s, c);
        const double d = on_segment(a, b, p) ? 0.0 : std::hypot(p[0] - c[0], p[1] - c[1]);
        if (d <= best.distance && (!best.found || d < best.distance)) {
            best.found = true;
            best.side = i;
            best.s = s;
            best.distance = d;
        }
    });
    return best;
}

void StudyArea::sides_near(const double* p, double r, std::vector<std::size_t>& out) const {
    out.clear();
    tree_.visit(Box2{p[0] - r, p[1] - r, p[0] + r, p[1] + r},
                [&](std::int64_t e) { out.push_back(static_cast<std::size_t>(e)); });
}

StudyArea::RayHit StudyArea::ray_hit(const double* p, const double* d) const {
    RayHit best;
    best.t = kInf;
    {
        std::vector<Hit> hits;
        locate(p, hits);
        if (!hits.empty()) {
            best.t = 0.0;
            best.side = hits[0].side;
            best.s = hits[0].s;
            return best;
        }
    }
    const double dd = d[0] * d[0] + d[1] * d[1];
    if (!(dd > 0.0) || !std::isfinite(dd)) return best;
    // The ray's line through p and q = p + d (scaled to the polygon's size so
    // that q is not lost in p's rounding). Side a-b crosses the line iff a and
    // b are not strictly on the same side of it (exact); the crossing is at
    // the fraction oa / (oa - ob) along the side.
    double ext = 0.0;
    for (std::size_t i = 0; i < n_sides(); ++i)
        ext = std::max(ext, std::max(std::fabs(corner(i)[0] - p[0]), std::fabs(corner(i)[1] - p[1])));
    const double scale = (ext > 0.0 ? ext : 1.0) / std::sqrt(dd);
    const double q[2] = {p[0] + scale * d[0], p[1] + scale * d[1]};
    for (std::size_t i = 0; i < n_sides(); ++i) {
        const double* a = corner(i);
        const double* b = corner(i + 1);
        const double oa = orient2d(p, q, a), ob = orient2d(p, q, b);
        if ((oa > 0.0 && ob > 0.0) || (oa < 0.0 && ob < 0.0)) continue;
        double s;
        if (oa == 0.0 && ob == 0.0) {
            // The side lies on the ray's line: the nearer end ahead of p.
            const double ta = (a[0] - p[0]) * d[0] + (a[1] - p[1]) * d[1];
            const double tb = (b[0] - p[0]) * d[0] + (b[1] - p[1]) * d[1];
            if (ta < 0.0 && tb < 0.0) continue;
            s = (ta >= 0.0 && (tb < 0.0 || ta <= tb)) ? 0.0 : len_[i];
        } else {
            s = len_[i] * (oa / (oa - ob));
        }
        // A hit within the tolerance of a corner is the corner (as in locate).
        if (s <= tol_) s = 0.0;
        if (s >= len_[i] - tol_) s = len_[i];
        double c[2];
        place(i, s, c);
        const double t = ((c[0] - p[0]) * d[0] + (c[1] - p[1]) * d[1]) / dd;
        if (t < 0.0) continue;
        if (t < best.t) {
            best.t = t;
            best.side = i;
            best.s = s;
        }
    }
    return best;
}

}  // namespace faultmesh
