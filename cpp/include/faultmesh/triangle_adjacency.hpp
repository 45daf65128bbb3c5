// faultmesh/triangle_adjacency.hpp -- opposite half-edges ("twins") of a
// triangle list: the one adjacency structure of the library. The stitcher
// (stitch.hpp), the growth of a removed set (overlap.hpp) and the cutting
// baseline (cutting.hpp) all build it here.
//
// Half-edge e = 3 t + k of triangle t runs from triangles[e] to
// triangles[next_halfedge(e)] -- the layout of DelaunayResult::halfedges and
// Tin::halfedges. twins[e] is the half-edge of the other triangle on the same
// edge, or -1 if the edge has one triangle (the mesh boundary).
//
// Built in O(m + n) by a counting sort of the half-edges by their smaller
// vertex: each bucket holds the edges of one vertex (about six in a TIN) and
// is matched by a scan (buckets of more than 32 half-edges -- fan centres --
// are sorted first).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace faultmesh {

inline std::int64_t next_halfedge(std::int64_t e) { return e % 3 == 2 ? e - 2 : e + 1; }
inline std::int64_t prev_halfedge(std::int64_t e) { return e % 3 == 0 ? e + 2 : e - 1; }

enum class EdgeOrientation {
    // Consistently oriented triangles: the two half-edges of an interior edge
    // run in opposite directions. Two in the same direction is an error
    // (a flipped triangle, or two triangles on the same side of the edge).
    consistent,
    // Triangles of any orientation: the two uses of an edge are paired
    // whatever their directions.
    any,
};

// How the error messages name things: vertex i is called vertex_ids[i] and
// triangle t row_ids[t] (for an adjacency of a subset of a larger mesh);
// null: by their own index. `edge_word` names an edge ("edge", "layer edge").
struct AdjacencyLabels {
    const std::int64_t* vertex_ids = nullptr;
    const std::int64_t* row_ids = nullptr;
    const char* edge_word = "edge";
};

// Twins (3 m entries) of m triangles (3 vertex indices each, all in
// [0, n_vertices): the caller checks the indices). Throws GeometryError
// starting with `fn` and naming the edge's two vertices and the triangle rows
// for an edge used by more than two triangles ("... is used by 3 triangles
// (rows 4, 9, 17): the mesh is not a manifold") and, with
// EdgeOrientation::consistent, for an edge used twice in the same direction
// ("... is used twice in the same direction (triangles 4 and 9): inconsistent
// orientation"). std::invalid_argument if 3 m or n_vertices reaches 2^32.
std::vector<std::int64_t> halfedge_twins(const std::int64_t* triangles, std::size_t n_triangles,
                                         std::size_t n_vertices, EdgeOrientation orientation,
                                         const std::string& fn, const AdjacencyLabels& labels = {});

}  // namespace faultmesh
