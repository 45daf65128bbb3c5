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
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

// Peak resident memory of this process image in KiB: VmHWM of
// /proc/self/status (Linux). getrusage's ru_maxrss is not used because Linux
// carries the parent's high-water mark over fork + exec, so a child of a big
// Python process would report the parent's size. -1 if unavailable.
static long peak_rss_kib() {
    std::FILE* f = std::fopen("/proc/self/status", "r");
    if (!f) return -1;
    char line[256];
    long kib = -1;
    while (std::fgets(line, sizeof line, f))
        if (std::strncmp(line, "VmHWM:", 6) == 0) kib = std::strtol(line + 6, nullptr, 10);
    std::fclose(f);
    return kib;
}

static void die(const std::string& msg) {
    std::fprintf(stderr, "delaunay_driver: %s\n", msg.c_str());
    std::exit(2);
}

int main(int argc, char** argv) {
    if (argc < 2) die("usage: delaunay_driver INPUT [OUTPUT|-] [--repeat K]");
    std::string in_path = argv[1], out_path = "-";
    int repeat = 1;
    for (int i = 2; i < argc; ++i) {
        if (std::strcmp(argv[i], "--repeat") == 0 && i + 1 < argc) {
            repeat = std::atoi(argv[++i]);
            if (repeat < 1) die("--repeat must be >= 1");
        } else {
            out_path = argv[i];
        }
    }
    std::FILE* f = std::fopen(in_path.c_str(), "rb");
    if (!f) die("cannot open " + in_path);
    std::int64_t n = 0;
    if (std::fread(&n, sizeof n, 1, f) != 1 || n < 0) die("bad header in " + in_path);
    std::vector<double> xy(static_cast<std::size_t>(2 * n));
    if (n > 0 && std::fread(xy.data(), sizeof(double), xy.size(), f) != xy.size())
        die("truncated point data in " + in_path);
    std::fclose(f);

    faultmesh::DelaunayResult r;
    std::vector<double> runs;
    for (int k = 0; k < repeat; ++k) {
        const auto t0 = std::chrono::steady_clock::now();
        r = faultmesh::delaunay(xy.data(), static_cast<std::size_t>(n));
        const auto t1 = std::chrono::steady_clock::now();
        runs.push_back(std::chrono::duration<double>(t1 - t0).count());
    }
    if (out_path != "-") {
        std::FILE* o = std::fopen(out_path.c_str(), "wb");
        if (!o) die("cannot open " + out_path);
        const std::int64_t m = static_cast<std::int64_t>(r.triangles.size() / 3);
        std::fwrite(&m, sizeof m, 1, o);
        std::fwrite(r.triangles.data(), sizeof(std::int64_t), r.triangles.size(), o);
        std::fwrite(&n, sizeof n, 1, o);
        std::fwrite(r.vertex_of_input.data(), sizeof(std::int64_t), r.vertex_of_input.size(), o);
        std::fclose(o);
    }
    double best = runs[0];
    std::string rs;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        if (runs[i] < best) best = runs[i];
        char buf[32];
        std::snprintf(buf, sizeof buf, "%s%.6f", i ? ", " : "", runs[i]);
        rs += buf;
    }
    std::printf("{\"program\": \"delaunay_driver\", \"n\": %lld, \"vertices\": %zu, \"triangles\": %zu, "
                "\"seconds\": %.6f, \"runs\": [%s], \"peak_rss_kib\": %ld}\n",
                static_cast<long long>(n), static_cast<std::size_t>(n) - r.n_duplicates,
                r.triangles.size() / 3, best, rs.c_str(), peak_rss_kib());
    return 0;
}
