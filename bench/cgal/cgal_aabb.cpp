// CGAL reference for faultmesh::AabbTree (bench/bench_aabb.py).
//
//   cgal_aabb MODE VERTICES TRIANGLES BOXES [HITS_OUT|-]
//
// Inputs (binary, little-endian):
//   VERTICES  int64 n, then n * 2 float64 (x0, y0, x1, y1, ...)
//   TRIANGLES int64 m, then m * 3 int64 vertex indices
//   BOXES     int64 q, then q * 4 float64 (xmin, ymin, xmax, ymax) per query
// MODE:
//   tree  CGAL::AABB_tree over the triangles (Epick, AABB_triangle_primitive
//         over Triangle_3 lifted to z = 0); each query box becomes a
//         Bbox_3(xmin, ymin, -1, xmax, ymax, 1) and is answered with
//         all_intersected_primitives: the triangles that really meet the
//         closed box (CGAL's exact Do_intersect_3(Bbox_3, Triangle_3)). This
//         is what faultmesh's AabbTree.query(boxes, exact=True) answers.
//   boxd  CGAL::box_intersection_d (CLOSED topology) between the triangles'
//         XY boxes and the query boxes: every (triangle box, query box) pair
//         that meets. This is what AabbTree.query(boxes) answers (candidate
//         stage, box against box).
// HITS_OUT (optional, binary): int64 total, then for the tree mode the CSR of
// the hits (q + 1 offsets, then indices, each query's indices sorted) so the
// caller can compare the answers one by one.
//
// Prints one JSON line on stdout:
//   {"program": "cgal_aabb", "mode": ..., "triangles": m, "queries": q,
//    "seconds_build": b, "seconds_query": s, "seconds": b + s,
//    "cpu_seconds_build": ..., "cpu_seconds_query": ..., "hits": H,
//    "peak_rss_kib": VmHWM}
// seconds: wall clock (steady_clock); cpu_seconds: this process's CPU time
// (CLOCK_PROCESS_CPUTIME_ID), which other load on a shared machine disturbs
// less. Times exclude file I/O. "build" is what a CGAL user does to get a tree from
// index arrays: constructing the Triangle_3 objects, inserting them and
// building the tree (for boxd: building the Box_d arrays); "query" is the
// query loop collecting triangle indices (for boxd: the batch intersection
// with a counting callback).
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_io.hpp"

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Triangle = K::Triangle_3;
using TriIt = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<K, TriIt>;
using Traits = CGAL::AABB_traits<K, Primitive>;
using Tree = CGAL::AABB_tree<Traits>;
using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 2, std::int64_t>;

int main(int argc, char** argv) {
    using bench::cpu_now;
    using bench::die;
    bench::program_name = "cgal_aabb";
    if (argc < 5) die("usage: cgal_aabb tree|boxd VERTICES TRIANGLES BOXES [HITS_OUT|-]");
    const std::string mode = argv[1];
    if (mode != "tree" && mode != "boxd") die("MODE must be tree or boxd");
    const std::string out_path = argc > 5 ? argv[5] : "-";
    const std::vector<double> xy = bench::read_array<double>(argv[2], 2);
    const std::vector<std::int64_t> tri = bench::read_array<std::int64_t>(argv[3], 3);
    const std::vector<double> qb = bench::read_array<double>(argv[4], 4);
    const std::size_t n = xy.size() / 2, m = tri.size() / 3, q = qb.size() / 4;
    for (std::int64_t v : tri)
        if (v < 0 || static_cast<std::size_t>(v) >= n) die("triangle index out of range");

    using clock = std::chrono::steady_clock;
    double t_build = 0, t_query = 0, c_build = 0, c_query = 0;
    std::int64_t hits = 0;
    std::vector<std::int64_t> offsets, indices;
    // Build = [t0, t1), query = [t1, t2), wall clock and CPU time alike.
    const auto record = [&](clock::time_point t0, clock::time_point t1, clock::time_point t2, double c0,
                            double c1, double c2) {
        c_build = c1 - c0;
        c_query = c2 - c1;
        t_build = std::chrono::duration<double>(t1 - t0).count();
        t_query = std::chrono::duration<double>(t2 - t1).count();
    };

    if (mode == "tree") {
        const double c0 = cpu_now();
        const auto t0 = clock::now();
        std::vector<Triangle> tris;
        tris.reserve(m);
        for (std::size_t t = 0; t < m; ++t) {
            const double* a = &xy[2 * static_cast<std::size_t>(tri[3 * t])];
            const double* b = &xy[2 * static_cast<std::size_t>(tri[3 * t + 1])];
            const double* c = &xy[2 * static_cast<std::size_t>(tri[3 * t + 2])];
            tris.emplace_back(Point(a[0], a[1], 0.0), Point(b[0], b[1], 0.0), Point(c[0], c[1], 0.0));
        }
        Tree tree(tris.cbegin(), tris.cend());
        tree.build();
        const auto t1 = clock::now();
        const double c1 = cpu_now();
        offsets.assign(1, 0);
        std::vector<Tree::Primitive_id> ids;
        for (std::size_t i = 0; i < q; ++i) {
            const double* b = &qb[4 * i];
            ids.clear();
            tree.all_intersected_primitives(CGAL::Bbox_3(b[0], b[1], -1.0, b[2], b[3], 1.0),
                                            std::back_inserter(ids));
            for (const auto& id : ids) indices.push_back(static_cast<std::int64_t>(id - tris.cbegin()));
            offsets.push_back(static_cast<std::int64_t>(indices.size()));
        }
        record(t0, t1, clock::now(), c0, c1, cpu_now());
        hits = static_cast<std::int64_t>(indices.size());
    } else {
        const double c0 = cpu_now();
        const auto t0 = clock::now();
        std::vector<Box> tb, qbox;
        tb.reserve(m);
        qbox.reserve(q);
        for (std::size_t t = 0; t < m; ++t) {
            double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
            for (int c = 0; c < 3; ++c) {
                const double* p = &xy[2 * static_cast<std::size_t>(tri[3 * t + static_cast<std::size_t>(c)])];
                lo[0] = std::min(lo[0], p[0]);
                lo[1] = std::min(lo[1], p[1]);
                hi[0] = std::max(hi[0], p[0]);
                hi[1] = std::max(hi[1], p[1]);
            }
            tb.emplace_back(lo, hi, static_cast<std::int64_t>(t));
        }
        for (std::size_t i = 0; i < q; ++i) {
            double lo[2] = {qb[4 * i], qb[4 * i + 1]}, hi[2] = {qb[4 * i + 2], qb[4 * i + 3]};
            qbox.emplace_back(lo, hi, static_cast<std::int64_t>(i));
        }
        const auto t1 = clock::now();
        const double c1 = cpu_now();
        CGAL::box_intersection_d(tb.begin(), tb.end(), qbox.begin(), qbox.end(),
                                 [&hits](const Box&, const Box&) { ++hits; });
        record(t0, t1, clock::now(), c0, c1, cpu_now());
    }

    if (out_path != "-") {
        std::FILE* f = bench::open_or_die(out_path, "wb");
        std::fwrite(&hits, sizeof hits, 1, f);
        if (mode == "tree") {
            for (std::size_t i = 0; i < q; ++i)
                std::sort(indices.begin() + offsets[i], indices.begin() + offsets[i + 1]);
            std::fwrite(offsets.data(), sizeof(std::int64_t), offsets.size(), f);
            std::fwrite(indices.data(), sizeof(std::int64_t), indices.size(), f);
        }
        std::fclose(f);
    }
    std::printf("{\"program\": \"cgal_aabb\", \"mode\": \"%s\", \"triangles\": %zu, \"queries\": %zu, "
                "\"seconds_build\": %.6f, \"seconds_query\": %.6f, \"seconds\": %.6f, "
                "\"cpu_seconds_build\": %.6f, \"cpu_seconds_query\": %.6f, \"hits\": %lld, "
                "\"peak_rss_kib\": %ld}\n",
                mode.c_str(), m, q, t_build, t_query, t_build + t_query, c_build, c_query,
                static_cast<long long>(hits), bench::peak_rss_kib());
    return 0;
}
