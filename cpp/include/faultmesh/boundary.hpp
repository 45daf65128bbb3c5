// faultmesh/boundary.hpp -- boundary contours of a triangulated surface
// (paper section 2.5): edge-frequency extraction (2.5.1) and the sorting of
// the unordered boundary segments into vertex sequences by head and tail
// insertion (2.5.2, Algorithm 1).
//
// Extraction: every triangle (a, b, c) contributes the directed edges a->b,
// b->c, c->a. An undirected edge used by exactly one triangle is a boundary
// edge, kept with that triangle's direction, so loops follow the triangles'
// orientation: for counter-clockwise triangles the outer loop is
// counter-clockwise and the holes are clockwise. The count is done without a
// hash table: half-edges are bucketed by their smaller vertex with a counting
// sort (O(m + n)), and each bucket (about six entries in a TIN) is matched
// with branch-free compares.
// Interior edges used twice in the same direction (inconsistent orientation)
// and edges used three or more times (non-manifold) are reported.
//
// Sorting (Algorithm 1): segments are read in the order above; each one is
// appended to the sequence whose tail it continues (tail insertion), put in
// front of the sequence whose head it precedes (head insertion), joins two
// sequences, closes one into a loop, or starts a new sequence. The paper
// scans all open sequences for a match; here the match is found in O(1)
// through per-vertex head/tail slots, so the whole sort is O(k).
// At a pinch vertex (a vertex on the boundary more than once: two holes
// touching at a vertex, a hole touching the outer boundary, ...) "the
// segment leaving v" is ambiguous; with triangles available the successor of
// an edge entering v is found by walking around v through the triangles
// (the boundary of each fan), which separates the loops exactly as the
// surface does. Where even that is not possible (inconsistent orientation or
// non-manifold edges at v, or a vertex whose in- and out-degree differ), the
// sequences are cut at that vertex and returned as open chains.
//
// Loops are returned without repeating the first vertex, each starting at
// its boundary edge with the lexicographically smallest (start, end) vertex
// pair, loops ordered by that start vertex: the output does not depend on
// the order of the triangles.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace faultmesh {

// Directed boundary edges (2 per edge: from, to), grouped by their smaller
// vertex in ascending order (the counting sort's order; within a group in
// triangle order, except around vertices with more than 32 incident
// half-edges, whose edges come by increasing other vertex).
// n_vertices == 0 means "max index + 1". Throws std::invalid_argument for a
// negative (or >= n_vertices) index, naming the row. Memory is O(triangles +
// vertices used), never O(largest index): when the index range (or
// n_vertices) is far beyond the 3 m corners, the used vertices are
// renumbered internally (monotonically, so the output is the same).
std::vector<std::int64_t> boundary_edges(const std::int64_t* triangles, std::size_t n_triangles,
                                         std::size_t n_vertices = 0);

struct BoundaryContours {
    std::vector<std::vector<std::int64_t>> loops;        // closed, first vertex not repeated
    std::vector<std::vector<std::int64_t>> open_chains;  // vertex sequences that do not close
    std::vector<std::int64_t> pinch_vertices;            // sorted: on the boundary more than once
    std::vector<std::int64_t> nonmanifold_edges;         // 2 per edge (min, max), used >= 3 times
    std::vector<std::int64_t> inconsistent_edges;        // 2 per edge (min, max), used twice, same direction
    // Vertices where a sequence had to be cut (in-degree != out-degree, or a
    // pinch that the triangles cannot resolve). Sorted.
    std::vector<std::int64_t> chain_break_vertices;
    bool clean() const {
        return open_chains.empty() && pinch_vertices.empty() && nonmanifold_edges.empty() &&
               inconsistent_edges.empty();
    }
};

// Full report: loops, open chains and everything irregular.
BoundaryContours boundary_contours(const std::int64_t* triangles, std::size_t n_triangles,
                                   std::size_t n_vertices = 0);

// Just the loops. strict = true: throws GeometryError naming a vertex if
// there is a pinch vertex, an open chain, a non-manifold or an
// inconsistently oriented edge. strict = false: the loops of the full report
// (open chains are dropped; use boundary_contours to see them).
std::vector<std::vector<std::int64_t>> boundary_loops(const std::int64_t* triangles,
                                                      std::size_t n_triangles,
                                                      std::size_t n_vertices = 0,
                                                      bool strict = true);

// Algorithm 1 alone, on arbitrary directed segments (2 vertex indices each):
// loops and open chains by head/tail insertion; a vertex with more than one
// segment leaving or entering it is a pinch, pairing there follows input
// order and the vertex is listed in pinch_vertices (there are no triangles
// to resolve it). Duplicate segments are kept as given.
BoundaryContours sort_segments(const std::int64_t* segments, std::size_t n_segments,
                               std::size_t n_vertices = 0);

}  // namespace faultmesh
