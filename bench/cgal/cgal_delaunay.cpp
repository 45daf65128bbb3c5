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
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<std::int64_t, K>;
using Fb = CGAL::Triangulation_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Delaunay = CGAL::Delaunay_triangulation_2<K, Tds>;

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
    std::fprintf(stderr, "cgal_delaunay: %s\n", msg.c_str());
    std::exit(2);
}

int main(int argc, char** argv) {
    if (argc < 2) die("usage: cgal_delaunay INPUT [OUTPUT|-] [--repeat K]");
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

    std::vector<std::int64_t> tri;
    std::size_t nv = 0;
    std::vector<double> runs;
    for (int r = 0; r < repeat; ++r) {
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

    if (out_path != "-") {
        std::FILE* o = std::fopen(out_path.c_str(), "wb");
        if (!o) die("cannot open " + out_path);
        const std::int64_t m = static_cast<std::int64_t>(tri.size() / 3);
        std::fwrite(&m, sizeof m, 1, o);
        std::fwrite(tri.data(), sizeof(std::int64_t), tri.size(), o);
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
    std::printf("{\"program\": \"cgal_delaunay\", \"n\": %lld, \"vertices\": %zu, \"triangles\": %zu, "
                "\"seconds\": %.6f, \"runs\": [%s], \"peak_rss_kib\": %ld}\n",
                static_cast<long long>(n), nv, tri.size() / 3, best, rs.c_str(), peak_rss_kib());
    return 0;
}
