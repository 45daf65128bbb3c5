// Stratum TINs and the layer-crossing repair: see layer_tin.hpp.
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/layer_tin.hpp>
#include <faultmesh/predicates.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "point_grid.hpp"

namespace faultmesh {
namespace detail {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt_xy(const double* p) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "(%.10g, %.10g)", p[0], p[1]);
    return buf;
}

// Eigenvalues of a symmetric 3x3 matrix (cyclic Jacobi; converges in a few
// sweeps for 3x3).
std::array<double, 3> sym3_eigenvalues(std::array<double, 9> a) {
    for (int sweep = 0; sweep < 50; ++sweep) {
        const double off = a[1] * a[1] + a[2] * a[2] + a[5] * a[5];
        const double diag = a[0] * a[0] + a[4] * a[4] + a[8] * a[8];
        if (off <= 1e-30 * diag) break;
        for (int p = 0; p < 2; ++p)
            for (int q = p + 1; q < 3; ++q) {
                const double apq = a[3 * p + q];
                if (apq == 0.0) continue;
                const double app = a[3 * p + p], aqq = a[3 * q + q];
                const double theta = (aqq - app) / (2.0 * apq);
                const double t = (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
                const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < 3; ++k) {
                    const double akp = a[3 * k + p], akq = a[3 * k + q];
                    a[3 * k + p] = c * akp - s * akq;
                    a[3 * k + q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; ++k) {
                    const double apk = a[3 * p + k], aqk = a[3 * q + k];
                    a[3 * p + k] = c * apk - s * aqk;
                    a[3 * q + k] = s * apk + c * aqk;
                }
            }
    }
    return {a[0], a[4], a[8]};
}

// Solves the 3x3 system m x = b by Gaussian elimination with partial pivoting.
bool solve3(std::array<double, 9> m, std::array<double, 3> b, std::array<double, 3>& x) {
    for (int c = 0; c < 3; ++c) {
        int piv = c;
        for (int r = c + 1; r < 3; ++r)
            if (std::fabs(m[3 * r + c]) > std::fabs(m[3 * piv + c])) piv = r;
        if (m[3 * piv + c] == 0.0) return false;
        if (piv != c) {
            for (int k = 0; k < 3; ++k) std::swap(m[3 * c + k], m[3 * piv + k]);
            std::swap(b[c], b[piv]);
        }
        for (int r = c + 1; r < 3; ++r) {
            const double f = m[3 * r + c] / m[3 * c + c];
            for (int k = c; k < 3; ++k) m[3 * r + k] -= f * m[3 * c + k];
            b[r] -= f * b[c];
        }
    }
    for (int r = 2; r >= 0; --r) {
        double v = b[r];
        for (int k = r + 1; k < 3; ++k) v -= m[3 * r + k] * x[k];
        x[r] = v / m[3 * r + r];
    }
    return std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]);
}

}  // namespace

// z at q from an inverse-distance weighted plane fit to the k nearest data
// points (see layer_tin.hpp); data: 3 per point.
double plane_fit_z(const PointGrid& grid, const std::vector<double>& data, const double* q, int k,
                   double lo, double hi) {
    const auto nb = grid.nearest(q, static_cast<std::size_t>(std::max(1, k)));
    double exact_sum = 0.0;
    int exact_n = 0;
    double dmax = 0.0;
    for (const auto& e : nb) {
        if (e.second == 0.0) {
            exact_sum += data[3 * static_cast<std::size_t>(e.first) + 2];
            ++exact_n;
        }
        dmax = std::max(dmax, e.second);
    }
    if (exact_n) return exact_sum / exact_n;
    // Weights 1/d^2 with a floor that only matters for d ~ 0 (handled above).
    std::array<double, 9> m{};
    std::array<double, 3> rhs{};
    double wsum = 0.0, wz = 0.0;
    const double scale = dmax > 0.0 ? dmax : 1.0;
    for (const auto& e : nb) {
        const double* p = &data[3 * static_cast<std::size_t>(e.first)];
        const double w = 1.0 / (e.second * e.second + 1e-12 * (1.0 + dmax * dmax));
        wsum += w;
        wz += w * p[2];
        const double a[3] = {1.0, (p[0] - q[0]) / scale, (p[1] - q[1]) / scale};
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) m[3 * r + c] += w * a[r] * a[c];
            rhs[r] += w * a[r] * p[2];
        }
    }
    const double idw = wz / wsum;
    const double pad = 0.5 * (hi - lo) + 1.0;
    if (nb.size() >= 3) {
        // Use the fit when the weighted design matrix is well conditioned:
        // its singular values (square roots of m's eigenvalues) within a
        // factor 1e6 of each other, i.e. the neighbours are not collinear.
        const auto ev = sym3_eigenvalues(m);
        const double emax = std::max(ev[0], std::max(ev[1], ev[2]));
        const double emin = std::min(ev[0], std::min(ev[1], ev[2]));
        std::array<double, 3> c{};
        if (emin > 1e-12 * emax && solve3(m, rhs, c)) return std::min(std::max(c[0], lo - pad), hi + pad);
    }
    return idw;
}

// Boundary vertex bookkeeping: per side, the boundary vertices by arc
// length s in [0, side length). A piece runs from an entry to the next entry
// of its side, or to the next side's corner (s = 0 there).
struct LayerTinState {
    std::string name;
    StudyArea area;
    LayerTinOptions opt;
    double spacing = 0.0;
    std::size_t n_data = 0, n_outside = 0, n_boundary_data = 0;
    std::optional<Tin> tin;  // set at the end of the constructor
    std::vector<std::map<double, std::int64_t>> by_side;
    std::vector<char> on_boundary;  // per TIN vertex

    void mark_boundary(std::int64_t v) {
        if (static_cast<std::size_t>(v) >= on_boundary.size()) on_boundary.resize(static_cast<std::size_t>(v) + 1, 0);
        on_boundary[static_cast<std::size_t>(v)] = 1;
    }
};

}  // namespace detail

using detail::LayerTinState;

namespace {

// One boundary piece: from vertex a at (side, sa) to vertex b at arc sb on the
// same side (sb = side length when b is the next corner).
struct Piece {
    std::size_t side;
    double sa, sb;
    std::int64_t a, b;
};

Piece piece_at(const LayerTinState& s, std::size_t side, std::map<double, std::int64_t>::const_iterator it) {
    const auto& m = s.by_side[side];
    auto nx = std::next(it);
    Piece p{side, it->first, 0.0, it->second, -1};
    if (nx != m.end()) {
        p.sb = nx->first;
        p.b = nx->second;
    } else {
        const std::size_t ns = (side + 1) % s.area.n_sides();
        p.sb = s.area.side_length(side);
        p.b = s.by_side[ns].begin()->second;
    }
    return p;
}

}  // namespace

// ---------------------------------------------------------------- set-up
LayerTin::LayerTin(std::string name, const double* data, std::size_t n, const StudyArea& area,
                   const LayerTinOptions& options)
    : s_(std::make_unique<LayerTinState>()) {
    LayerTinState& s = *s_;
    s.name = std::move(name);
    s.area = area;
    s.opt = options;
    const std::string fn = "LayerTin('" + s.name + "')";
    if (data == nullptr && n) throw std::invalid_argument(fn + ": null data array");
    for (std::size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k)
            if (!std::isfinite(data[3 * i + k]))
                throw std::invalid_argument(fn + ": data point " + std::to_string(i) +
                                            " has a non-finite coordinate");
    const std::size_t ns = area.n_sides();
    // Data in the study area; those on its boundary go to their side.
    std::vector<double> used;  // 3 per used data point (interior and boundary)
    used.reserve(3 * n);
    std::vector<std::vector<std::pair<double, double>>> side_data(ns);  // (s, z) of boundary data
    std::vector<std::array<double, 2>> side_xy_tmp;
    std::vector<double> interior;
    interior.reserve(3 * n);
    std::vector<StudyArea::Hit> hits;
    struct BData {
        std::size_t side;
        double s, x, y, z;
    };
    std::vector<BData> bdata;
    for (std::size_t i = 0; i < n; ++i) {
        const double* p = data + 3 * i;
        area.locate(p, hits);
        if (!hits.empty()) {
            // A corner is the start of the side that begins there.
            StudyArea::Hit h = hits[0];
            for (const auto& x : hits)
                if (x.s == 0.0) h = x;
            if (h.s >= area.side_length(h.side)) h = {(h.side + 1) % ns, 0.0};
            bdata.push_back({h.side, h.s, p[0], p[1], p[2]});
            used.insert(used.end(), p, p + 3);
            continue;
        }
        if (!area.contains(p)) {
            ++s.n_outside;
            continue;
        }
        interior.insert(interior.end(), p, p + 3);
        used.insert(used.end(), p, p + 3);
    }
    s.n_data = used.size() / 3;
    s.n_boundary_data = bdata.size();
    if (s.n_data == 0) throw GeometryError(fn + ": no data point lies in the study area");
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t i = 0; i < s.n_data; ++i) {
        lo = std::min(lo, used[3 * i + 2]);
        hi = std::max(hi, used[3 * i + 2]);
    }
    // Spacing: about the data spacing, clamped so that a side gets at least
    // a few and at most a few thousand pieces.
    const std::vector<double>& ring = area.ring();
    double a2 = 0.0;
    for (std::size_t i = 0; i < ns; ++i) {
        const double* p = area.corner(i);
        const double* q = area.corner(i + 1);
        a2 += (p[0] - ring[0]) * (q[1] - ring[1]) - (q[0] - ring[0]) * (p[1] - ring[1]);
    }
    const double perim = area.perimeter();
    double spacing = options.spacing > 0.0 ? options.spacing
                                           : std::sqrt(0.5 * std::fabs(a2) / static_cast<double>(s.n_data));
    spacing = std::min(std::max(spacing, perim / 4000.0), perim / 12.0);
    s.spacing = spacing;

    // Boundary vertices per side: corners, densification, data on the side
    // (a data point at the position of a densification point replaces it).
    struct BPoint {
        double s;
        bool known;
        double x, y, z;
    };
    std::vector<std::vector<BPoint>> per_side(ns);
    for (std::size_t i = 0; i < ns; ++i) {
        const double L = area.side_length(i);
        const std::size_t k = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(L / spacing)));
        for (std::size_t j = 0; j < k; ++j) {
            const double sv = L * static_cast<double>(j) / static_cast<double>(k);
            double xy[2];
            area.place(i, sv, xy);
            per_side[i].push_back({sv, false, xy[0], xy[1], detail::kNaN});
        }
    }
    for (const auto& b : bdata) per_side[b.side].push_back({b.s, true, b.x, b.y, b.z});
    detail::PointGrid data_grid(used.data(), s.n_data, 3);
    std::vector<double> pts;  // boundary vertices first, then interior data
    std::vector<std::pair<std::size_t, double>> bpos;
    for (std::size_t i = 0; i < ns; ++i) {
        auto& v = per_side[i];
        std::stable_sort(v.begin(), v.end(), [](const BPoint& a, const BPoint& b) {
            return a.s < b.s || (a.s == b.s && a.known && !b.known);
        });
        for (std::size_t j = 0; j < v.size(); ++j) {
            if (j > 0 && v[j].s == v[j - 1].s) continue;  // the known one came first
            double z = v[j].z;
            if (!v[j].known) {
                const double q[2] = {v[j].x, v[j].y};
                z = detail::plane_fit_z(data_grid, used, q, options.plane_fit_neighbours, lo, hi);
            }
            pts.push_back(v[j].x);
            pts.push_back(v[j].y);
            pts.push_back(z);
            bpos.emplace_back(i, v[j].s);
        }
    }
    const std::size_t nb = bpos.size();
    pts.insert(pts.end(), interior.begin(), interior.end());

    // Protection: split pieces whose closed diametral disk holds another vertex.
    s.by_side.assign(ns, {});
    std::vector<std::pair<std::size_t, double>> pos = bpos;  // per point of pts: (side, s) or (npos, 0)
    pos.resize(pts.size() / 3, {static_cast<std::size_t>(-1), 0.0});
    for (std::size_t i = 0; i < nb; ++i) s.by_side[bpos[i].first].emplace(bpos[i].second, static_cast<std::int64_t>(i));
    detail::PointGrid grid(pts.data(), pts.size() / 3, 3);
    std::vector<std::pair<std::size_t, double>> work;  // (side, sa) of pieces to check
    for (std::size_t i = 0; i < ns; ++i)
        for (const auto& e : s.by_side[i]) work.emplace_back(i, e.first);
    const double min_piece = 1e-9 * perim;
    while (!work.empty()) {
        const auto w = work.back();
        work.pop_back();
        auto it = s.by_side[w.first].find(w.second);
        if (it == s.by_side[w.first].end()) continue;
        const Piece pc = piece_at(s, w.first, it);
        const double* pa = &pts[3 * static_cast<std::size_t>(pc.a)];
        const double* pb = &pts[3 * static_cast<std::size_t>(pc.b)];
        const double c[2] = {0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])};
        const double r = 0.5 * std::hypot(pb[0] - pa[0], pb[1] - pa[1]);
        bool blocked = false;
        // A relative slack of 1e-9 makes points ON the circle count as inside:
        // a cocircular tie would otherwise let the Delaunay edge flip away.
        grid.disk(c, r * (1.0 + 1e-9), [&](std::int64_t v) {
            if (v != pc.a && v != pc.b) blocked = true;
        });
        if (!blocked) continue;
        if (pc.sb - pc.sa < min_piece)
            throw GeometryError(fn + ": cannot protect the study-area boundary near " + detail::fmt_xy(pa) +
                                ": a data point lies on the boundary within rounding but was not snapped "
                                "onto it");
        const double sm = 0.5 * (pc.sa + pc.sb);
        double xy[2];
        area.place(pc.side, sm, xy);
        // Linear z along the piece: the surface along the boundary is unchanged.
        const double u = (sm - pc.sa) / (pc.sb - pc.sa);
        const double z = pa[2] + u * (pb[2] - pa[2]);
        const std::int64_t id = static_cast<std::int64_t>(pts.size() / 3);
        pts.push_back(xy[0]);
        pts.push_back(xy[1]);
        pts.push_back(z);
        pos.emplace_back(pc.side, sm);
        grid.add(xy);
        s.by_side[pc.side].emplace(sm, id);
        work.emplace_back(pc.side, pc.sa);
        work.emplace_back(pc.side, sm);
    }
    s.tin.emplace(pts.data(), pts.size() / 3);
    const auto& vmap = s.tin->vertex_of_input();
    for (auto& m : s.by_side)
        for (auto& e : m) {
            e.second = vmap[static_cast<std::size_t>(e.second)];
            s.mark_boundary(e.second);
        }
    s.on_boundary.resize(s.tin->n_vertices(), 0);
    (void)mesh();  // checks that every piece is a TIN edge and the inside is closed
}

LayerTin::~LayerTin() = default;
LayerTin::LayerTin(LayerTin&&) noexcept = default;
LayerTin& LayerTin::operator=(LayerTin&&) noexcept = default;
LayerTin::LayerTin(const LayerTin& o) : s_(std::make_unique<LayerTinState>(*o.s_)) {}
LayerTin& LayerTin::operator=(const LayerTin& o) {
    if (this != &o) s_ = std::make_unique<LayerTinState>(*o.s_);
    return *this;
}

const std::string& LayerTin::name() const { return s_->name; }
const StudyArea& LayerTin::area() const { return s_->area; }
double LayerTin::spacing() const { return s_->spacing; }
std::size_t LayerTin::n_data() const { return s_->n_data; }
std::size_t LayerTin::n_outside() const { return s_->n_outside; }
std::size_t LayerTin::n_boundary_data() const { return s_->n_boundary_data; }
std::size_t LayerTin::n_vertices() const { return s_->tin->n_vertices(); }
const Tin& LayerTin::tin() const { return *s_->tin; }

std::vector<double> LayerTin::z() const {
    const std::vector<double> v = s_->tin->vertices();
    std::vector<double> z(v.size() / 3);
    for (std::size_t i = 0; i < z.size(); ++i) z[i] = v[3 * i + 2];
    return z;
}

std::vector<std::int64_t> LayerTin::boundary_vertices() const {
    std::vector<std::int64_t> out;
    for (const auto& m : s_->by_side)
        for (const auto& e : m) out.push_back(e.second);
    return out;
}

void LayerTin::set_z(const std::int64_t* vertices, const double* z, std::size_t n) {
    s_->tin->set_z(vertices, z, n);
}

std::vector<double> LayerTin::interpolate(const double* xy, std::size_t n) const {
    return s_->tin->interpolate(xy, n);
}

// ---------------------------------------------------------------- insert
std::size_t LayerTin::insert(const double* xyz, std::size_t n) {
    LayerTinState& s = *s_;
    const std::string fn = "LayerTin('" + s.name + "').insert";
    for (std::size_t i = 0; i < 3 * n; ++i)
        if (!std::isfinite(xyz[i]))
            throw std::invalid_argument(fn + ": point " + std::to_string(i / 3) + " has a non-finite coordinate");
    const std::size_t n0 = s.tin->n_vertices();
    const std::size_t ns = s.area.n_sides();
    // Points on the boundary become boundary vertices; points outside are ignored.
    std::vector<double> keep;
    std::vector<std::pair<std::size_t, double>> keep_pos;
    std::vector<StudyArea::Hit> hits;
    for (std::size_t i = 0; i < n; ++i) {
        const double* p = xyz + 3 * i;
        s.area.locate(p, hits);
        if (!hits.empty()) {
            StudyArea::Hit h = hits[0];
            for (const auto& x : hits)
                if (x.s == 0.0) h = x;
            if (h.s >= s.area.side_length(h.side)) h = {(h.side + 1) % ns, 0.0};
            keep_pos.emplace_back(h.side, h.s);
        } else if (s.area.contains(p)) {
            keep_pos.emplace_back(static_cast<std::size_t>(-1), 0.0);
        } else {
            continue;
        }
        keep.insert(keep.end(), p, p + 3);
    }
    if (keep.empty()) return 0;
    const std::size_t k = keep.size() / 3;
    std::vector<std::int64_t> ids = s.tin->insert(keep.data(), k);
    {
        std::vector<double> z(k);
        for (std::size_t i = 0; i < k; ++i) z[i] = keep[3 * i + 2];
        s.tin->set_z(ids.data(), z.data(), k);
    }
    s.on_boundary.resize(s.tin->n_vertices(), 0);
    std::vector<std::int64_t> fresh;  // new vertices to protect the pieces against
    for (std::size_t i = 0; i < k; ++i) {
        const auto& pp = keep_pos[i];
        if (pp.first != static_cast<std::size_t>(-1) && !s.on_boundary[static_cast<std::size_t>(ids[i])]) {
            s.by_side[pp.first].emplace(pp.second, ids[i]);
            s.mark_boundary(ids[i]);
        }
        if (static_cast<std::size_t>(ids[i]) >= n0) fresh.push_back(ids[i]);
    }
    // Protection against the new vertices: a piece's disk can only hold a
    // point whose projection falls on the piece, so test the piece of each
    // nearby side at the point's projection.
    double max_half = 0.0;
    std::vector<double> V = s.tin->vertices();
    auto vx = [&](std::int64_t v) { return &V[3 * static_cast<std::size_t>(v)]; };
    for (std::size_t i = 0; i < ns; ++i) {
        const auto& m = s.by_side[i];
        for (auto it = m.begin(); it != m.end(); ++it) {
            const Piece pc = piece_at(s, i, it);
            max_half = std::max(max_half, 0.5 * (pc.sb - pc.sa));
        }
    }
    const double min_piece = 1e-9 * s.area.perimeter();
    std::vector<std::size_t> near;
    for (std::size_t round = 0; !fresh.empty(); ++round) {
        std::vector<double> add;
        std::vector<std::pair<std::size_t, double>> add_pos;
        for (std::int64_t v : fresh) {
            const double* p = vx(v);
            s.area.sides_near(p, max_half, near);
            for (std::size_t side : near) {
                const double* a = s.area.corner(side);
                const double* b = s.area.corner(side + 1);
                const double L = s.area.side_length(side);
                const double sp = ((p[0] - a[0]) * (b[0] - a[0]) + (p[1] - a[1]) * (b[1] - a[1])) / L;
                if (sp < 0.0 || sp > L) continue;
                const auto& m = s.by_side[side];
                auto it = m.upper_bound(sp);
                if (it == m.begin()) continue;
                --it;
                const Piece pc = piece_at(s, side, it);
                if (v == pc.a || v == pc.b) continue;
                const double* qa = vx(pc.a);
                const double* qb = vx(pc.b);
                const double c[2] = {0.5 * (qa[0] + qb[0]), 0.5 * (qa[1] + qb[1])};
                const double r = 0.5 * std::hypot(qb[0] - qa[0], qb[1] - qa[1]) * (1.0 + 1e-9);
                const double dx = p[0] - c[0], dy = p[1] - c[1];
                if (dx * dx + dy * dy > r * r) continue;
                if (pc.sb - pc.sa < min_piece)
                    throw GeometryError(fn + ": cannot keep the study-area boundary protected near " +
                                        detail::fmt_xy(p) + " (a point lies on the boundary within rounding)");
                const double sm = 0.5 * (pc.sa + pc.sb);
                bool dup = false;
                for (const auto& q : add_pos)
                    if (q.first == side && q.second == sm) dup = true;
                if (dup) continue;
                double xy[2];
                s.area.place(side, sm, xy);
                const double u = (sm - pc.sa) / (pc.sb - pc.sa);
                add.push_back(xy[0]);
                add.push_back(xy[1]);
                add.push_back(qa[2] + u * (qb[2] - qa[2]));
                add_pos.emplace_back(side, sm);
            }
        }
        fresh.clear();
        if (add.empty()) break;
        const std::size_t na = add.size() / 3;
        const std::size_t before = s.tin->n_vertices();
        std::vector<std::int64_t> got = s.tin->insert(add.data(), na);
        std::vector<double> z(na);
        for (std::size_t i = 0; i < na; ++i) z[i] = add[3 * i + 2];
        s.tin->set_z(got.data(), z.data(), na);
        s.on_boundary.resize(s.tin->n_vertices(), 0);
        for (std::size_t i = 0; i < na; ++i) {
            if (!s.on_boundary[static_cast<std::size_t>(got[i])]) {
                s.by_side[add_pos[i].first].emplace(add_pos[i].second, got[i]);
                s.mark_boundary(got[i]);
            }
            if (static_cast<std::size_t>(got[i]) >= before) fresh.push_back(got[i]);
        }
        // The new boundary points themselves may sit in neighbouring pieces'
        // disks only if those pieces are longer than them; re-test them too.
        V = s.tin->vertices();
        if (round > 200)
            throw GeometryError(fn + ": could not keep the study-area boundary protected");
    }
    return s.tin->n_vertices() - n0;
}

// ---------------------------------------------------------------- mesh
LayerTinMesh LayerTin::mesh() const {
    const LayerTinState& s = *s_;
    const std::string fn = "LayerTin('" + s.name + "')";
    const std::vector<std::int64_t> T = s.tin->triangles();
    const std::vector<std::int64_t> H = s.tin->halfedges();
    const std::vector<double> V = s.tin->vertices();
    const std::size_t nv = V.size() / 3, m = T.size() / 3;
    // Outgoing half-edges per vertex (counting sort by the start vertex).
    std::vector<std::int64_t> start(nv + 1, 0), hs(3 * m);
    for (std::size_t h = 0; h < 3 * m; ++h) ++start[static_cast<std::size_t>(T[h]) + 1];
    for (std::size_t i = 0; i < nv; ++i) start[i + 1] += start[i];
    {
        std::vector<std::int64_t> fill(start.begin(), start.end() - 1);
        for (std::size_t h = 0; h < 3 * m; ++h) hs[static_cast<std::size_t>(fill[static_cast<std::size_t>(T[h])]++)] = static_cast<std::int64_t>(h);
    }
    auto nxt = [](std::int64_t h) { return h % 3 == 2 ? h - 2 : h + 1; };
    // Walls: the half-edges of the pieces (area on their left) and their twins.
    std::vector<char> wall(3 * m, 0);
    std::vector<std::int64_t> seeds;
    const std::size_t ns = s.area.n_sides();
    for (std::size_t i = 0; i < ns; ++i)
        for (auto it = s.by_side[i].begin(); it != s.by_side[i].end(); ++it) {
            const Piece pc = piece_at(s, i, it);
            std::int64_t found = -1;
            for (std::int64_t j = start[static_cast<std::size_t>(pc.a)]; j < start[static_cast<std::size_t>(pc.a) + 1]; ++j) {
                const std::int64_t h = hs[static_cast<std::size_t>(j)];
                if (T[static_cast<std::size_t>(nxt(h))] == pc.b) found = h;
            }
            if (found < 0)
                throw GeometryError(fn + ": the boundary piece from " + detail::fmt_xy(&V[3 * static_cast<std::size_t>(pc.a)]) +
                                    " to " + detail::fmt_xy(&V[3 * static_cast<std::size_t>(pc.b)]) +
                                    " is not an edge of the TIN");
            wall[static_cast<std::size_t>(found)] = 1;
            if (H[static_cast<std::size_t>(found)] >= 0) wall[static_cast<std::size_t>(H[static_cast<std::size_t>(found)])] = 1;
            seeds.push_back(found / 3);
        }
    std::vector<char> inside(m, 0);
    std::vector<std::int64_t> stack;
    for (std::int64_t t : seeds)
        if (!inside[static_cast<std::size_t>(t)]) {
            inside[static_cast<std::size_t>(t)] = 1;
            stack.push_back(t);
        }
    while (!stack.empty()) {
        const std::int64_t t = stack.back();
        stack.pop_back();
        for (int k = 0; k < 3; ++k) {
            const std::int64_t h = 3 * t + k;
            if (wall[static_cast<std::size_t>(h)]) continue;
            const std::int64_t o = H[static_cast<std::size_t>(h)];
            if (o < 0)
                throw GeometryError(fn + ": the study area leaks to the convex hull near " +
                                    detail::fmt_xy(&V[3 * static_cast<std::size_t>(T[static_cast<std::size_t>(h)])]) +
                                    " (boundary not protected)");
            if (!inside[static_cast<std::size_t>(o / 3)]) {
                inside[static_cast<std::size_t>(o / 3)] = 1;
                stack.push_back(o / 3);
            }
        }
    }
    LayerTinMesh out;
    std::vector<std::int64_t> remap(nv, -1), tri_of(m, -1);
    std::int64_t mt = 0;
    for (std::size_t t = 0; t < m; ++t)
        if (inside[t]) tri_of[t] = mt++;
    out.halfedges.assign(3 * static_cast<std::size_t>(mt), -1);
    for (std::size_t t = 0; t < m; ++t) {
        if (!inside[t]) continue;
        for (int k = 0; k < 3; ++k) {
            const std::int64_t o = H[3 * t + static_cast<std::size_t>(k)];
            if (o >= 0 && tri_of[static_cast<std::size_t>(o / 3)] >= 0)
                out.halfedges[3 * static_cast<std::size_t>(tri_of[t]) + static_cast<std::size_t>(k)] =
                    3 * tri_of[static_cast<std::size_t>(o / 3)] + o % 3;
        }
        for (int k = 0; k < 3; ++k) {
            const std::int64_t v = T[3 * t + static_cast<std::size_t>(k)];
            if (remap[static_cast<std::size_t>(v)] < 0) {
                remap[static_cast<std::size_t>(v)] = static_cast<std::int64_t>(out.tin_vertex.size());
                out.tin_vertex.push_back(v);
            }
            out.triangles.push_back(remap[static_cast<std::size_t>(v)]);
        }
    }
    out.vertices.reserve(3 * out.tin_vertex.size());
    for (std::int64_t v : out.tin_vertex)
        out.vertices.insert(out.vertices.end(), &V[3 * static_cast<std::size_t>(v)], &V[3 * static_cast<std::size_t>(v)] + 3);
    return out;
}

// ---------------------------------------------------------------- repair
RepairCounts repair_crossings(const LayerTin& upper, LayerTin& lower, const RepairOptions& opt) {
    const std::string fn = "repair_crossings('" + upper.name() + "', '" + lower.name() + "')";
    RepairCounts counts;
    const LayerTinMesh um = upper.mesh();
    const std::size_t nu = um.vertices.size() / 3, mu = um.triangles.size() / 3;
    double zscale = 1.0;
    for (std::size_t i = 0; i < nu; ++i) zscale = std::max(zscale, std::fabs(um.vertices[3 * i + 2]));
    for (double z : lower.z()) zscale = std::max(zscale, std::fabs(z));
    const double tol = opt.tolerance >= 0.0 ? opt.tolerance : 1e-9 * zscale;
    std::vector<double> uxy(2 * nu);
    for (std::size_t i = 0; i < nu; ++i) {
        uxy[2 * i] = um.vertices[3 * i];
        uxy[2 * i + 1] = um.vertices[3 * i + 1];
    }
    const AabbTree utree = AabbTree::from_triangles(um.vertices.data(), nu, 3, um.triangles.data(), mu);
    const std::size_t n_start = lower.n_vertices();
    std::int64_t inserted = 0;
    // Small layers may need many points relative to their size (a few local
    // crossings); the budget only has to stop runaway refinement.
    const double budget = std::max(opt.max_inserted_per_vertex * static_cast<double>(n_start), 10000.0);
    // Lower vertices whose edges rule 2 must look at: every vertex in the
    // first round, then those lowered or created since rule 2 last ran (a
    // Delaunay insertion creates edges only at the new vertex).
    std::vector<char> dirty(lower.n_vertices(), 1);
    auto mark_new = [&](std::size_t before) {
        dirty.resize(lower.n_vertices(), 0);
        for (std::size_t v = before; v < lower.n_vertices(); ++v) dirty[v] = 1;
    };
    auto insert = [&](std::vector<double>& pts, std::int64_t& counter) {
        if (pts.empty()) return false;
        const std::size_t k = pts.size() / 3, before = lower.n_vertices();
        lower.insert(pts.data(), k);
        counter += static_cast<std::int64_t>(k);
        inserted += static_cast<std::int64_t>(k);
        mark_new(before);
        return true;
    };
    for (int round = 0; round < opt.max_rounds; ++round) {
        bool changed = false;
        // Rule 1: lower vertices above the upper surface take its elevation.
        {
            const LayerTinMesh lm = lower.mesh();
            const std::size_t nl = lm.vertices.size() / 3;
            std::vector<double> xy(2 * nl);
            for (std::size_t i = 0; i < nl; ++i) {
                xy[2 * i] = lm.vertices[3 * i];
                xy[2 * i + 1] = lm.vertices[3 * i + 1];
            }
            const std::vector<double> zu = upper.interpolate(xy.data(), nl);
            std::vector<std::int64_t> ids;
            std::vector<double> zs;
            for (std::size_t i = 0; i < nl; ++i)
                if (std::isfinite(zu[i]) && lm.vertices[3 * i + 2] - zu[i] > tol) {
                    ids.push_back(lm.tin_vertex[i]);
                    zs.push_back(zu[i]);
                }
            if (!ids.empty()) {
                lower.set_z(ids.data(), zs.data(), ids.size());
                counts.rule1 += static_cast<std::int64_t>(ids.size());
                changed = true;
                for (std::int64_t v : ids) dirty[static_cast<std::size_t>(v)] = 1;
            }
        }
        // Rule 1b: upper vertices below the lower surface.
        {
            const std::vector<double> zl = lower.interpolate(uxy.data(), nu);
            std::vector<double> add;
            for (std::size_t i = 0; i < nu; ++i)
                if (std::isfinite(zl[i]) && zl[i] - um.vertices[3 * i + 2] > tol)
                    add.insert(add.end(), &um.vertices[3 * i], &um.vertices[3 * i] + 3);
            changed |= insert(add, counts.rule1b);
        }
        // Rule 2: lower edges (each once: the half-edge without a twin or
        // the one of the two with the smaller index) that have a dirty end
        // and rise above the upper surface at a crossing with an upper edge.
        std::vector<double> add;
        {
            const LayerTinMesh lm = lower.mesh();
            const std::size_t ml = lm.triangles.size() / 3;
            std::vector<Box2> qboxes;
            std::vector<std::array<std::int64_t, 2>> qedges;
            for (std::size_t h = 0; h < 3 * ml; ++h) {
                const std::int64_t o = lm.halfedges[h];
                if (o >= 0 && o < static_cast<std::int64_t>(h)) continue;
                const std::int64_t a = lm.triangles[h], b = lm.triangles[h % 3 == 2 ? h - 2 : h + 1];
                if (!dirty[static_cast<std::size_t>(lm.tin_vertex[static_cast<std::size_t>(a)])] &&
                    !dirty[static_cast<std::size_t>(lm.tin_vertex[static_cast<std::size_t>(b)])])
                    continue;
                const double* p = &lm.vertices[3 * static_cast<std::size_t>(a)];
                const double* q = &lm.vertices[3 * static_cast<std::size_t>(b)];
                qboxes.push_back({std::min(p[0], q[0]), std::min(p[1], q[1]), std::max(p[0], q[0]),
                                  std::max(p[1], q[1])});
                qedges.push_back({a, b});
            }
            std::fill(dirty.begin(), dirty.end(), 0);
            const Csr hits = utree.query(qboxes.data(), qboxes.size(), /*sorted=*/false);
            for (std::size_t e = 0; e < qedges.size(); ++e) {
                const double* P = &lm.vertices[3 * static_cast<std::size_t>(qedges[e][0])];
                const double* Q = &lm.vertices[3 * static_cast<std::size_t>(qedges[e][1])];
                const double rx = Q[0] - P[0], ry = Q[1] - P[1];
                double best = tol, bx = 0.0, by = 0.0, bz = 0.0;
                bool found = false;
                for (std::int64_t j = hits.offsets[e]; j < hits.offsets[e + 1]; ++j) {
                    const std::size_t t = static_cast<std::size_t>(hits.indices[static_cast<std::size_t>(j)]);
                    for (std::size_t k = 0; k < 3; ++k) {
                        const double* A = &um.vertices[3 * static_cast<std::size_t>(um.triangles[3 * t + k])];
                        const double* B = &um.vertices[3 * static_cast<std::size_t>(um.triangles[3 * t + (k + 1) % 3])];
                        // The crossing of the two segments (floating point:
                        // it only locates a violation of more than tol).
                        const double sx = B[0] - A[0], sy = B[1] - A[1];
                        const double den = rx * sy - ry * sx;
                        if (den == 0.0) continue;
                        const double wx = A[0] - P[0], wy = A[1] - P[1];
                        const double tt = (wx * sy - wy * sx) / den;
                        const double uu = (wx * ry - wy * rx) / den;
                        if (!(tt > 0.0 && tt < 1.0 && uu >= 0.0 && uu <= 1.0)) continue;
                        const double zl = P[2] + tt * (Q[2] - P[2]);
                        const double zu = A[2] + uu * (B[2] - A[2]);
                        if (zl - zu > best) {
                            best = zl - zu;
                            found = true;
                            bx = P[0] + tt * rx;
                            by = P[1] + tt * ry;
                            bz = zu;
                        }
                    }
                }
                if (!found) continue;
                if (round < opt.midpoint_rounds) {
                    add.push_back(0.5 * (P[0] + Q[0]));
                    add.push_back(0.5 * (P[1] + Q[1]));
                    add.push_back(0.5 * (P[2] + Q[2]));
                } else {
                    add.push_back(bx);
                    add.push_back(by);
                    add.push_back(bz);
                }
            }
        }
        if (round < opt.midpoint_rounds && !add.empty()) {
            // The midpoint at the lower of the two elevations.
            const std::size_t k = add.size() / 3;
            std::vector<double> xy(2 * k);
            for (std::size_t i = 0; i < k; ++i) {
                xy[2 * i] = add[3 * i];
                xy[2 * i + 1] = add[3 * i + 1];
            }
            const std::vector<double> zu = upper.interpolate(xy.data(), k);
            for (std::size_t i = 0; i < k; ++i)
                if (std::isfinite(zu[i])) add[3 * i + 2] = std::min(add[3 * i + 2], zu[i]);
        }
        changed |= insert(add, round < opt.midpoint_rounds ? counts.rule2 : counts.rule2_crossing);
        counts.rounds = round + 1;
        if (!changed) return counts;
        if (static_cast<double>(inserted) > budget)
            throw GeometryError(fn + ": the layers still cross after " + std::to_string(inserted) +
                                " inserted points (" + std::to_string(n_start) + " vertices at the start): '" +
                                lower.name() + "' lies above '" + upper.name() +
                                "' over a large area; is the layer order right?");
    }
    throw GeometryError(fn + ": '" + lower.name() + "' still crosses '" + upper.name() + "' after " +
                        std::to_string(opt.max_rounds) + " rounds");
}

}  // namespace faultmesh
