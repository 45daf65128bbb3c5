// CGAL reference for faultmesh.triangulate_polygon(refine=True): the
// constrained Delaunay triangulation of a polygon with holes.
//
// Usage: cgal_polygon_cdt INPUT OUTPUT
//
// INPUT (text, whitespace separated):
//   n_rings
//   k_0            then k_0 lines "x y"  (outer ring)
//   k_1            then k_1 lines "x y"  (first hole)
//   ...
// Points are numbered 0.. in file order over all rings (the same indices as
// faultmesh's concatenated rings). A ring is closed implicitly.
//
// OUTPUT (text): one triangle per line, "i j k", counter-clockwise, indices
// of input points (for points given more than once with equal coordinates,
// the first index; Steiner vertices at crossing constraints: n, n+1, ...).
//
// stdout: one JSON line {"program": ..., "triangles": m, "seconds": t} where t
// is the wall time of building the CDT (Epick kernel, points inserted with
// their index as vertex info, ring edges as constraints) and marking the
// faces inside the polygon; reading and writing files is not timed.
//
// Inside faces: nesting levels by flood fill. The faces reachable from the
// infinite face without crossing a constrained edge have level 0; crossing a
// constrained edge adds one level. Faces of odd level are inside (outer ring
// = level 1, a hole = level 2, ...).
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <fstream>
#include <iostream>
#include <utility>
#include <vector>

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
// Vertex info: input index; -1 for a Steiner vertex CGAL adds where two
// constraints cross (invalid polygons only). Those are numbered n, n+1, ...
// in the output (and counted as "steiner" in the JSON line).
struct Index {
    std::int64_t v = -1;
};
using Vb = CGAL::Triangulation_vertex_base_with_info_2<Index, K>;
using Fbi = CGAL::Triangulation_face_base_with_info_2<int, K>;  // nesting level, -1 = unset
using Fb = CGAL::Constrained_triangulation_face_base_2<K, Fbi>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;
using Point = K::Point_2;

int main(int argc, char** argv) {
    if (argc != 3) {
        std::cerr << "usage: cgal_polygon_cdt INPUT OUTPUT\n";
        return 2;
    }
    std::ifstream in(argv[1]);
    if (!in) {
        std::cerr << "cgal_polygon_cdt: cannot read " << argv[1] << "\n";
        return 2;
    }
    std::size_t n_rings = 0;
    in >> n_rings;
    std::vector<Point> pts;
    std::vector<std::pair<std::size_t, std::size_t>> rings;  // [begin, end)
    for (std::size_t r = 0; r < n_rings; ++r) {
        std::size_t k = 0;
        if (!(in >> k)) {
            std::cerr << "cgal_polygon_cdt: ring " << r << ": missing vertex count\n";
            return 2;
        }
        const std::size_t b = pts.size();
        for (std::size_t i = 0; i < k; ++i) {
            double x, y;
            if (!(in >> x >> y)) {
                std::cerr << "cgal_polygon_cdt: ring " << r << ": missing point " << i << "\n";
                return 2;
            }
            pts.emplace_back(x, y);
        }
        rings.emplace_back(b, pts.size());
    }

    const auto t0 = std::chrono::steady_clock::now();
    // Equal points are inserted once; canon[i] = first index with i's coordinates.
    std::vector<std::int64_t> order(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) order[i] = static_cast<std::int64_t>(i);
    std::sort(order.begin(), order.end(), [&](std::int64_t a, std::int64_t b) {
        return pts[a] < pts[b] || (pts[a] == pts[b] && a < b);
    });
    std::vector<std::int64_t> canon(pts.size());
    std::vector<std::pair<Point, Index>> unique;
    for (std::size_t k = 0; k < order.size(); ++k) {
        if (k > 0 && pts[order[k]] == pts[order[k - 1]]) {
            canon[order[k]] = canon[order[k - 1]];
        } else {
            canon[order[k]] = order[k];
            unique.emplace_back(pts[order[k]], Index{order[k]});
        }
    }
    CDT cdt;
    cdt.insert(unique.begin(), unique.end());  // spatially sorted bulk insertion
    std::vector<CDT::Vertex_handle> vh(pts.size());
    for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) vh[v->info().v] = v;
    for (const auto& [b, e] : rings) {
        for (std::size_t i = b; i < e; ++i) {
            const std::size_t j = (i + 1 == e) ? b : i + 1;
            const auto va = vh[canon[i]], vb = vh[canon[j]];
            if (va != vb) cdt.insert_constraint(va, vb);
        }
    }
    std::int64_t steiner = 0;
    for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v)
        if (v->info().v < 0) v->info().v = static_cast<std::int64_t>(pts.size()) + steiner++;
    // Nesting levels by flood fill across edges; a constrained edge raises the level.
    for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f) f->info() = -1;
    std::deque<CDT::Face_handle> border{cdt.infinite_face()};
    int level = 0;
    while (!border.empty()) {
        std::deque<CDT::Face_handle> next_border;
        while (!border.empty()) {
            CDT::Face_handle start = border.front();
            border.pop_front();
            if (start->info() != -1) continue;
            std::deque<CDT::Face_handle> queue{start};
            start->info() = level;
            while (!queue.empty()) {
                CDT::Face_handle f = queue.front();
                queue.pop_front();
                for (int i = 0; i < 3; ++i) {
                    CDT::Face_handle n = f->neighbor(i);
                    if (n->info() != -1) continue;
                    if (cdt.is_constrained(CDT::Edge(f, i))) {
                        next_border.push_back(n);
                    } else {
                        n->info() = level;
                        queue.push_back(n);
                    }
                }
            }
        }
        border.swap(next_border);
        ++level;
    }
    std::vector<std::int64_t> tris;
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f)
        if (f->info() % 2 == 1)
            for (int i = 0; i < 3; ++i) tris.push_back(f->vertex(i)->info().v);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    std::FILE* out = std::fopen(argv[2], "w");
    if (!out) {
        std::cerr << "cgal_polygon_cdt: cannot write " << argv[2] << "\n";
        return 2;
    }
    for (std::size_t t = 0; t < tris.size(); t += 3)
        std::fprintf(out, "%lld %lld %lld\n", static_cast<long long>(tris[t]),
                     static_cast<long long>(tris[t + 1]), static_cast<long long>(tris[t + 2]));
    std::fclose(out);
    std::printf("{\"program\": \"cgal_polygon_cdt\", \"triangles\": %zu, \"steiner\": %lld, \"seconds\": %.9f}\n",
                tris.size() / 3, static_cast<long long>(steiner), seconds);
    return 0;
}
