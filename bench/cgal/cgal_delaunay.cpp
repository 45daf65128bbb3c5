// CGAL reference for faultmesh::delaunay.
//
//   cgal_delaunay INPUT [OUTPUT|-] [--repeat K]
//
// INPUT (binary, little-endian): int64 n, then n * 2 float64 (x0, y0, x1, y1, ...).
// OUTPUT (binary, little-endian): int64 m, then m * 3 int64 -- the finite faces
// as indices into the input points, counter-clockwise. "-" (or no OUTPUT)
// writes nothing. Of a group of duplicate input points CGAL keeps the first one
// it inserts (after its own spatial sort), so the index that represents a
// duplicate group is whichever CGAL kept; callers that compare must map
// duplicates to one representative themselves.
//
// Prints one JSON line on stdout:
//   {"program": "cgal_delaunay", "n": n, "vertices": v, "triangles": m,
//    "seconds": best, "runs": [...], "peak_rss_kib": VmHWM}
// where each run times, excluding file I/O, what a user of CGAL does to get an
// index array: building the (Point_2, index) pairs, range insertion into a
// Delaunay_triangulation_2<Epick> whose vertices carry the input index (the
// range insert spatially sorts), and extracting the faces into an int64 array.
#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "bench_io.hpp"

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<std::int64_t, K>;
using Fb = CGAL::Triangulation_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Delaunay = CGAL::Delaunay_triangulation_2<K, Tds>;

int main(int argc, char** argv) {
    bench::program_name = "cgal_delaunay";
    const bench::IoArgs args = bench::parse_io_args(argc, argv);
    const std::vector<double> xy = bench::read_array<double>(args.in_path, 2);
    const std::int64_t n = static_cast<std::int64_t>(xy.size() / 2);

    std::vector<std::int64_t> tri;
    std::size_t nv = 0;
    std::vector<double> runs;
    for (int r = 0; r < args.repeat; ++r) {
        tri.clear();
        const auto t0 = std::chrono::steady_clock::now();
        {
            std::vector<std::pair<K::Point_2, std::int64_t>> pts;
            pts.reserve(static_cast<std::size_t>(n));
            for (std::int64_t i = 0; i < n; ++i) pts.emplace_back(K::Point_2(xy[2 * i], xy[2 * i + 1]), i);
            Delaunay dt;
            dt.insert(pts.begin(), pts.end());
            tri.reserve(3 * dt.number_of_faces());
            for (auto fit = dt.finite_faces_begin(); fit != dt.finite_faces_end(); ++fit) {
                tri.push_back(fit->vertex(0)->info());
                tri.push_back(fit->vertex(1)->info());
                tri.push_back(fit->vertex(2)->info());
            }
            nv = dt.number_of_vertices();
        }
        const auto t1 = std::chrono::steady_clock::now();
        runs.push_back(std::chrono::duration<double>(t1 - t0).count());
    }

    if (args.out_path != "-") {
        std::FILE* o = bench::open_or_die(args.out_path, "wb");
        bench::write_rows(o, tri, 3);
        std::fclose(o);
    }
    std::string rs;
    const double best = bench::runs_json(runs, rs);
    std::printf("{\"program\": \"cgal_delaunay\", \"n\": %lld, \"vertices\": %zu, \"triangles\": %zu, "
                "\"seconds\": %.6f, \"runs\": [%s], \"peak_rss_kib\": %ld}\n",
                static_cast<long long>(n), nv, tri.size() / 3, best, rs.c_str(), bench::peak_rss_kib());
    return 0;
}
