// AABB tree: Morton order + quadtree-aligned splits, flat node array.
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/predicates.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace faultmesh {

namespace detail {
namespace {

// Spread the 32 bits of x over the even bits of a 64-bit word.
inline std::uint64_t part1by1(std::uint64_t x) {
    x &= 0xffffffffULL;
    x = (x | (x << 16)) & 0x0000ffff0000ffffULL;
    x = (x | (x << 8)) & 0x00ff00ff00ff00ffULL;
    x = (x | (x << 4)) & 0x0f0f0f0f0f0f0f0fULL;
    x = (x | (x << 2)) & 0x3333333333333333ULL;
    x = (x | (x << 1)) & 0x5555555555555555ULL;
    return x;
}

// LSD radix sort of (key, value) pairs on 16-bit digits; digits on which all
// keys agree are skipped (common for the top digits of clustered data).
void radix_sort(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& vals) {
    const std::size_t n = keys.size();
    std::vector<std::uint64_t> k2(n);
    std::vector<std::uint32_t> v2(n);
    std::vector<std::size_t> count(65536);
    for (int pass = 0; pass < 4; ++pass) {
        const int shift = 16 * pass;
        std::fill(count.begin(), count.end(), 0);
        for (std::size_t i = 0; i < n; ++i) ++count[(keys[i] >> shift) & 0xffff];
        if (count[(keys[0] >> shift) & 0xffff] == n) continue;  // one digit value: order unchanged
        std::size_t sum = 0;
        for (auto& c : count) {
            const std::size_t t = c;
            c = sum;
            sum += t;
        }
        for (std::size_t i = 0; i < n; ++i) {
            const std::size_t d = (keys[i] >> shift) & 0xffff;
            const std::size_t p = count[d]++;
            k2[p] = keys[i];
            v2[p] = vals[i];
        }
        keys.swap(k2);
        vals.swap(v2);
    }
}

inline Box2 join(const Box2& a, const Box2& b) {
    return {std::min(a.xmin, b.xmin), std::min(a.ymin, b.ymin), std::max(a.xmax, b.xmax),
            std::max(a.ymax, b.ymax)};
}

constexpr Box2 kEmptyBox = {std::numeric_limits<double>::infinity(),
                            std::numeric_limits<double>::infinity(),
                            -std::numeric_limits<double>::infinity(),
                            -std::numeric_limits<double>::infinity()};

}  // namespace
}  // namespace detail

AabbTree::AabbTree(const std::vector<Box2>& boxes) : AabbTree(boxes.data(), boxes.size()) {}

AabbTree::AabbTree(const Box2* boxes, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
        const Box2& b = boxes[i];
        // Boxes are only compared, never put through a predicate: any
        // ordered, non-NaN box is fine (+-1e300 included), the coordinate
        // limit applies where the tree meets triangles (from_triangles,
        // from_segments, exact queries). The negated comparisons are also
        // true for NaN.
        if (!(b.xmin <= b.xmax) || !(b.ymin <= b.ymax))
            throw std::invalid_argument("AabbTree: box " + std::to_string(i) +
                                        " is empty or has a NaN coordinate (need xmin <= xmax, "
                                        "ymin <= ymax)");
    }
    build(boxes, n);
}

namespace {
AabbTree from_elements(const char* fn, const double* xy, std::size_t n_vertices, std::size_t stride,
                       const std::int64_t* elems, std::size_t n_elems, int per) {
    if (stride < 2) throw std::invalid_argument(std::string(fn) + ": stride must be >= 2");
    std::vector<Box2> boxes(n_elems);
    for (std::size_t t = 0; t < n_elems; ++t) {
        Box2 b = detail::kEmptyBox;
        for (int c = 0; c < per; ++c) {
            const std::int64_t v = elems[per * t + static_cast<std::size_t>(c)];
            if (v < 0 || static_cast<std::uint64_t>(v) >= n_vertices)
                throw std::invalid_argument(std::string(fn) + ": row " + std::to_string(t) +
                                            " has vertex index " + std::to_string(v) +
                                            " out of range [0, " + std::to_string(n_vertices) + ")");
            const double x = xy[stride * static_cast<std::size_t>(v)];
            const double y = xy[stride * static_cast<std::size_t>(v) + 1];
            if (!coordinate_in_range(x) || !coordinate_in_range(y))
                throw_coordinate_error(fn, "vertices row " + std::to_string(v) + " (used by row " + std::to_string(t) + ")",
                                       coordinate_in_range(x) ? 1 : 0, coordinate_in_range(x) ? y : x);
            b.xmin = std::min(b.xmin, x);
            b.xmax = std::max(b.xmax, x);
            b.ymin = std::min(b.ymin, y);
            b.ymax = std::max(b.ymax, y);
        }
        boxes[t] = b;
    }
    AabbTree tree;
    // Boxes built from finite points are valid: no second validation pass.
    tree = AabbTree(boxes.data(), boxes.size());
    return tree;
}
}  // namespace

AabbTree AabbTree::from_triangles(const double* xy, std::size_t n_vertices, std::size_t stride,
                                  const std::int64_t* triangles, std::size_t n_triangles) {
    return from_elements("AabbTree.from_triangles", xy, n_vertices, stride, triangles, n_triangles, 3);
}

AabbTree AabbTree::from_segments(const double* xy, std::size_t n_vertices, std::size_t stride,
                                 const std::int64_t* segments, std::size_t n_segments) {
    return from_elements("AabbTree.from_segments", xy, n_vertices, stride, segments, n_segments, 2);
}

void AabbTree::build(const Box2* boxes, std::size_t n) {
    nodes_.clear();
    boxes_.clear();
    index_.clear();
    rank_.clear();
    root_ = Ref{detail::kEmptyBox, 0, 0};
    if (n == 0) return;
    if (n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::invalid_argument("AabbTree: at most 2^31 - 1 boxes");

    // Morton codes of the box centres, quantised to 32 bits per axis over the
    // centres' bounding box. Centres are computed as xmin/2 + xmax/2 so that
    // huge coordinates cannot overflow.
    double cx0 = std::numeric_limits<double>::infinity(), cy0 = cx0, cx1 = -cx0, cy1 = -cx0;
    std::vector<double> cx(n), cy(n);
    for (std::size_t i = 0; i < n; ++i) {
        cx[i] = 0.5 * boxes[i].xmin + 0.5 * boxes[i].xmax;
        cy[i] = 0.5 * boxes[i].ymin + 0.5 * boxes[i].ymax;
        cx0 = std::min(cx0, cx[i]);
        cx1 = std::max(cx1, cx[i]);
        cy0 = std::min(cy0, cy[i]);
        cy1 = std::max(cy1, cy[i]);
    }
    // 4294967295 = 2^32 - 1; the scale maps the range onto [0, 2^32 - 1].
    const double sx = cx1 > cx0 ? 4294967295.0 / (cx1 - cx0) : 0.0;
    const double sy = cy1 > cy0 ? 4294967295.0 / (cy1 - cy0) : 0.0;
    std::vector<std::uint64_t> code(n);
    std::vector<std::uint32_t> order(n);
    for (std::size_t i = 0; i < n; ++i) {
        // Infinite extents (cx1 - cx0 overflowing) give sx == 0: all codes
        // equal, the tree then splits ranges in the middle -- still correct.
        double qx = (cx[i] - cx0) * sx, qy = (cy[i] - cy0) * sy;
        qx = std::min(std::max(qx, 0.0), 4294967295.0);
        qy = std::min(std::max(qy, 0.0), 4294967295.0);
        if (!(qx == qx)) qx = 0.0;
        if (!(qy == qy)) qy = 0.0;
        code[i] = (detail::part1by1(static_cast<std::uint64_t>(qy)) << 1) |
                  detail::part1by1(static_cast<std::uint64_t>(qx));
        order[i] = static_cast<std::uint32_t>(i);
    }
    std::vector<double>().swap(cx);
    std::vector<double>().swap(cy);
    detail::radix_sort(code, order);

    boxes_.resize(n);
    index_.resize(n);
    rank_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        boxes_[i] = boxes[order[i]];
        index_[i] = order[i];
        rank_[order[i]] = static_cast<std::int64_t>(i);
    }
    nodes_.reserve(n / kLeafSize + 1);
    root_ = build_range(0, static_cast<std::int32_t>(n), code);
    if (depth() > 120) throw std::logic_error("AabbTree: tree deeper than the query stack");
}

// Depth-first build over the Morton-sorted range [lo, hi): a node's index is
// reserved before its children's, so the layout is pre-order. Recursion depth
// is the tree depth (<= 64 bit levels + log2 n middle splits).
AabbTree::Ref AabbTree::build_range(std::int32_t lo, std::int32_t hi, const std::vector<std::uint64_t>& code) {
    if (hi - lo <= kLeafSize) {
        Box2 b = detail::kEmptyBox;
        for (std::int32_t j = lo; j < hi; ++j) b = detail::join(b, boxes_[static_cast<std::size_t>(j)]);
        return {b, lo, hi - lo};
    }
    const std::uint64_t c0 = code[static_cast<std::size_t>(lo)];
    const std::uint64_t c1 = code[static_cast<std::size_t>(hi - 1)];
    std::int32_t split;
    if (c0 == c1) {
        split = lo + (hi - lo) / 2;
    } else {
        // First position whose code has the highest differing bit set.
        const int bit = 63 - __builtin_clzll(c0 ^ c1);
        const std::uint64_t prefix = (c0 >> bit) | 1;  // c1's prefix
        std::int32_t a = lo + 1, b = hi - 1;
        while (a < b) {
            const std::int32_t mid = a + (b - a) / 2;
            if ((code[static_cast<std::size_t>(mid)] >> bit) >= prefix)
                b = mid;
            else
                a = mid + 1;
        }
        split = a;
    }
    const auto self = static_cast<std::int32_t>(nodes_.size());
    nodes_.push_back(Node{});
    const Ref l = build_range(lo, split, code);
    const Ref r = build_range(split, hi, code);
    Node& nd = nodes_[static_cast<std::size_t>(self)];
    nd.box[0] = l.box;
    nd.box[1] = r.box;
    nd.ref[0] = l.ref;
    nd.ref[1] = r.ref;
    nd.cnt[0] = l.cnt;
    nd.cnt[1] = r.cnt;
    return {detail::join(l.box, r.box), self, 0};
}

Box2 AabbTree::bounds() const { return index_.empty() ? detail::kEmptyBox : root_.box; }

int AabbTree::depth_of(std::int32_t ref, std::int32_t cnt) const {
    if (cnt > 0) return 1;
    const Node& nd = nodes_[static_cast<std::size_t>(ref)];
    return 1 + std::max(depth_of(nd.ref[0], nd.cnt[0]), depth_of(nd.ref[1], nd.cnt[1]));
}

int AabbTree::depth() const { return index_.empty() ? 0 : depth_of(root_.ref, root_.cnt); }

void AabbTree::query(const Box2& q, std::vector<std::int64_t>& out) const {
    visit(q, [&](std::int64_t i) { out.push_back(i); });
}

std::vector<std::uint32_t> AabbTree::batch_order(const Box2* queries, std::size_t n_queries) const {
    std::vector<std::uint32_t> order(n_queries);
    for (std::size_t i = 0; i < n_queries; ++i) order[i] = static_cast<std::uint32_t>(i);
    if (n_queries < 64 || index_.empty()) return order;
    // 16 bits per axis over the tree's bounds is plenty to group neighbours.
    const Box2 b = bounds();
    const double sx = b.xmax > b.xmin ? 65535.0 / (b.xmax - b.xmin) : 0.0;
    const double sy = b.ymax > b.ymin ? 65535.0 / (b.ymax - b.ymin) : 0.0;
    std::vector<std::uint64_t> code(n_queries);
    for (std::size_t i = 0; i < n_queries; ++i) {
        const Box2& q = queries[i];
        double qx = ((0.5 * q.xmin + 0.5 * q.xmax) - b.xmin) * sx;
        double qy = ((0.5 * q.ymin + 0.5 * q.ymax) - b.ymin) * sy;
        // Clamp (and map NaN to 0): the order only affects speed.
        qx = qx >= 0.0 ? std::min(qx, 65535.0) : 0.0;
        qy = qy >= 0.0 ? std::min(qy, 65535.0) : 0.0;
        if (!std::isfinite(sx) || !std::isfinite(sy)) qx = qy = 0.0;
        code[i] = (detail::part1by1(static_cast<std::uint64_t>(qy)) << 1) |
                  detail::part1by1(static_cast<std::uint64_t>(qx));
    }
    detail::radix_sort(code, order);
    return order;
}

Csr AabbTree::gather(std::vector<std::int64_t>& hits, std::vector<std::int64_t>& start,
                     std::vector<std::int64_t>& count, bool sorted) {
    const std::size_t nq = start.size();
    Csr r;
    r.offsets.resize(nq + 1);
    r.offsets[0] = 0;
    for (std::size_t j = 0; j < nq; ++j) r.offsets[j + 1] = r.offsets[j] + count[j];
    r.indices.resize(hits.size());
    for (std::size_t j = 0; j < nq; ++j) {
        auto src = hits.begin() + start[j];
        auto dst = r.indices.begin() + r.offsets[j];
        std::copy(src, src + count[j], dst);
        if (!sorted) continue;
        if (count[j] <= 24) {
            // Typical answers are short: insertion sort beats introsort's setup.
            for (std::int64_t a = 1; a < count[j]; ++a) {
                const std::int64_t x = dst[a];
                std::int64_t b = a;
                for (; b > 0 && dst[b - 1] > x; --b) dst[b] = dst[b - 1];
                dst[b] = x;
            }
        } else {
            std::sort(dst, dst + count[j]);
        }
    }
    return r;
}

Csr AabbTree::query(const Box2* queries, std::size_t n_queries, bool sorted) const {
    return query_filtered(queries, n_queries, [](std::size_t, std::int64_t) { return true; }, sorted);
}

namespace {
// The box corners of exact queries enter orient2d: the coordinate limit
// (predicates.hpp) applies to them.
void check_query_boxes(const Box2* q, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
        const double c[4] = {q[i].xmin, q[i].ymin, q[i].xmax, q[i].ymax};
        for (int k = 0; k < 4; ++k)
            if (!coordinate_in_range(c[k]))
                throw_coordinate_error("AabbTree.query(exact=True)", "boxes row " + std::to_string(i), k % 2, c[k]);
    }
}
}  // namespace

Csr AabbTree::query_triangles_exact(const Box2* queries, std::size_t n_queries, const double* xy,
                                    std::size_t stride, const std::int64_t* triangles,
                                    bool sorted) const {
    // The box corners enter orient2d: the coordinate limit applies to them.
    check_query_boxes(queries, n_queries);
    return query_filtered(
        queries, n_queries,
        [&](std::size_t j, std::int64_t t) {
            const std::int64_t* e = triangles + 3 * t;
            return triangle_meets_box(xy + stride * static_cast<std::size_t>(e[0]),
                                      xy + stride * static_cast<std::size_t>(e[1]),
                                      xy + stride * static_cast<std::size_t>(e[2]), queries[j]);
        },
        sorted);
}

Csr AabbTree::query_segments_exact(const Box2* queries, std::size_t n_queries, const double* xy,
                                   std::size_t stride, const std::int64_t* segments,
                                   bool sorted) const {
    check_query_boxes(queries, n_queries);
    return query_filtered(
        queries, n_queries,
        [&](std::size_t j, std::int64_t s) {
            const std::int64_t* e = segments + 2 * s;
            const double* b = xy + stride * static_cast<std::size_t>(e[1]);
            return triangle_meets_box(xy + stride * static_cast<std::size_t>(e[0]), b, b, queries[j]);
        },
        sorted);
}

void AabbTree::query_polygon(const double* ring_xy, const std::int64_t* ring_offsets,
                             std::size_t n_rings, std::vector<std::int64_t>& out,
                             bool sorted) const {
    Box2 q = detail::kEmptyBox;
    for (std::size_t r = 0; r < n_rings; ++r) {
        if (ring_offsets[r] < 0 || ring_offsets[r + 1] < ring_offsets[r])
            throw std::invalid_argument("AabbTree.query_polygon: ring offsets must be non-negative "
                                        "and non-decreasing (ring " + std::to_string(r) + ")");
        for (std::int64_t p = ring_offsets[r]; p < ring_offsets[r + 1]; ++p) {
            const double x = ring_xy[2 * p], y = ring_xy[2 * p + 1];
            if (!coordinate_in_range(x) || !coordinate_in_range(y))
                throw_coordinate_error("AabbTree.query_polygon", "ring " + std::to_string(r) + " point " +
                                                                     std::to_string(p - ring_offsets[r]),
                                       coordinate_in_range(x) ? 1 : 0, coordinate_in_range(x) ? y : x);
            q.xmin = std::min(q.xmin, x);
            q.xmax = std::max(q.xmax, x);
            q.ymin = std::min(q.ymin, y);
            q.ymax = std::max(q.ymax, y);
        }
    }
    const std::size_t start = out.size();
    query(q, out);
    if (sorted) std::sort(out.begin() + static_cast<std::ptrdiff_t>(start), out.end());
}

bool triangle_meets_box(const double* a, const double* b, const double* c, const Box2& box) {
    // Separating axes: the box's axes (bounding-box test) and the triangle's
    // edge normals; closed sets are disjoint iff strictly separated on one.
    const double txmin = std::min({a[0], b[0], c[0]}), txmax = std::max({a[0], b[0], c[0]});
    const double tymin = std::min({a[1], b[1], c[1]}), tymax = std::max({a[1], b[1], c[1]});
    if (!(txmin <= box.xmax && txmax >= box.xmin && tymin <= box.ymax && tymax >= box.ymin))
        return false;
    // Quick accept: a vertex in the closed box (coordinate comparisons only).
    auto in_box = [&](const double* p) {
        return p[0] >= box.xmin && p[0] <= box.xmax && p[1] >= box.ymin && p[1] <= box.ymax;
    };
    if (in_box(a) || in_box(b) || in_box(c)) return true;
    const int s = orient2d_sign(a, b, c);
    if (s == 0) {
        // Degenerate triangle: a segment between its two extreme points (a
        // point would have been accepted above). Separated iff all corners
        // lie strictly on one side of the segment's line.
        const double* pts[3] = {a, b, c};
        const double* lo = a;
        const double* hi = a;
        for (const double* p : pts) {
            if (p[0] < lo[0] || (p[0] == lo[0] && p[1] < lo[1])) lo = p;
            if (p[0] > hi[0] || (p[0] == hi[0] && p[1] > hi[1])) hi = p;
        }
        const double corners[4][2] = {
            {box.xmin, box.ymin}, {box.xmax, box.ymin}, {box.xmax, box.ymax}, {box.xmin, box.ymax}};
        int pos = 0, neg = 0;
        for (const auto& q : corners) {
            const int o = orient2d_sign(lo, hi, q);
            pos += o > 0;
            neg += o < 0;
        }
        return !(pos == 4 || neg == 4);
    }
    // For each edge u -> v only the corner deepest on the triangle's side can
    // decide: the signs of the edge's (exactly signed) coordinate differences
    // pick it. With the triangle on the left (s > 0), orient(u, v, corner)
    // grows with -dy * x + dx * y.
    const double* tri[3] = {a, b, c};
    for (int e = 0; e < 3; ++e) {
        const double* u = tri[e];
        const double* v = tri[(e + 1) % 3];
        double dx = v[0] - u[0], dy = v[1] - u[1];
        if (s < 0) {
            dx = -dx;
            dy = -dy;
        }
        const double corner[2] = {dy > 0 ? box.xmin : box.xmax, dx > 0 ? box.ymax : box.ymin};
        if (s * orient2d_sign(u, v, corner) < 0) return false;
    }
    return true;
}

}  // namespace faultmesh
