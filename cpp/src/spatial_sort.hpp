// Private helper of delaunay.cpp and tin.cpp: spatial orders for incremental
// insertion and batched point location.
//
// hilbert_order    -- points sorted along a Hilbert curve over their bounding
//                     square, so that consecutive points are close and a walk
//                     from the previous point is short.
// brio_order       -- Amenta, Choi and Rote's biased randomized insertion order
//                     (BRIO): points are split into rounds of geometrically
//                     growing size at random (each point belongs to the last
//                     round with probability 1/2, to the one before with 1/4,
//                     ...), rounds are inserted coarse to fine, and each round
//                     is sorted along the Hilbert curve. Randomness keeps the
//                     expected cavity sizes small even for adversarial input
//                     orders; the Hilbert order keeps the walks short.
//
// Keys are computed by quantising each coordinate to kHilbertLevels bits and
// mapping the cell to its Hilbert index with a 4-state automaton (the state is
// the accumulated swap/complement of the sub-square); the 32-bit keys are then
// sorted with an LSD radix sort, and runs of points sharing a cell are
// re-sorted on a grid over their own extent (clustered data).
// Everything is deterministic: the random rounds come from a fixed-seed hash
// of the point's index.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace faultmesh::detail {

// One Hilbert level: (x bit, y bit) of the original cell and the state
// (bit 0: swap x/y, bit 1: complement both) give the quadrant digit 0..3 along
// the curve and the next state. This is the textbook iterative xy -> d mapping
// with its coordinate rotation expressed as a state instead of being applied
// to the remaining bits.
constexpr unsigned hilbert_step(unsigned state, unsigned bx, unsigned by, unsigned& digit) {
    const unsigned swap = state & 1u, comp = (state >> 1) & 1u;
    const unsigned tx = swap ? by : bx, ty = swap ? bx : by;
    const unsigned rx = tx ^ comp, ry = ty ^ comp;
    digit = (3u * rx) ^ ry;
    unsigned s = swap, c = comp;
    if (ry == 0) {
        s ^= 1u;
        c ^= rx;
    }
    return s | (c << 1);
}

// Table for 4 levels at once: index = state << 8 | x nibble << 4 | y nibble;
// entry = 8 digit bits | next state << 8.
struct HilbertTable {
    std::uint16_t entry[4 * 256];
};

constexpr HilbertTable make_hilbert_table() {
    HilbertTable t{};
    for (unsigned state = 0; state < 4; ++state)
        for (unsigned xn = 0; xn < 16; ++xn)
            for (unsigned yn = 0; yn < 16; ++yn) {
                unsigned s = state, digits = 0;
                for (int bit = 3; bit >= 0; --bit) {
                    unsigned d = 0;
                    s = hilbert_step(s, (xn >> bit) & 1u, (yn >> bit) & 1u, d);
                    digits = (digits << 2) | d;
                }
                t.entry[(state << 8) | (xn << 4) | yn] = static_cast<std::uint16_t>(digits | (s << 8));
            }
    return t;
}

inline constexpr HilbertTable kHilbertTable = make_hilbert_table();

// Hilbert index of cell (x, y) of a 2^levels x 2^levels grid, levels a
// multiple of 4 and at most 32.
inline std::uint64_t hilbert_index(std::uint32_t x, std::uint32_t y, int levels) {
    unsigned state = 0;
    std::uint64_t d = 0;
    for (int shift = levels - 4; shift >= 0; shift -= 4) {
        const unsigned xn = (x >> shift) & 15u, yn = (y >> shift) & 15u;
        const unsigned e = kHilbertTable.entry[(state << 8) | (xn << 4) | yn];
        d = (d << 8) | (e & 0xffu);
        state = e >> 8;
    }
    return d;
}

// Sorts vals by keys (both permuted), stable, LSD radix on bytes; byte
// positions where all keys agree are skipped.
template <class Key>
void radix_sort_by_key(std::vector<Key>& keys, std::vector<std::uint32_t>& vals) {
    constexpr int kBytes = static_cast<int>(sizeof(Key));
    const std::size_t n = keys.size();
    if (n < 2) return;
    std::vector<std::size_t> hist(kBytes * 256, 0);
    for (std::size_t i = 0; i < n; ++i) {
        const Key k = keys[i];
        for (int b = 0; b < kBytes; ++b) ++hist[b * 256 + ((k >> (8 * b)) & 0xffu)];
    }
    std::vector<Key> k2(n);
    std::vector<std::uint32_t> v2(n);
    for (int b = 0; b < kBytes; ++b) {
        std::size_t* h = &hist[b * 256];
        bool trivial = false;
        for (int j = 0; j < 256; ++j)
            if (h[j] == n) trivial = true;
        if (trivial) continue;
        std::size_t sum = 0;
        for (int j = 0; j < 256; ++j) {
            const std::size_t c = h[j];
            h[j] = sum;
            sum += c;
        }
        const int shift = 8 * b;
        for (std::size_t i = 0; i < n; ++i) {
            const std::size_t dst = h[(keys[i] >> shift) & 0xffu]++;
            k2[dst] = keys[i];
            v2[dst] = vals[i];
        }
        keys.swap(k2);
        vals.swap(v2);
    }
}

// Levels of the Hilbert keys: 2^28 cells leave 4 bits of a 32-bit key for
// the BRIO round and give a uniform set of a few million points tens of cells
// per point; cells that still hold many points (clusters) are refined by
// refine_ties.
constexpr int kHilbertLevels = 14;

// Quantisation of the bounding square of a point set (or of a subset given by
// indices) onto a 2^kHilbertLevels grid.
struct HilbertFrame {
    double x0 = 0, y0 = 0, scale = 0;
    static constexpr double kCells = double((1u << kHilbertLevels) - 1);

    // Points i (or idx[i] when idx is given) for i < n, `stride` doubles each
    // (x, y first); non-finite coordinates are ignored.
    HilbertFrame(const double* pts, std::size_t stride, std::size_t n, const std::uint32_t* idx = nullptr) {
        double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY;
        for (std::size_t i = 0; i < n; ++i) {
            const double* p = pts + stride * (idx ? idx[i] : i);
            const double x = p[0], y = p[1];
            if (!(std::isfinite(x) && std::isfinite(y))) continue;
            xmin = std::min(xmin, x);
            xmax = std::max(xmax, x);
            ymin = std::min(ymin, y);
            ymax = std::max(ymax, y);
        }
        const double ext = std::max(xmax - xmin, ymax - ymin);
        x0 = xmin;
        y0 = ymin;
        // A zero extent (one point, or all equal) maps everything to cell 0.
        scale = (ext > 0 && std::isfinite(ext)) ? kCells / ext : 0.0;
    }

    // 28-bit Hilbert key of (x, y); points outside the frame are clamped and
    // NaN goes to cell 0.
    std::uint32_t key(double x, double y) const {
        double fx = (x - x0) * scale, fy = (y - y0) * scale;
        fx = fx > 0 ? (fx < kCells ? fx : kCells) : 0.0;
        fy = fy > 0 ? (fy < kCells ? fy : kCells) : 0.0;
        // 16 table levels on coordinates shifted up by 2: the key of the
        // 2^14 grid is the 2^16 key of its cell's corner, shifted down by 4
        // (the Hilbert curve of a coarser grid is the finer one's prefix).
        const std::uint32_t ix = static_cast<std::uint32_t>(fx) << 2, iy = static_cast<std::uint32_t>(fy) << 2;
        return static_cast<std::uint32_t>(hilbert_index(ix, iy, 16) >> 4);
    }
};

// Within idx[lo, hi) (sorted by keys), re-sorts every run of equal keys
// longer than a few points along a Hilbert curve over the run's own
// bounding square, recursively: clustered inputs (many points per cell of the
// global grid) keep a spatially coherent order.
inline void refine_ties(const double* pts, std::size_t stride, std::vector<std::uint32_t>& keys,
                        std::vector<std::uint32_t>& idx, std::size_t lo, std::size_t hi, int depth) {
    constexpr std::size_t kRun = 16;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> buf;
    std::size_t i = lo;
    while (i < hi) {
        std::size_t j = i + 1;
        while (j < hi && keys[j] == keys[i]) ++j;
        if (j - i > kRun && depth < 4) {
            const HilbertFrame f(pts, stride, j - i, &idx[i]);
            if (f.scale > 0) {
                buf.resize(j - i);
                for (std::size_t k = i; k < j; ++k) {
                    const double* p = pts + stride * idx[k];
                    buf[k - i] = {f.key(p[0], p[1]), idx[k]};
                }
                std::stable_sort(buf.begin(), buf.end(),
                                 [](const auto& a, const auto& b) { return a.first < b.first; });
                for (std::size_t k = i; k < j; ++k) {
                    keys[k] = buf[k - i].first;
                    idx[k] = buf[k - i].second;
                }
                refine_ties(pts, stride, keys, idx, i, j, depth + 1);
            }
        }
        i = j;
    }
}

inline std::uint64_t splitmix64(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

// Indices 0..n-1 in Hilbert order of the points (stride doubles per point).
inline std::vector<std::uint32_t> hilbert_order(const double* pts, std::size_t stride, std::size_t n) {
    const HilbertFrame frame(pts, stride, n);
    std::vector<std::uint32_t> keys(n), idx(n);
    for (std::size_t i = 0; i < n; ++i) {
        keys[i] = frame.key(pts[i * stride], pts[i * stride + 1]);
        idx[i] = static_cast<std::uint32_t>(i);
    }
    radix_sort_by_key(keys, idx);
    refine_ties(pts, stride, keys, idx, 0, n, 0);
    return idx;
}

// Indices 0..n-1 in BRIO order: rounds coarse to fine, each along the Hilbert
// curve. The first round holds about 64 points or more.
inline std::vector<std::uint32_t> brio_order(const double* pts, std::size_t stride, std::size_t n,
                                             std::uint64_t seed = 0x9d2c5680f00dcafeull) {
    const HilbertFrame frame(pts, stride, n);
    int rounds = 0;  // number of halvings: round r holds ~n / 2^(r+1) points
    while (rounds < 12 && (n >> (rounds + 1)) >= 64) ++rounds;
    std::vector<std::uint32_t> keys(n), idx(n);
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t h = splitmix64(seed ^ (std::uint64_t(i) * 0x2545f4914f6cdd1dull));
        // Geometric round: P(r) = 2^-(r+1), capped; the coarsest round
        // (r == rounds) is inserted first.
        int r = 0;
        std::uint64_t bits = h;
        while (r < rounds && (bits & 1u)) {
            ++r;
            bits >>= 1;
        }
        const std::uint32_t round_rank = static_cast<std::uint32_t>(rounds - r);
        keys[i] = (round_rank << (2 * kHilbertLevels)) | frame.key(pts[i * stride], pts[i * stride + 1]);
        idx[i] = static_cast<std::uint32_t>(i);
    }
    radix_sort_by_key(keys, idx);
    refine_ties(pts, stride, keys, idx, 0, n, 0);
    return idx;
}

}  // namespace faultmesh::detail
