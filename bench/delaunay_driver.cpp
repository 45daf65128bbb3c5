// faultmesh side of bench/bench_delaunay.py: the C++ library called from C++,
// so that the timing compares the two C++ implementations (no Python, no
// numpy conversion).
//
//   delaunay_driver INPUT [OUTPUT|-] [--repeat K]
//
// INPUT: the format of bench/cgal/cgal_delaunay.cpp (little-endian int64 n,
// then n * 2 float64). OUTPUT (optional): int64 m, m * 3 int64 triangles
// (indices into the input, counter-clockwise), then int64 n and n int64
// vertex_of_input. Prints one JSON line like cgal_delaunay: the time of the
// faultmesh::delaunay call (validation, spatial sort, triangulation and the
// int64 triangle/half-edge/duplicate arrays), excluding file I/O.
#include <faultmesh/delaunay.hpp>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_io.hpp"  // bench/cgal: shared with the CGAL programs

int main(int argc, char** argv) {
    bench::program_name = "delaunay_driver";
    const bench::IoArgs args = bench::parse_io_args(argc, argv);
    const std::vector<double> xy = bench::read_array<double>(args.in_path, 2);
    const std::int64_t n = static_cast<std::int64_t>(xy.size() / 2);

    faultmesh::DelaunayResult r;
    std::vector<double> runs;
    for (int k = 0; k < args.repeat; ++k) {
        const auto t0 = std::chrono::steady_clock::now();
        r = faultmesh::delaunay(xy.data(), static_cast<std::size_t>(n));
        const auto t1 = std::chrono::steady_clock::now();
        runs.push_back(std::chrono::duration<double>(t1 - t0).count());
    }
    if (args.out_path != "-") {
        std::FILE* o = bench::open_or_die(args.out_path, "wb");
        bench::write_rows(o, r.triangles, 3);
        bench::write_rows(o, r.vertex_of_input, 1);
        std::fclose(o);
    }
    std::string rs;
    const double best = bench::runs_json(runs, rs);
    std::printf("{\"program\": \"delaunay_driver\", \"n\": %lld, \"vertices\": %zu, \"triangles\": %zu, "
                "\"seconds\": %.6f, \"runs\": [%s], \"peak_rss_kib\": %ld}\n",
                static_cast<long long>(n), static_cast<std::size_t>(n) - r.n_duplicates,
                r.triangles.size() / 3, best, rs.c_str(), bench::peak_rss_kib());
    return 0;
}
