// Shared plumbing of the benchmark programs (bench/cgal/*.cpp and
// bench/delaunay_driver.cpp): argument parsing, the binary array files of
// bench/README.md, peak memory and the timing fields of the JSON line each
// program prints. Header-only so that bench/cgal/CMakeLists.txt (one
// executable per .cpp) and the driver's direct compiler call in
// bench/bench_delaunay.py (-I bench/cgal) need nothing else.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

namespace bench {

// Name that prefixes error messages; each program sets it first thing in main.
inline std::string program_name = "bench";

[[noreturn]] inline void die(const std::string& msg) {
    std::fprintf(stderr, "%s: %s\n", program_name.c_str(), msg.c_str());
    std::exit(2);
}

// Peak resident memory of this process image in KiB: VmHWM of
// /proc/self/status (Linux). getrusage's ru_maxrss is not used because Linux
// carries the parent's high-water mark over fork + exec, so a child of a big
// Python process would report the parent's size. -1 if unavailable.
inline long peak_rss_kib() {
    std::FILE* f = std::fopen("/proc/self/status", "r");
    if (!f) return -1;
    char line[256];
    long kib = -1;
    while (std::fgets(line, sizeof line, f))
        if (std::strncmp(line, "VmHWM:", 6) == 0) kib = std::strtol(line + 6, nullptr, 10);
    std::fclose(f);
    return kib;
}

// This process's CPU time in seconds: less disturbed than the wall clock by
// other load on a shared machine.
inline double cpu_now() {
    timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// The command line "PROGRAM INPUT [OUTPUT|-] [--repeat K]".
struct IoArgs {
    std::string in_path;
    std::string out_path = "-";
    int repeat = 1;
};

inline IoArgs parse_io_args(int argc, char** argv) {
    if (argc < 2) die("usage: " + program_name + " INPUT [OUTPUT|-] [--repeat K]");
    IoArgs a;
    a.in_path = argv[1];
    for (int i = 2; i < argc; ++i) {
        if (std::strcmp(argv[i], "--repeat") == 0 && i + 1 < argc) {
            a.repeat = std::atoi(argv[++i]);
            if (a.repeat < 1) die("--repeat must be >= 1");
        } else {
            a.out_path = argv[i];
        }
    }
    return a;
}

inline std::FILE* open_or_die(const std::string& path, const char* mode) {
    std::FILE* f = std::fopen(path.c_str(), mode);
    if (!f) die("cannot open " + path);
    return f;
}

// One little-endian int64 from f (the counts of the input formats).
inline std::int64_t read_i64(std::FILE* f, const std::string& what) {
    std::int64_t v = 0;
    if (std::fread(&v, sizeof v, 1, f) != 1) die("truncated input reading " + what);
    return v;
}

// An array file: int64 n, then n * cols values of T (float64 or int64).
template <class T>
std::vector<T> read_array(const std::string& path, std::size_t cols) {
    std::FILE* f = open_or_die(path, "rb");
    std::int64_t n = 0;
    if (std::fread(&n, sizeof n, 1, f) != 1 || n < 0) die("bad header in " + path);
    std::vector<T> a(static_cast<std::size_t>(n) * cols);
    if (!a.empty() && std::fread(a.data(), sizeof(T), a.size(), f) != a.size()) die("truncated " + path);
    std::fclose(f);
    return a;
}

// Writes int64 m = values.size() / cols, then the values (the triangle files).
inline void write_rows(std::FILE* f, const std::vector<std::int64_t>& values, std::size_t cols) {
    const std::int64_t m = static_cast<std::int64_t>(values.size() / cols);
    std::fwrite(&m, sizeof m, 1, f);
    if (!values.empty()) std::fwrite(values.data(), sizeof(std::int64_t), values.size(), f);
}

// "seconds" (the best run) and "runs" (all of them) of the JSON line:
// returns the best and sets `list` to "t0, t1, ...".
inline double runs_json(const std::vector<double>& runs, std::string& list) {
    double best = runs.empty() ? 0.0 : runs[0];
    list.clear();
    for (std::size_t i = 0; i < runs.size(); ++i) {
        if (runs[i] < best) best = runs[i];
        char buf[32];
        std::snprintf(buf, sizeof buf, "%s%.6f", i ? ", " : "", runs[i]);
        list += buf;
    }
    return best;
}

}  // namespace bench
