// Delaunay triangulation: input validation, insertion order, first triangle,
// and the conversion of the engine's arrays (delaunay_core.hpp) into the
// public result.
#include <faultmesh/delaunay.hpp>
#include <faultmesh/errors.hpp>

#include <cmath>
#include <sstream>
#include <string>

#include "delaunay_core.hpp"
#include "spatial_sort.hpp"

namespace faultmesh {
namespace detail {

void check_finite_xy(const double* pts, std::size_t stride, std::size_t n, const char* fn,
                     const char* what) {
    check_coordinates(pts, n, stride, 2, fn, what);
}

namespace {

inline bool same_xy(const double* a, const double* b) { return a[0] == b[0] && a[1] == b[1]; }

void check_size(std::size_t n, const char* fn) {
    if (n > kMaxPoints) {
        std::ostringstream msg;
        msg << fn << ": " << n << " points is more than the supported maximum of " << kMaxPoints;
        throw std::invalid_argument(msg.str());
    }
}

}  // namespace

void build_core(DelaunayCore& core, const double* pts, std::size_t stride, std::size_t n,
                const char* fn, std::vector<std::uint32_t>& input_of_id,
                std::vector<std::int32_t>& dup_of) {
    check_size(n, fn);
    check_finite_xy(pts, stride, n, fn, stride == 3 ? "xyz" : "xy");
    if (n < 3) {
        std::ostringstream msg;
        msg << fn << ": need at least 3 distinct points, got " << n << " point" << (n == 1 ? "" : "s");
        throw GeometryError(msg.str());
    }
    std::vector<std::uint32_t> ord = brio_order(pts, stride, n);
    auto P = [&](std::size_t k) { return pts + static_cast<std::size_t>(ord[k]) * stride; };

    // The first triangle: the first point in BRIO order, the next distinct
    // one, and the next one not collinear with them. Points skipped on the way
    // are inserted later like any other.
    std::size_t i1 = 1;
    while (i1 < n && same_xy(P(i1), P(0))) ++i1;
    std::size_t i2 = i1 + 1;
    if (i1 < n) {
        while (i2 < n && orient2d(P(0), P(i1), P(i2)) == 0.0) ++i2;
    }
    if (i1 >= n || i2 >= n) {
        // Distinguish "fewer than 3 distinct" from "collinear" for the message.
        std::size_t distinct = i1 >= n ? 1 : 2;
        if (i1 < n)
            for (std::size_t k = i1 + 1; k < n; ++k)
                if (!same_xy(P(k), P(0)) && !same_xy(P(k), P(i1))) {
                    distinct = 3;
                    break;
                }
        std::ostringstream msg;
        if (distinct < 3)
            msg << fn << ": need at least 3 distinct points, got " << distinct << " distinct among " << n;
        else
            msg << fn << ": all " << n << " points are collinear";
        throw GeometryError(msg.str());
    }

    // Ids: ord with positions i1 and i2 moved to 1 and 2 (the others keep
    // their order), in place.
    {
        const std::uint32_t a = ord[i1], b = ord[i2];
        std::size_t w = i2;
        for (std::size_t k = i2; k-- > 1;)
            if (k != i1) ord[w--] = ord[k];
        ord[1] = a;
        ord[2] = b;
    }
    input_of_id = std::move(ord);

    core.reserve_vertices(n);
    core.xy.resize(2 * n);
    for (std::size_t id = 0; id < n; ++id) {
        const double* q = pts + static_cast<std::size_t>(input_of_id[id]) * stride;
        core.xy[2 * id] = q[0];
        core.xy[2 * id + 1] = q[1];
    }
    core.init(0, 1, 2);
    dup_of.assign(n, -1);
    for (std::size_t id = 3; id < n; ++id) dup_of[id] = core.insert(static_cast<std::int32_t>(id));
}

void insert_batch(DelaunayCore& core, const double* pts, std::size_t stride, std::size_t n,
                  std::vector<std::uint32_t>& input_of_id, std::vector<std::int32_t>& dup_of) {
    const std::size_t first = core.xy.size() / 2;
    check_size(first + n, "Tin.insert");
    // Into a triangulation already larger than the batch, the points go in
    // Hilbert order: each walk starts at the previous point's triangle, a few
    // steps away. BRIO's random rounds guard the expected cost of building
    // from scratch, but here they only make walks jump across the existing
    // triangulation (measured on build_layer_tins of 5 layers x 94k points,
    // about 2,300 boundary and extra points inserted per layer into a copied
    // TIN: 5-10 % less CPU time in all). The triangulation is canonical, so
    // the order changes no triangle.
    const std::vector<std::uint32_t> ord = n < first ? hilbert_order(pts, stride, n) : brio_order(pts, stride, n);
    core.reserve_vertices(first + n);
    core.xy.resize(2 * (first + n));
    for (std::size_t k = 0; k < n; ++k) {
        const double* q = pts + static_cast<std::size_t>(ord[k]) * stride;
        core.xy[2 * (first + k)] = q[0];
        core.xy[2 * (first + k) + 1] = q[1];
    }
    input_of_id.assign(ord.begin(), ord.end());
    dup_of.resize(n);
    for (std::size_t k = 0; k < n; ++k) dup_of[k] = core.insert(static_cast<std::int32_t>(first + k));
}

std::size_t compact_slots(const DelaunayCore& core, std::vector<std::int32_t>& compact) {
    const std::size_t ns = core.n_slots();
    compact.resize(ns);
    const std::int32_t* V = core.tv.data();
    std::int32_t m = 0;
    for (std::size_t t = 0; t < ns; ++t) {
        const std::int32_t* v = V + 3 * t;
        compact[t] = (v[0] == kInf || v[1] == kInf || v[2] == kInf) ? -1 : m++;
    }
    return static_cast<std::size_t>(m);
}

template <class Index>
void export_mesh_impl(const DelaunayCore& core, const std::vector<std::int32_t>& compact, std::size_t m,
                      const Index* vertex_of_id, std::vector<std::int64_t>* triangles,
                      std::vector<std::int64_t>* halfedges) {
    if (triangles) triangles->resize(3 * m);
    if (halfedges) halfedges->resize(3 * m);
    const std::int32_t* V = core.tv.data();
    const std::int32_t* H = core.th.data();
    std::int64_t* T = triangles ? triangles->data() : nullptr;
    std::int64_t* E = halfedges ? halfedges->data() : nullptr;
    const std::size_t ns = core.n_slots();
    for (std::size_t t = 0; t < ns; ++t) {
        const std::int32_t c = compact[t];
        if (c < 0) continue;
        const std::size_t out = 3 * static_cast<std::size_t>(c);
        for (std::size_t i = 0; i < 3; ++i) {
            const std::size_t e = 3 * t + i;
            if (T) T[out + i] = static_cast<std::int64_t>(vertex_of_id[V[e]]);
            if (E) {
                const std::int32_t tw = H[e];
                const std::int32_t ct = compact[tw / 3];
                E[out + i] = ct < 0 ? -1 : 3 * static_cast<std::int64_t>(ct) + tw % 3;
            }
        }
    }
}

void export_mesh(const DelaunayCore& core, const std::vector<std::int32_t>& compact, std::size_t m,
                 const std::int64_t* vertex_of_id, std::vector<std::int64_t>* triangles,
                 std::vector<std::int64_t>* halfedges) {
    export_mesh_impl(core, compact, m, vertex_of_id, triangles, halfedges);
}

void export_mesh(const DelaunayCore& core, const std::vector<std::int32_t>& compact, std::size_t m,
                 const std::uint32_t* vertex_of_id, std::vector<std::int64_t>* triangles,
                 std::vector<std::int64_t>* halfedges) {
    export_mesh_impl(core, compact, m, vertex_of_id, triangles, halfedges);
}

}  // namespace detail

DelaunayResult delaunay(const double* xy, std::size_t n, bool with_halfedges) {
    detail::DelaunayCore core;
    std::vector<std::uint32_t> input_of_id;
    std::vector<std::int32_t> dup_of;
    detail::build_core(core, xy, 2, n, "delaunay", input_of_id, dup_of);

    DelaunayResult r;
    // Representative of a duplicate group: its smallest input index, so the
    // result does not depend on which copy the insertion order met first.
    // input_of_id becomes that representative, in place: first remember the
    // id each row maps to, then lower the vertices' input index to their
    // group's minimum, then resolve the rows.
    r.vertex_of_input.resize(n);
    for (std::size_t id = 0; id < n; ++id) {
        const std::int32_t d = dup_of[id];
        r.vertex_of_input[input_of_id[id]] = d >= 0 ? d : static_cast<std::int64_t>(id);
    }
    for (std::size_t id = 0; id < n; ++id) {
        const std::int32_t d = dup_of[id];
        if (d >= 0) {
            ++r.n_duplicates;
            if (input_of_id[id] < input_of_id[d]) input_of_id[d] = input_of_id[id];
        }
    }
    for (auto& v : r.vertex_of_input) v = input_of_id[static_cast<std::size_t>(v)];

    if (!with_halfedges) {
        // Triangles only: no compacted slot index is needed, one pass.
        const std::size_t ns = core.n_slots();
        // Finite triangles = slots - hull edges; 2n - 2 slots bound it.
        r.triangles.resize(3 * ns);
        const std::int32_t* V = core.tv.data();
        std::int64_t* T = r.triangles.data();
        std::size_t w = 0;
        for (std::size_t e = 0; e < 3 * ns; e += 3) {
            const std::int32_t a = V[e], b = V[e + 1], c = V[e + 2];
            if (a == detail::kInf || b == detail::kInf || c == detail::kInf) continue;
            T[w] = input_of_id[a];
            T[w + 1] = input_of_id[b];
            T[w + 2] = input_of_id[c];
            w += 3;
        }
        r.triangles.resize(w);
        return r;
    }
    std::vector<std::int32_t> compact;
    const std::size_t m = detail::compact_slots(core, compact);
    detail::export_mesh(core, compact, m, input_of_id.data(), &r.triangles, &r.halfedges);
    return r;
}

}  // namespace faultmesh
