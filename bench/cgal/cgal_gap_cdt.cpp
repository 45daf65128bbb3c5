// CGAL reference for the stitched gaps: the constrained Delaunay triangulation
// of each gap polygon (outer ring plus holes), restricted to the polygon.
//
//   cgal_gap_cdt INPUT [OUTPUT|-] [--repeat K]
//
// INPUT (binary, little-endian):
//   int64 n_polygons, then per polygon:
//     int64 n_rings, int64 size[n_rings], then sum(size) * 2 float64
//     (x, y of ring 0 -- the outer ring -- then of each hole, concatenated).
// OUTPUT (binary, little-endian), per polygon: int64 m, then m * 3 int64 --
// the triangles inside the polygon as indices into that polygon's
// concatenated ring points, counter-clockwise. Points with equal coordinates
// (touching rings, a vertex repeated in a weakly simple ring) are one CGAL
// vertex; it is reported with the index of its first occurrence.
//
// Prints one JSON line on stdout:
//   {"program": "cgal_gap_cdt", "polygons": [{"points": p, "vertices": v,
//     "triangles": m, "seconds": best}, ...], "seconds": total_best}
// "vertices" counts the CGAL vertices (fewer than "points" when points
// coincide, more when constraints crossed and CGAL added intersection points).
// Each polygon is timed on its own, excluding file I/O: inserting the points
// and the ring edges as constraints into a Constrained_Delaunay_triangulation_2
// (exact predicates), marking the faces inside the polygon by nesting depth
// and collecting them into an int64 array; the best of K runs is reported.
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <string>
#include <vector>

#include "bench_io.hpp"

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

// Vertex info: index of the first input point at this position (-1 until set,
// so a duplicate insert does not overwrite it).
struct VInfo {
    std::int64_t index = -1;
};
// Face info: nesting depth of the face (-1 = not yet reached), the number of
// constrained edges crossed from the infinite face. Odd depth = inside.
struct FInfo {
    int depth = -1;
};
using Vb = CGAL::Triangulation_vertex_base_with_info_2<VInfo, K>;
using Fbi = CGAL::Triangulation_face_base_with_info_2<FInfo, K>;
using Fb = CGAL::Constrained_triangulation_face_base_2<K, Fbi>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
// Exact_predicates_tag: crossing constraints are allowed (CGAL then adds the
// crossing points, which shows up as vertices > distinct points).
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;

struct Polygon {
    std::vector<std::int64_t> sizes;
    std::vector<double> xy;
};

// Nesting depth by breadth-first flooding: faces reachable from the infinite
// face without crossing a constraint get depth 0, across one constraint 1, ...
// (the domain-marking of CGAL's polygon triangulation example, written out).
void mark_domains(Cdt& cdt) {
    for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f) f->info().depth = -1;
    std::deque<Cdt::Face_handle> border;
    border.push_back(cdt.infinite_face());
    int depth = 0;
    while (!border.empty()) {
        std::deque<Cdt::Face_handle> next_border;
        while (!border.empty()) {
            Cdt::Face_handle start = border.front();
            border.pop_front();
            if (start->info().depth != -1) continue;
            std::deque<Cdt::Face_handle> queue{start};
            start->info().depth = depth;
            while (!queue.empty()) {
                Cdt::Face_handle f = queue.front();
                queue.pop_front();
                for (int i = 0; i < 3; ++i) {
                    Cdt::Face_handle n = f->neighbor(i);
                    if (n->info().depth != -1) continue;
                    if (cdt.is_constrained(Cdt::Edge(f, i))) {
                        next_border.push_back(n);
                    } else {
                        n->info().depth = depth;
                        queue.push_back(n);
                    }
                }
            }
        }
        border.swap(next_border);
        ++depth;
    }
}

// One CDT of one polygon; returns the inside triangles (indices), sets n_vertices.
std::vector<std::int64_t> triangulate(const Polygon& poly, std::size_t& n_vertices) {
    Cdt cdt;
    std::vector<Cdt::Vertex_handle> handle(poly.xy.size() / 2);
    for (std::size_t i = 0; i < handle.size(); ++i) {
        Cdt::Vertex_handle v = cdt.insert(K::Point_2(poly.xy[2 * i], poly.xy[2 * i + 1]));
        if (v->info().index < 0) v->info().index = static_cast<std::int64_t>(i);
        handle[i] = v;
    }
    std::size_t start = 0;
    for (std::int64_t size : poly.sizes) {
        const std::size_t k = static_cast<std::size_t>(size);
        for (std::size_t j = 0; j < k; ++j) {
            Cdt::Vertex_handle a = handle[start + j], b = handle[start + (j + 1) % k];
            if (a != b) cdt.insert_constraint(a, b);
        }
        start += k;
    }
    mark_domains(cdt);
    std::vector<std::int64_t> tri;
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
        if (f->info().depth % 2 != 1) continue;
        for (int i = 0; i < 3; ++i) tri.push_back(f->vertex(i)->info().index);
    }
    n_vertices = cdt.number_of_vertices();
    return tri;
}

}  // namespace

int main(int argc, char** argv) {
    using bench::die;
    using bench::read_i64;
    bench::program_name = "cgal_gap_cdt";
    const bench::IoArgs args = bench::parse_io_args(argc, argv);
    const std::string& in_path = args.in_path;
    std::FILE* f = bench::open_or_die(in_path, "rb");
    const std::int64_t n_poly = read_i64(f, "the polygon count");
    if (n_poly < 0 || n_poly > (std::int64_t{1} << 32)) die("bad polygon count in " + in_path);
    std::vector<Polygon> polys(static_cast<std::size_t>(n_poly));
    for (std::int64_t p = 0; p < n_poly; ++p) {
        const std::string where = "polygon " + std::to_string(p);
        const std::int64_t n_rings = read_i64(f, where + " ring count");
        if (n_rings < 1 || n_rings > (std::int64_t{1} << 24)) die(where + ": bad ring count");
        std::int64_t total = 0;
        for (std::int64_t r = 0; r < n_rings; ++r) {
            const std::int64_t s = read_i64(f, where + " ring size");
            if (s < 0 || s > (std::int64_t{1} << 32)) die(where + ": bad ring size");
            polys[p].sizes.push_back(s);
            total += s;
        }
        polys[p].xy.resize(static_cast<std::size_t>(2 * total));
        if (total > 0 &&
            std::fread(polys[p].xy.data(), sizeof(double), polys[p].xy.size(), f) != polys[p].xy.size())
            die(where + ": truncated point data");
    }
    std::fclose(f);

    std::vector<std::vector<std::int64_t>> results(polys.size());
    std::vector<std::size_t> n_vertices(polys.size(), 0);
    std::vector<double> best(polys.size(), 0.0);
    for (std::size_t p = 0; p < polys.size(); ++p) {
        for (int r = 0; r < args.repeat; ++r) {
            const auto t0 = std::chrono::steady_clock::now();
            results[p] = triangulate(polys[p], n_vertices[p]);
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            if (r == 0 || s < best[p]) best[p] = s;
        }
    }

    if (args.out_path != "-") {
        std::FILE* o = bench::open_or_die(args.out_path, "wb");
        for (const auto& tri : results) bench::write_rows(o, tri, 3);
        std::fclose(o);
    }
    double total = 0.0;
    std::string items;
    for (std::size_t p = 0; p < polys.size(); ++p) {
        total += best[p];
        char buf[160];
        std::snprintf(buf, sizeof buf,
                      "%s{\"points\": %zu, \"vertices\": %zu, \"triangles\": %zu, \"seconds\": %.9f}",
                      p ? ", " : "", polys[p].xy.size() / 2, n_vertices[p], results[p].size() / 3, best[p]);
        items += buf;
    }
    std::printf("{\"program\": \"cgal_gap_cdt\", \"polygons\": [%s], \"seconds\": %.9f}\n", items.c_str(),
                total);
    return 0;
}
