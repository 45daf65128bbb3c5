// faultmesh/aabb_tree.hpp -- a static 2D AABB tree over axis-aligned boxes
// (the XY boxes of triangles or segments), the first stage of the overlap
// detection of paper section 2.4.
//
// Layout: flat arrays, no per-node allocation. Primitives are ordered along a
// Morton (Z-order) curve of their box centres (64-bit codes, LSD radix sort:
// O(n)); the tree splits each range where the highest differing Morton bit
// changes (a quadtree-aligned split, as in Karras' LBVH), and in the middle
// of the range when all codes are equal. Leaves hold up to kLeafSize
// primitives. Each binary node stores the boxes of its two children (a child
// whose box misses the query is never fetched); boxes are the exact double
// unions of their primitives' boxes, so the tree never loses a primitive to
// rounding. Build is O(n log n) in the worst case (depth <= 64 + log2 n),
// O(n) for typical inputs. At most 2^31 - 1 primitives.
//
// Batched queries (query, query_filtered, ...) are processed in Morton order
// of the query centres, so that consecutive queries reuse the cached nodes,
// and their answers are returned in the caller's order.
//
// Query semantics: closed boxes. A primitive is reported for a query box Q
// iff its box B meets Q: B.xmin <= Q.xmax && B.xmax >= Q.xmin &&
// B.ymin <= Q.ymax && B.ymax >= Q.ymin (the paper's candidate set TA).
// Touching boxes count. A query box with xmin > xmax (or ymin > ymax) is
// empty and meets nothing; NaN boxes meet nothing.
//
// Results are primitive indices in the caller's numbering (the position of
// the primitive in the array given to the constructor), sorted ascending per
// query when `sorted` is true (the default), otherwise in tree order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace faultmesh {

struct Box2 {
    double xmin, ymin, xmax, ymax;
};

// True iff the closed boxes meet (see above).
inline bool boxes_meet(const Box2& a, const Box2& b) {
    return a.xmin <= b.xmax && a.xmax >= b.xmin && a.ymin <= b.ymax && a.ymax >= b.ymin;
}

// Many-to-many answer: the hits of query i are indices[offsets[i] .. offsets[i+1]).
struct Csr {
    std::vector<std::int64_t> offsets;  // q + 1 entries, offsets[0] == 0
    std::vector<std::int64_t> indices;
};

class AabbTree {
public:
    static constexpr int kLeafSize = 8;

    AabbTree() = default;

    // Tree over arbitrary boxes (n of them). Throws std::invalid_argument if a
    // box has a NaN coordinate or xmin > xmax / ymin > ymax. Boxes are only
    // compared, so any other box (even +-inf) is fine: the coordinate limit of
    // predicates.hpp applies where the tree meets geometry (from_triangles,
    // from_segments, the exact queries).
    explicit AabbTree(const std::vector<Box2>& boxes);
    AabbTree(const Box2* boxes, std::size_t n);

    // Tree over the XY boxes of triangles (3 vertex indices each) or segments
    // (2 each). `xy` holds n_vertices points with `stride` doubles per point
    // (2 for (x, y), 3 for (x, y, z)); only x and y are used. Throws
    // std::invalid_argument naming the row if an index is out of range or a
    // used coordinate is outside the range of predicates.hpp. The tree keeps
    // boxes only: the exact queries below read xy and the indices again, so
    // the caller must keep those arrays alive and unchanged (the Python
    // AabbTree keeps its own copies).
    static AabbTree from_triangles(const double* xy, std::size_t n_vertices, std::size_t stride,
                                   const std::int64_t* triangles, std::size_t n_triangles);
    static AabbTree from_segments(const double* xy, std::size_t n_vertices, std::size_t stride,
                                  const std::int64_t* segments, std::size_t n_segments);

    std::size_t size() const { return index_.size(); }
    bool empty() const { return index_.empty(); }
    // Union of all boxes ({+inf, +inf, -inf, -inf} for an empty tree).
    Box2 bounds() const;
    // Box of primitive i (caller's numbering).
    Box2 box(std::size_t i) const { return boxes_[rank_[i]]; }
    // Number of internal nodes and depth (levels, leaves included) of the
    // tree, for tests and benchmarks.
    std::size_t node_count() const { return nodes_.size(); }
    int depth() const;

    // Calls f(index) for every primitive whose box meets q, in tree order.
    template <class F>
    void visit(const Box2& q, F&& f) const;

    // True as soon as pred(index) returns true for a primitive whose box meets
    // q (early exit); false if it never does.
    template <class F>
    bool any_of(const Box2& q, F&& pred) const;

    // Appends the hits of one query to `out` (tree order, not sorted).
    void query(const Box2& q, std::vector<std::int64_t>& out) const;

    // Batched queries; one CSR answer in the order of `queries`. The queries
    // are processed in Morton order of their centres (neighbouring queries
    // visit the same nodes while they are in cache) and the answers are put
    // back in input order.
    Csr query(const Box2* queries, std::size_t n_queries, bool sorted = true) const;

    // Batched queries with a refinement: primitive i is reported for query j
    // only if its box meets queries[j] and keep(j, i) is true (e.g. the exact
    // triangle/box test). Same ordering and output as query().
    template <class Keep>
    Csr query_filtered(const Box2* queries, std::size_t n_queries, Keep&& keep,
                       bool sorted = true) const;

    // Batched exact queries over triangles (3 indices per triangle, the same
    // arrays the tree was built from, unchanged): the triangles that
    // themselves meet each closed query box, by triangle_meets_box. The query
    // boxes must lie within the coordinate limit (std::invalid_argument).
    Csr query_triangles_exact(const Box2* queries, std::size_t n_queries, const double* xy,
                              std::size_t stride, const std::int64_t* triangles,
                              bool sorted = true) const;
    // Same for segments (2 indices per segment).
    Csr query_segments_exact(const Box2* queries, std::size_t n_queries, const double* xy,
                             std::size_t stride, const std::int64_t* segments,
                             bool sorted = true) const;

    // Polygon queries, stage 1 of the overlap test: the candidates for a
    // region given as rings (interleaved x, y; ring r is points
    // ring_offsets[r] .. ring_offsets[r+1]) are the primitives whose box meets
    // the box of all the rings' points. Exact refinement against triangles is
    // faultmesh::overlapping_triangles (overlap.hpp).
    void query_polygon(const double* ring_xy, const std::int64_t* ring_offsets, std::size_t n_rings,
                       std::vector<std::int64_t>& out, bool sorted = true) const;

private:
    // Processing order of a batch of queries (Morton order of their centres).
    std::vector<std::uint32_t> batch_order(const Box2* queries, std::size_t n_queries) const;
    // Gathers per-query hits produced in processing order into a CSR in input order.
    static Csr gather(std::vector<std::int64_t>& hits, std::vector<std::int64_t>& start,
                      std::vector<std::int64_t>& count, bool sorted);

    // A binary node stores the boxes of its two children, so a child whose
    // box misses the query is rejected without being fetched. A child is an
    // internal node (cnt == 0, ref = node index) or a leaf (cnt primitives
    // starting at position ref of the tree order).
    struct Node {
        Box2 box[2];
        std::int32_t ref[2];
        std::int32_t cnt[2];
    };
    struct Ref {
        Box2 box;
        std::int32_t ref, cnt;
    };
    void build(const Box2* boxes, std::size_t n);
    Ref build_range(std::int32_t lo, std::int32_t hi, const std::vector<std::uint64_t>& code);
    int depth_of(std::int32_t ref, std::int32_t cnt) const;

    std::vector<Node> nodes_;
    Ref root_{{0, 0, 0, 0}, 0, 0};
    std::vector<Box2> boxes_;          // primitive boxes in tree order
    std::vector<std::int64_t> index_;  // tree order -> caller's index
    std::vector<std::int64_t> rank_;   // caller's index -> tree order
};

// Exact test of a triangle (a, b, c; any orientation, possibly degenerate)
// against a closed axis-aligned box, decided with orient2d on the input
// doubles: true iff the closed triangle and the closed box share a point.
// Used to refine box candidates into true triangle/box hits (what CGAL's
// AABB_tree answers for a Bbox query over triangle primitives).
bool triangle_meets_box(const double* a, const double* b, const double* c, const Box2& box);

// ------------------------------------------------------------- inline
template <class F>
void AabbTree::visit(const Box2& q, F&& f) const {
    (void)any_of(q, [&](std::int64_t i) {
        f(i);
        return false;
    });
}

template <class Keep>
Csr AabbTree::query_filtered(const Box2* queries, std::size_t n_queries, Keep&& keep,
                             bool sorted) const {
    const std::vector<std::uint32_t> order = batch_order(queries, n_queries);
    std::vector<std::int64_t> hits, start(n_queries), count(n_queries);
    hits.reserve(8 * n_queries);
    for (std::uint32_t j : order) {
        start[j] = static_cast<std::int64_t>(hits.size());
        visit(queries[j], [&](std::int64_t i) {
            if (keep(static_cast<std::size_t>(j), i)) hits.push_back(i);
        });
        count[j] = static_cast<std::int64_t>(hits.size()) - start[j];
    }
    return gather(hits, start, count, sorted);
}

template <class F>
bool AabbTree::any_of(const Box2& q, F&& pred) const {
    if (index_.empty() || !(q.xmin <= q.xmax) || !(q.ymin <= q.ymax) || !boxes_meet(root_.box, q))
        return false;
    auto leaf = [&](std::int32_t first, std::int32_t cnt) {
        for (std::int32_t i = first; i < first + cnt; ++i)
            if (boxes_meet(boxes_[static_cast<std::size_t>(i)], q) && pred(index_[static_cast<std::size_t>(i)]))
                return true;
        return false;
    };
    if (root_.cnt > 0) return leaf(root_.ref, root_.cnt);
    std::int32_t stack[128];
    int top = 0;
    stack[top++] = root_.ref;
    while (top > 0) {
        const Node& nd = nodes_[static_cast<std::size_t>(stack[--top])];
        for (int c = 1; c >= 0; --c) {
            if (!boxes_meet(nd.box[c], q)) continue;
            if (nd.cnt[c] > 0) {
                if (leaf(nd.ref[c], nd.cnt[c])) return true;
            } else {
                stack[top++] = nd.ref[c];
            }
        }
    }
    return false;
}

}  // namespace faultmesh
