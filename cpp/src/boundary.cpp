// Boundary contours: edge frequency by counting sort, Algorithm 1 sorting.
#include <faultmesh/boundary.hpp>
#include <faultmesh/errors.hpp>

#include <algorithm>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace faultmesh {

namespace detail {
namespace {

// ------------------------------------------------------------ validation
// One streaming pass: negative indices, repeated vertices and the largest
// index are accumulated without branches; the row is searched only on error.
std::size_t check_triangles(const char* fn, const std::int64_t* tri, std::size_t m,
                            std::size_t n_vertices) {
    std::int64_t mx = -1;
    bool bad = false;
    for (std::size_t t = 0; t < m; ++t) {
        const std::int64_t a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2];
        bad |= (a < 0) | (b < 0) | (c < 0) | (a == b) | (b == c) | (c == a);
        mx = std::max(mx, std::max(a, std::max(b, c)));
    }
    if (bad) {
        for (std::size_t t = 0; t < m; ++t) {
            const std::int64_t a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2];
            if (a < 0 || b < 0 || c < 0)
                throw std::invalid_argument(std::string(fn) + ": triangles row " + std::to_string(t) +
                                            " has a negative vertex index");
            if (a == b || b == c || c == a)
                throw std::invalid_argument(std::string(fn) + ": triangles row " + std::to_string(t) +
                                            " repeats vertex " + std::to_string(a == b || a == c ? a : b));
        }
    }
    std::size_t n = n_vertices;
    if (n == 0) {
        n = static_cast<std::size_t>(mx) + 1;
    } else if (mx >= 0 && static_cast<std::size_t>(mx) >= n) {
        for (std::size_t t = 0; t < 3 * m; ++t)
            if (tri[t] == mx)
                throw std::invalid_argument(std::string(fn) + ": triangles row " + std::to_string(t / 3) +
                                            " has vertex index " + std::to_string(mx) + " out of range [0, " +
                                            std::to_string(n) + ")");
    }
    return n;
}

// The vertex numbering the edge count works on. Its tables are O(vertices),
// so a few huge indices (or a huge n_vertices) would allocate by the largest
// index: when the range is far beyond the 3 m corners the triangles can use,
// the used vertices are renumbered 0..k-1 in increasing order. The map is
// monotone, so every output order (edges by smaller vertex, loops by start
// vertex) is the same as with the original numbers, mapped back at the end.
struct Numbering {
    const std::int64_t* tri = nullptr;      // the triangles in this numbering
    std::size_t n = 0;                      // its vertex count
    std::vector<std::int64_t> compact_tri;  // owned triangles when renumbered
    std::vector<std::int64_t> original;     // compact id -> input id (empty: identity)
    std::int64_t input_id(std::int64_t v) const {
        return original.empty() ? v : original[static_cast<std::size_t>(v)];
    }
    void to_input(std::vector<std::int64_t>& v) const {
        if (!original.empty())
            for (auto& x : v) x = original[static_cast<std::size_t>(x)];
    }
};

Numbering numbering(const char* fn, const std::int64_t* tri, std::size_t m, std::size_t n_vertices) {
    Numbering r;
    r.tri = tri;
    r.n = check_triangles(fn, tri, m, n_vertices);
    // 1024: small meshes keep their numbering (no renumbering cost at all).
    if (r.n > 3 * m + 1024) {
        r.original.assign(tri, tri + 3 * m);
        std::sort(r.original.begin(), r.original.end());
        r.original.erase(std::unique(r.original.begin(), r.original.end()), r.original.end());
        r.compact_tri.resize(3 * m);
        for (std::size_t i = 0; i < 3 * m; ++i)
            r.compact_tri[i] = std::lower_bound(r.original.begin(), r.original.end(), tri[i]) - r.original.begin();
        r.tri = r.compact_tri.data();
        r.n = r.original.size();
    }
    if (r.n > (std::size_t{1} << 31) - 1)
        throw std::invalid_argument(std::string(fn) + ": at most 2^31 - 1 vertices");
    return r;
}

// ------------------------------------------------------------ edge frequency
struct EdgeCount {
    std::vector<std::int64_t> boundary;     // (from, to) pairs, by smaller vertex
    std::vector<std::int64_t> nonmanifold;  // (min, max) pairs
    std::vector<std::int64_t> inconsistent;
};

// Every half-edge u -> v of every triangle goes into the bucket of its
// smaller vertex (counting sort: one counting pass, one placing pass). An
// entry is 4 bytes: the larger vertex (31 bits) and whether the half-edge
// leaves the bucket's vertex (1 bit); the bucket is the other endpoint. In a
// TIN a bucket holds about six entries, so each is matched against all others
// of its bucket with branch-free compares (vectorised); buckets above 32
// entries (fan centres) are sorted instead. A group of entries with the same
// larger vertex is one undirected edge: 1 entry = boundary edge, 2 entries of
// opposite directions = interior edge, 2 of one direction = inconsistent
// orientation, 3+ = non-manifold.
EdgeCount count_edges(const std::int64_t* tri, std::size_t m, std::size_t n) {
    if (3 * m > std::numeric_limits<std::uint32_t>::max())
        throw std::invalid_argument("boundary: at most 1431655765 triangles");
    EdgeCount out;
    std::vector<std::uint32_t> start(n + 1, 0);
    for (std::size_t t = 0; t < m; ++t) {
        const auto a = static_cast<std::uint32_t>(tri[3 * t]);
        const auto b = static_cast<std::uint32_t>(tri[3 * t + 1]);
        const auto c = static_cast<std::uint32_t>(tri[3 * t + 2]);
        ++start[std::min(a, b) + 1];
        ++start[std::min(b, c) + 1];
        ++start[std::min(c, a) + 1];
    }
    for (std::size_t v = 0; v < n; ++v) start[v + 1] += start[v];
    // Every slot is written by the placing pass: no zero-initialisation.
    // The placing pass advances start[v] itself (no separate fill array: a
    // smaller working set for the random accesses); afterwards bucket v is
    // [start[v-1], start[v]) with start[-1] = 0, and start is shifted back.
    std::unique_ptr<std::uint32_t[]> entry(new std::uint32_t[3 * m + 1]);
    {
        std::uint32_t* E = entry.get();
        std::uint32_t* F = start.data();
        // Branch-free: the direction is random in a TIN, a branch on u < v
        // would be mispredicted half the time.
        auto put = [E, F](std::uint32_t u, std::uint32_t v) {
            const std::uint32_t lt = u < v;
            const std::uint32_t key = lt ? u : v, other = lt ? v : u;
            E[F[key]++] = (other << 1) | lt;
        };
        for (std::size_t t = 0; t < m; ++t) {
            const auto a = static_cast<std::uint32_t>(tri[3 * t]);
            const auto b = static_cast<std::uint32_t>(tri[3 * t + 1]);
            const auto c = static_cast<std::uint32_t>(tri[3 * t + 2]);
            put(a, b);
            put(b, c);
            put(c, a);
        }
        for (std::size_t v = n; v > 0; --v) start[v] = start[v - 1];
        start[0] = 0;
    }
    auto emit_boundary = [&](std::size_t v, std::uint32_t e) {
        const auto o = static_cast<std::int64_t>(e >> 1);
        const auto k = static_cast<std::int64_t>(v);
        if (e & 1u) {
            out.boundary.push_back(k);
            out.boundary.push_back(o);
        } else {
            out.boundary.push_back(o);
            out.boundary.push_back(k);
        }
    };
    auto irregular = [&](std::size_t v, std::uint32_t other, unsigned cnt, unsigned leaving) {
        auto& dst = cnt == 2 ? out.inconsistent : out.nonmanifold;
        if (cnt == 2 && leaving == 1) return;  // regular interior edge
        dst.push_back(static_cast<std::int64_t>(v));
        dst.push_back(static_cast<std::int64_t>(other));
    };
    const std::uint32_t* E = entry.get();
    for (std::size_t v = 0; v < n; ++v) {
        const std::size_t s = start[v], d = start[v + 1] - s;
        std::uint32_t* b = entry.get() + s;
        if (d <= 32) {
            for (std::size_t i = 0; i < d; ++i) {
                const std::uint32_t o = E[s + i] >> 1;
                unsigned cnt = 0, leaving = 0;
                for (std::size_t j = 0; j < d; ++j) {
                    const unsigned eq = (E[s + j] >> 1) == o;
                    cnt += eq;
                    leaving += eq & E[s + j];
                }
                if (cnt == 1) {
                    emit_boundary(v, E[s + i]);
                } else if (!(cnt == 2 && leaving == 1)) {
                    // Report each irregular edge once: at its first entry.
                    bool first = true;
                    for (std::size_t j = 0; j < i; ++j) first &= (E[s + j] >> 1) != o;
                    if (first) irregular(v, o, cnt, leaving);
                }
            }
        } else {
            // Sorting changes the order within the bucket; boundary entries
            // are then emitted by increasing other vertex.
            std::sort(b, b + d);
            for (std::size_t i = 0; i < d;) {
                const std::uint32_t o = b[i] >> 1;
                std::size_t j = i + 1;
                unsigned leaving = b[i] & 1u;
                while (j < d && (b[j] >> 1) == o) leaving += b[j++] & 1u;
                const auto cnt = static_cast<unsigned>(j - i);
                if (cnt == 1)
                    emit_boundary(v, b[i]);
                else
                    irregular(v, o, cnt, leaving);
                i = j;
            }
        }
    }
    return out;
}

// ------------------------------------------------------------ Algorithm 1
// Pairing at a pinch vertex: given the boundary edges entering and leaving
// v (ids into the segment list, input order), fill succ (same length as
// in_edges) with the successor of each entering edge, or return false if the
// pairing cannot be decided (the sequences are then cut at v).
using PinchResolver = std::function<bool(std::int64_t v, const std::vector<std::int64_t>& in_edges,
                                         const std::vector<std::int64_t>& out_edges,
                                         std::vector<std::int64_t>& succ)>;

// Directed segments seg[2e] -> seg[2e+1]. The per-vertex tables are indexed
// by a compact numbering of the segments' own vertices, so the cost does not
// depend on the size of the mesh the segments came from.
BoundaryContours assemble(const std::vector<std::int64_t>& seg, const PinchResolver& resolve) {
    BoundaryContours res;
    const std::size_t k = seg.size() / 2;
    if (k == 0) return res;
    std::vector<std::int64_t> verts(seg);
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    const std::size_t nv = verts.size();
    std::vector<std::uint32_t> lid(2 * k);
    for (std::size_t i = 0; i < 2 * k; ++i)
        lid[i] = static_cast<std::uint32_t>(std::lower_bound(verts.begin(), verts.end(), seg[i]) - verts.begin());
    std::vector<std::int32_t> outd(nv, 0), ind(nv, 0);
    for (std::size_t e = 0; e < k; ++e) {
        ++outd[lid[2 * e]];
        ++ind[lid[2 * e + 1]];
    }
    // Irregular vertices: pinch (in == out >= 2) or break (in != out, one >= 2).
    std::vector<std::int64_t> special;  // vertices with in >= 2 or out >= 2, sorted
    for (std::size_t v = 0; v < nv; ++v)
        if (outd[v] >= 2 || ind[v] >= 2) special.push_back(verts[v]);
    res.pinch_vertices = special;

    // Explicit successor for edges entering special vertices: -2 = not
    // special, -1 = cut here, else the successor edge.
    std::vector<std::int64_t> succ_special(k, -2), pred_special(k, -2);
    if (!special.empty()) {
        std::unordered_map<std::int64_t, std::size_t> slot;
        slot.reserve(special.size() * 2);
        for (std::size_t i = 0; i < special.size(); ++i) slot[special[i]] = i;
        std::vector<std::vector<std::int64_t>> ins(special.size()), outs(special.size());
        for (std::size_t e = 0; e < k; ++e) {
            auto it = slot.find(seg[2 * e]);
            if (it != slot.end()) outs[it->second].push_back(static_cast<std::int64_t>(e));
            it = slot.find(seg[2 * e + 1]);
            if (it != slot.end()) ins[it->second].push_back(static_cast<std::int64_t>(e));
        }
        std::vector<std::int64_t> succ;
        for (std::size_t i = 0; i < special.size(); ++i) {
            bool ok = ins[i].size() == outs[i].size();
            if (ok) {
                succ.assign(ins[i].size(), -1);
                ok = resolve(special[i], ins[i], outs[i], succ);
                // The pairing must be a bijection between entering and leaving edges.
                if (ok) {
                    std::vector<std::int64_t> s = succ;
                    std::sort(s.begin(), s.end());
                    std::vector<std::int64_t> o = outs[i];
                    std::sort(o.begin(), o.end());
                    ok = s == o;
                }
            }
            if (!ok) {
                res.chain_break_vertices.push_back(special[i]);
                for (std::int64_t e : ins[i]) succ_special[static_cast<std::size_t>(e)] = -1;
                for (std::int64_t e : outs[i]) pred_special[static_cast<std::size_t>(e)] = -1;
            } else {
                for (std::size_t j = 0; j < ins[i].size(); ++j) {
                    succ_special[static_cast<std::size_t>(ins[i][j])] = succ[j];
                    pred_special[static_cast<std::size_t>(succ[j])] = ins[i][j];
                }
            }
        }
    }

    // Head and tail insertion, segments in input order. A regular vertex has
    // at most one sequence ending there (tail slot) and one starting there
    // (head slot); a new segment is linked after the sequence whose tail it
    // continues and before the sequence whose head it precedes. Linking both
    // ways joins two sequences, or closes a loop when they are the same one.
    std::vector<std::int64_t> next(k, -1), prev(k, -1);
    std::vector<char> placed(k, 0);
    std::vector<std::int64_t> head_slot(nv, -1), tail_slot(nv, -1);
    auto link = [&](std::int64_t p, std::int64_t e) {
        next[static_cast<std::size_t>(p)] = e;
        prev[static_cast<std::size_t>(e)] = p;
    };
    for (std::size_t e = 0; e < k; ++e) {
        const std::size_t a = lid[2 * e], b = lid[2 * e + 1];
        const auto ei = static_cast<std::int64_t>(e);
        placed[e] = 1;
        // Where the segment starts.
        if (pred_special[e] != -2) {
            const std::int64_t p = pred_special[e];
            if (p >= 0 && placed[static_cast<std::size_t>(p)]) link(p, ei);
        } else if (tail_slot[a] >= 0) {
            link(tail_slot[a], ei);  // tail insertion
            tail_slot[a] = -1;
        } else {
            head_slot[a] = ei;
        }
        // Where it ends.
        if (succ_special[e] != -2) {
            const std::int64_t s = succ_special[e];
            if (s >= 0 && placed[static_cast<std::size_t>(s)]) link(ei, s);
        } else if (head_slot[b] >= 0) {
            link(ei, head_slot[b]);  // head insertion
            head_slot[b] = -1;
        } else {
            tail_slot[b] = ei;
        }
    }

    // Read the sequences off the links: open chains from their heads, then
    // the remaining edges are loops.
    std::vector<char> seen(k, 0);
    std::vector<std::vector<std::int64_t>> chains;
    for (std::size_t e = 0; e < k; ++e) {
        if (prev[e] != -1) continue;
        std::vector<std::int64_t> c;
        std::int64_t f = static_cast<std::int64_t>(e);
        c.push_back(seg[2 * e]);
        while (f != -1) {
            seen[static_cast<std::size_t>(f)] = 1;
            c.push_back(seg[2 * static_cast<std::size_t>(f) + 1]);
            f = next[static_cast<std::size_t>(f)];
        }
        chains.push_back(std::move(c));
    }
    std::vector<std::vector<std::int64_t>> loops;
    for (std::size_t e = 0; e < k; ++e) {
        if (seen[e]) continue;
        // Canonical start: the edge with the smallest (from, to).
        std::size_t best = e;
        std::size_t f = e;
        do {
            seen[f] = 1;
            if (seg[2 * f] < seg[2 * best] || (seg[2 * f] == seg[2 * best] && seg[2 * f + 1] < seg[2 * best + 1]))
                best = f;
            f = static_cast<std::size_t>(next[f]);
        } while (f != e);
        std::vector<std::int64_t> loop;
        f = best;
        do {
            loop.push_back(seg[2 * f]);
            f = static_cast<std::size_t>(next[f]);
        } while (f != best);
        loops.push_back(std::move(loop));
    }
    auto lex = [](const std::vector<std::int64_t>& x, const std::vector<std::int64_t>& y) {
        return x < y;
    };
    std::sort(loops.begin(), loops.end(), lex);
    std::sort(chains.begin(), chains.end(), lex);
    res.loops = std::move(loops);
    res.open_chains = std::move(chains);
    return res;
}

}  // namespace
}  // namespace detail

std::vector<std::int64_t> boundary_edges(const std::int64_t* triangles, std::size_t n_triangles,
                                         std::size_t n_vertices) {
    const detail::Numbering nb = detail::numbering("boundary_edges", triangles, n_triangles, n_vertices);
    std::vector<std::int64_t> e = detail::count_edges(nb.tri, n_triangles, nb.n).boundary;
    nb.to_input(e);
    return e;
}

BoundaryContours boundary_contours(const std::int64_t* triangles, std::size_t n_triangles,
                                   std::size_t n_vertices) {
    const detail::Numbering nb = detail::numbering("boundary_contours", triangles, n_triangles, n_vertices);
    const std::size_t n = nb.n;
    triangles = nb.tri;  // from here on in the (possibly compact) numbering
    detail::EdgeCount ec = detail::count_edges(triangles, n_triangles, n);
    const std::vector<std::int64_t>& seg = ec.boundary;
    const std::size_t k = seg.size() / 2;

    // Star of every pinch vertex, gathered lazily in one pass over the
    // triangles the first time a pinch needs resolving.
    std::unordered_map<std::int64_t, std::vector<std::uint32_t>> star;  // v -> triangles
    bool star_built = false;
    auto resolve = [&](std::int64_t v, const std::vector<std::int64_t>& in_edges,
                       const std::vector<std::int64_t>& out_edges,
                       std::vector<std::int64_t>& succ) -> bool {
        if (!star_built) {
            // First pinch: gather the stars of all vertices that lie on more
            // than one boundary edge (one pass over the triangles).
            star_built = true;
            // A bitset over the vertices filters the hash lookups.
            std::unordered_map<std::int64_t, int> deg;
            for (std::size_t e = 0; e < k; ++e) ++deg[seg[2 * e]];
            std::vector<std::uint64_t> mark(n / 64 + 1, 0);
            for (const auto& kv : deg)
                if (kv.second >= 2) {
                    star[kv.first];
                    mark[static_cast<std::size_t>(kv.first) >> 6] |= std::uint64_t{1} << (kv.first & 63);
                }
            for (std::size_t t = 0; t < n_triangles; ++t)
                for (int c = 0; c < 3; ++c) {
                    const std::int64_t v = triangles[3 * t + static_cast<std::size_t>(c)];
                    if (!((mark[static_cast<std::size_t>(v) >> 6] >> (v & 63)) & 1)) continue;
                    star[v].push_back(static_cast<std::uint32_t>(t));
                }
        }
        auto sit = star.find(v);
        if (sit == star.end()) return false;
        // Around v, triangle t = (v, x, y) has the half-edge v -> x leaving v
        // and y -> v entering it. Map "entering from y" -> triangle.
        std::unordered_map<std::int64_t, std::pair<std::int64_t, std::int64_t>> enter;  // y -> (x, t)
        for (std::uint32_t t : sit->second) {
            const std::int64_t* T = triangles + 3 * static_cast<std::size_t>(t);
            int r = T[0] == v ? 0 : T[1] == v ? 1 : 2;
            const std::int64_t x = T[(r + 1) % 3], y = T[(r + 2) % 3];
            if (!enter.emplace(y, std::make_pair(x, static_cast<std::int64_t>(t))).second)
                return false;  // two triangles enter v from y: inconsistent or non-manifold
        }
        std::unordered_map<std::int64_t, std::int64_t> leave_edge;  // x -> boundary edge v -> x
        for (std::int64_t e : out_edges) leave_edge[seg[2 * static_cast<std::size_t>(e) + 1]] = e;
        for (std::size_t i = 0; i < in_edges.size(); ++i) {
            // The entering boundary edge u -> v belongs to the triangle (v, x, u).
            const std::int64_t u = seg[2 * static_cast<std::size_t>(in_edges[i])];
            auto it = enter.find(u);
            if (it == enter.end()) return false;
            std::int64_t x = it->second.first;
            std::size_t steps = 0;
            for (;;) {
                auto le = leave_edge.find(x);
                if (le != leave_edge.end()) {
                    succ[i] = le->second;
                    break;
                }
                // v -> x is interior: continue in the triangle entering v from x.
                auto nx = enter.find(x);
                if (nx == enter.end() || ++steps > sit->second.size()) return false;
                x = nx->second.first;
            }
        }
        return true;
    };
    BoundaryContours res = detail::assemble(seg, resolve);
    res.nonmanifold_edges = std::move(ec.nonmanifold);
    res.inconsistent_edges = std::move(ec.inconsistent);
    if (!nb.original.empty()) {
        for (auto& l : res.loops) nb.to_input(l);
        for (auto& c : res.open_chains) nb.to_input(c);
        nb.to_input(res.pinch_vertices);
        nb.to_input(res.nonmanifold_edges);
        nb.to_input(res.inconsistent_edges);
        nb.to_input(res.chain_break_vertices);
    }
    return res;
}

std::vector<std::vector<std::int64_t>> boundary_loops(const std::int64_t* triangles,
                                                      std::size_t n_triangles,
                                                      std::size_t n_vertices, bool strict) {
    BoundaryContours c = boundary_contours(triangles, n_triangles, n_vertices);
    if (strict) {
        if (!c.nonmanifold_edges.empty())
            throw GeometryError("boundary_loops: edge (" + std::to_string(c.nonmanifold_edges[0]) + ", " +
                                std::to_string(c.nonmanifold_edges[1]) +
                                ") is used by three or more triangles (non-manifold); vertex " +
                                std::to_string(c.nonmanifold_edges[0]) +
                                "; pass strict=False or call boundary_contours for the full report");
        if (!c.inconsistent_edges.empty())
            throw GeometryError("boundary_loops: edge (" + std::to_string(c.inconsistent_edges[0]) + ", " +
                                std::to_string(c.inconsistent_edges[1]) +
                                ") is used twice in the same direction (inconsistent triangle "
                                "orientation); vertex " + std::to_string(c.inconsistent_edges[0]) +
                                "; pass strict=False or call boundary_contours for the full report");
        if (!c.pinch_vertices.empty())
            throw GeometryError("boundary_loops: vertex " + std::to_string(c.pinch_vertices[0]) +
                                " is a pinch vertex (it lies on the boundary more than once)" +
                                (c.pinch_vertices.size() > 1
                                     ? " (and " + std::to_string(c.pinch_vertices.size() - 1) + " more)"
                                     : std::string()) +
                                "; pass strict=False or call boundary_contours for the full report");
        if (!c.open_chains.empty())
            throw GeometryError("boundary_loops: the boundary has an open chain from vertex " +
                                std::to_string(c.open_chains[0].front()) + " to vertex " +
                                std::to_string(c.open_chains[0].back()) +
                                " (non-manifold or inconsistently oriented triangles)"
                                "; pass strict=False or call boundary_contours for the full report");
    }
    return std::move(c.loops);
}

BoundaryContours sort_segments(const std::int64_t* segments, std::size_t n_segments,
                               std::size_t n_vertices) {
    std::int64_t mx = -1;
    for (std::size_t e = 0; e < 2 * n_segments; ++e) {
        if (segments[e] < 0)
            throw std::invalid_argument("sort_segments: segments row " + std::to_string(e / 2) +
                                        " has a negative vertex index");
        mx = std::max(mx, segments[e]);
    }
    std::size_t n = n_vertices;
    if (n == 0) {
        n = static_cast<std::size_t>(mx) + 1;
    } else if (mx >= 0 && static_cast<std::size_t>(mx) >= n) {
        throw std::invalid_argument("sort_segments: vertex index " + std::to_string(mx) +
                                    " out of range [0, " + std::to_string(n) + ")");
    }
    std::vector<std::int64_t> seg(segments, segments + 2 * n_segments);
    // Without triangles a pinch is paired in input order: the i-th segment
    // entering v is followed by the i-th segment leaving it.
    auto resolve = [](std::int64_t, const std::vector<std::int64_t>& in_edges,
                      const std::vector<std::int64_t>& out_edges, std::vector<std::int64_t>& succ) {
        for (std::size_t i = 0; i < in_edges.size(); ++i) succ[i] = out_edges[i];
        return true;
    };
    return detail::assemble(seg, resolve);
}

}  // namespace faultmesh
