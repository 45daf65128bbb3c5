// Tin: the Delaunay engine of delaunay_core.hpp kept alive between
// insertions, with a z per vertex, point location and linear interpolation.
#include <faultmesh/errors.hpp>
#include <faultmesh/tin.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>

#include "delaunay_core.hpp"
#include "linear_interpolation.hpp"
#include "spatial_sort.hpp"

namespace faultmesh {
namespace detail {

struct TinImpl {
    DelaunayCore core;
    std::vector<double> xyz;                   // 3 per Tin vertex
    std::vector<std::int64_t> tin_of_id;       // engine id -> Tin vertex (duplicates too)
    std::vector<double> z_of_id;               // engine id -> z of its vertex (memory order of core.xy)
    std::vector<std::int64_t> vertex_of_input; // constructor rows -> Tin vertex
    std::size_t n_dups = 0;
    std::vector<std::int32_t> compact;         // engine slot -> triangle index or -1
    std::size_t m = 0;

    // The compact triangle numbering (and the jump-and-walk samples) costs
    // O(triangles) to rebuild, so an insert only marks it stale and the next
    // reader rebuilds it: inserting points one call at a time stays O(walk)
    // per point, as the paper's point-by-point insertion needs. Readers may
    // run concurrently (the Python binding shares a reader lock), so the
    // rebuild is guarded by its own mutex (double-checked flag).
    struct Lazy {
        std::mutex mu;
        std::atomic<bool> valid{false};
        Lazy() = default;
        Lazy(const Lazy& o) : valid(o.valid.load()) {}
        Lazy& operator=(const Lazy& o) {
            valid.store(o.valid.load());
            return *this;
        }
    } lazy;

    void ensure_compact() {
        if (lazy.valid.load(std::memory_order_acquire)) return;
        std::lock_guard<std::mutex> guard(lazy.mu);
        if (lazy.valid.load(std::memory_order_relaxed)) return;
        m = compact_slots(core, compact);
        lazy.valid.store(true, std::memory_order_release);
    }

    // Assigns Tin vertices to the engine ids [first, first + n) just inserted
    // from the n rows `rows` (input_of_id[id - first] = row, dup_of[id - first]
    // as build_core/insert_batch give them), in row order: a new vertex for
    // the first row of each new point, the existing vertex for a duplicate.
    // Returns the vertex of each row.
    std::vector<std::int64_t> assign(const double* rows, std::size_t n, std::size_t first,
                                     const std::vector<std::uint32_t>& input_of_id,
                                     const std::vector<std::int32_t>& dup_of) {
        const std::size_t end = first + n;
        tin_of_id.resize(end, -1);
        // Smallest row of each new point (indexed by engine id - first).
        std::vector<std::uint32_t> min_row(n, std::numeric_limits<std::uint32_t>::max());
        std::vector<std::uint32_t> id_of_row(n);
        for (std::size_t id = first; id < end; ++id) {
            const std::uint32_t row = input_of_id[id - first];
            id_of_row[row] = static_cast<std::uint32_t>(id);
            const std::int32_t d = dup_of[id - first];
            const std::size_t root = d >= 0 ? static_cast<std::size_t>(d) : id;
            if (d >= 0) ++n_dups;
            if (root >= first && row < min_row[root - first]) min_row[root - first] = row;
        }
        std::vector<std::int64_t> out(n);
        for (std::size_t row = 0; row < n; ++row) {
            const std::size_t id = id_of_row[row];
            const std::int32_t d = dup_of[id - first];
            const std::size_t root = d >= 0 ? static_cast<std::size_t>(d) : id;
            if (root >= first && min_row[root - first] == row) {
                // First appearance of a new point: it becomes a vertex with this row's z.
                tin_of_id[root] = static_cast<std::int64_t>(xyz.size() / 3);
                xyz.insert(xyz.end(), rows + 3 * row, rows + 3 * row + 3);
            }
            out[row] = tin_of_id[root];
        }
        z_of_id.resize(end);
        for (std::size_t id = first; id < end; ++id) {
            if (dup_of[id - first] >= 0)
                tin_of_id[id] = tin_of_id[static_cast<std::size_t>(dup_of[id - first])];
            z_of_id[id] = xyz[3 * static_cast<std::size_t>(tin_of_id[id]) + 2];
        }
        build_samples();
        lazy.valid.store(false, std::memory_order_release);
        return out;
    }

    // Jump-and-walk (Muecke, Saias and Zhu): a single query starts from the
    // sampled triangle whose first vertex is nearest, so that its walk is
    // O(n^(1/3)) steps instead of O(n^(1/2)) from an arbitrary triangle.
    std::vector<std::int32_t> samples;

    bool finite_slot(std::int32_t t) const {
        const std::int32_t* v = &core.tv[3 * static_cast<std::size_t>(t)];
        return v[0] != kInf && v[1] != kInf && v[2] != kInf;
    }

    // O(samples): strided engine slots, rebuilt after every insert. A slot
    // stays a live triangle when later inserts rewrite it (cavities reuse
    // their slots), but it may become a ghost, so users skip non-finite ones.
    void build_samples() {
        samples.clear();
        const std::size_t ns = core.n_slots();
        const std::size_t want = std::max<std::size_t>(1, static_cast<std::size_t>(std::cbrt(double(ns))) * 2);
        const std::size_t stride = std::max<std::size_t>(1, ns / want);
        for (std::size_t t = 0; t < ns; t += stride)
            if (finite_slot(static_cast<std::int32_t>(t))) samples.push_back(static_cast<std::int32_t>(t));
        if (samples.empty()) samples.push_back(core.hint);
    }

    std::int32_t nearest_sample(double x, double y) const {
        std::int32_t best = core.hint;
        double best_d = INFINITY;
        for (const std::int32_t t : samples) {
            if (!finite_slot(t)) continue;
            const double* a = core.pt(core.tv[3 * static_cast<std::size_t>(t)]);
            const double d = (a[0] - x) * (a[0] - x) + (a[1] - y) * (a[1] - y);
            if (d < best_d) {
                best_d = d;
                best = t;
            }
        }
        return best;
    }

    // Engine slot of a finite triangle containing (x, y), or -1 (outside the
    // hull or non-finite query). `start` is a finite slot to walk from; it is
    // updated to a finite slot near the query.
    std::int32_t locate_slot(double x, double y, std::int32_t& start) const {
        // Non-finite queries and those beyond the vertices' coordinate range
        // (where orient2d could overflow) are outside the hull.
        if (!(coordinate_in_range(x) && coordinate_in_range(y))) return -1;
        const double p[2] = {x, y};
        const std::int32_t t = core.locate(p, start);
        if (core.is_ghost(t)) {
            // Keep walking from the finite triangle behind the hull edge.
            const std::int32_t* v = &core.tv[3 * static_cast<std::size_t>(t)];
            const int i = v[0] == kInf ? 1 : (v[1] == kInf ? 2 : 0);  // the hull edge of the ghost
            start = core.th[3 * static_cast<std::size_t>(t) + i] / 3;
            return -1;
        }
        start = t;
        return t;
    }

    // Calls f(i, query, slot) for each of n queries (slot -1 outside), walking them
    // in Hilbert order, so that each walk starts where the previous ended and
    // f's accesses to the triangles stay local.
    template <class F>
    void for_each_located(const double* xy, std::size_t n, F&& f) const {
        if (n == 0) return;
        if (n == 1) {
            std::int32_t start = nearest_sample(xy[0], xy[1]);
            f(std::size_t(0), xy, locate_slot(xy[0], xy[1], start));
            return;
        }
        const std::vector<std::uint32_t> ord = hilbert_order(xy, 2, n);
        // The queries gathered in walk order (one pass), so that the walks
        // read them sequentially.
        std::vector<double> q(2 * n);
        for (std::size_t k = 0; k < n; ++k) {
            q[2 * k] = xy[2 * static_cast<std::size_t>(ord[k])];
            q[2 * k + 1] = xy[2 * static_cast<std::size_t>(ord[k]) + 1];
        }
        std::int32_t start = nearest_sample(q[0], q[1]);
        for (std::size_t k = 0; k < n; ++k) f(ord[k], &q[2 * k], locate_slot(q[2 * k], q[2 * k + 1], start));
    }
};

}  // namespace detail

Tin::Tin(const double* xyz, std::size_t n) : impl_(std::make_unique<detail::TinImpl>()) {
    detail::TinImpl& T = *impl_;
    std::vector<std::uint32_t> input_of_id;
    std::vector<std::int32_t> dup_of;
    detail::build_core(T.core, xyz, 3, n, "Tin", input_of_id, dup_of);
    T.vertex_of_input = T.assign(xyz, n, 0, input_of_id, dup_of);
}

Tin::~Tin() = default;
Tin::Tin(Tin&&) noexcept = default;
Tin& Tin::operator=(Tin&&) noexcept = default;
Tin::Tin(const Tin& o) : impl_(std::make_unique<detail::TinImpl>(*o.impl_)) {}
Tin::Tin(const Tin& o, std::size_t extra_vertices) : impl_(std::make_unique<detail::TinImpl>()) {
    detail::TinImpl& T = *impl_;
    const detail::TinImpl& S = *o.impl_;
    // Room first, then the copy into it (a vector assigned from a shorter one
    // keeps its storage), so the insertions to come reallocate nothing: the
    // engine's growth (DelaunayCore::ensure_slots) asks for 2 slots per
    // vertex or 1.5 times what it has.
    const std::size_t ids = S.core.xy.size() / 2 + extra_vertices;
    const std::size_t slot_ints = std::max(3 * (2 * ids + 2), S.core.tv.size() + S.core.tv.size() / 2);
    T.core.xy.reserve(2 * ids);
    T.core.tv.reserve(slot_ints);
    T.core.th.reserve(slot_ints);
    T.xyz.reserve(S.xyz.size() + 3 * extra_vertices);
    T.tin_of_id.reserve(ids);
    T.z_of_id.reserve(ids);
    T.compact.reserve(slot_ints / 3);
    T = S;
}
Tin& Tin::operator=(const Tin& o) {
    if (this != &o) impl_ = std::make_unique<detail::TinImpl>(*o.impl_);
    return *this;
}

std::vector<std::int64_t> Tin::insert(const double* xyz, std::size_t n) {
    detail::TinImpl& T = *impl_;
    detail::check_finite_xy(xyz, 3, n, "Tin.insert", "xyz");
    if (n == 0) return {};
    const std::size_t first = T.core.xy.size() / 2;
    std::vector<std::uint32_t> input_of_id;
    std::vector<std::int32_t> dup_of;
    // Start the walk near the new data (jump-and-walk): a scattered single
    // point would otherwise walk O(sqrt(n)) triangles from the last insertion.
    T.core.hint = T.nearest_sample(xyz[0], xyz[1]);
    detail::insert_batch(T.core, xyz, 3, n, input_of_id, dup_of);
    return T.assign(xyz, n, first, input_of_id, dup_of);
}

void Tin::set_z(const std::int64_t* vertices, const double* z, std::size_t n) {
    detail::TinImpl& T = *impl_;
    const std::int64_t nv = static_cast<std::int64_t>(T.xyz.size() / 3);
    for (std::size_t i = 0; i < n; ++i)
        if (vertices[i] < 0 || vertices[i] >= nv)
            throw std::invalid_argument("Tin.set_z: vertex index " + std::to_string(vertices[i]) + " at entry " +
                                        std::to_string(i) + " is out of range [0, " + std::to_string(nv) + ")");
    for (std::size_t i = 0; i < n; ++i) T.xyz[3 * static_cast<std::size_t>(vertices[i]) + 2] = z[i];
    // The engine-order copy of z: every id of a vertex (its duplicates too).
    for (std::size_t id = 0; id < T.z_of_id.size(); ++id)
        T.z_of_id[id] = T.xyz[3 * static_cast<std::size_t>(T.tin_of_id[id]) + 2];
}

std::size_t Tin::n_vertices() const { return impl_->xyz.size() / 3; }
std::size_t Tin::n_triangles() const {
    impl_->ensure_compact();
    return impl_->m;
}
const std::vector<std::int64_t>& Tin::vertex_of_input() const { return impl_->vertex_of_input; }
std::size_t Tin::n_duplicates() const { return impl_->n_dups; }
std::vector<double> Tin::vertices() const { return impl_->xyz; }

const std::vector<double>& Tin::vertex_array() const { return impl_->xyz; }

void Tin::mesh(std::vector<std::int64_t>* triangles, std::vector<std::int64_t>* halfedges) const {
    impl_->ensure_compact();
    detail::export_mesh(impl_->core, impl_->compact, impl_->m, impl_->tin_of_id.data(), triangles, halfedges);
}

std::vector<std::int64_t> Tin::triangles() const {
    impl_->ensure_compact();
    std::vector<std::int64_t> t;
    detail::export_mesh(impl_->core, impl_->compact, impl_->m, impl_->tin_of_id.data(), &t, nullptr);
    return t;
}

std::vector<std::int64_t> Tin::halfedges() const {
    impl_->ensure_compact();
    std::vector<std::int64_t> h;
    detail::export_mesh(impl_->core, impl_->compact, impl_->m, impl_->tin_of_id.data(), nullptr, &h);
    return h;
}

std::int64_t Tin::locate(double x, double y) const {
    impl_->ensure_compact();
    const double q[2] = {x, y};
    std::int64_t out = -1;
    impl_->for_each_located(q, 1, [&](std::size_t, const double*, std::int32_t s) { out = s < 0 ? -1 : impl_->compact[s]; });
    return out;
}

std::vector<std::int64_t> Tin::locate(const double* xy, std::size_t n) const {
    impl_->ensure_compact();
    std::vector<std::int64_t> out(n);
    const detail::TinImpl& T = *impl_;
    T.for_each_located(xy, n, [&](std::size_t i, const double*, std::int32_t s) { out[i] = s < 0 ? -1 : T.compact[s]; });
    return out;
}

std::vector<double> Tin::interpolate(const double* xy, std::size_t n) const {
    impl_->ensure_compact();
    const detail::TinImpl& T = *impl_;
    std::vector<double> out(n, std::numeric_limits<double>::quiet_NaN());
    T.for_each_located(xy, n, [&](std::size_t i, const double* p, std::int32_t s) {
        if (s < 0) return;
        const std::int32_t* v = &T.core.tv[3 * static_cast<std::size_t>(s)];
        const double* a = T.core.pt(v[0]);
        const double* b = T.core.pt(v[1]);
        const double* c = T.core.pt(v[2]);
        // The located triangle contains p (closed, exact predicates): a convex
        // combination of its vertices' z, see linear_interpolation.hpp.
        out[i] = detail::interpolate_in_triangle(a, b, c, p, T.z_of_id[v[0]], T.z_of_id[v[1]], T.z_of_id[v[2]]);
    });
    return out;
}

}  // namespace faultmesh
