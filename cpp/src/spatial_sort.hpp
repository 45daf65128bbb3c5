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
// Keys are computed by quantising each coordinate to `levels` bits and
// mapping the cell to its Hilbert index with a 4-state automaton (the state is
// the accumulated swap/complement of the sub-square); the keys are then sorted
// with an LSD radix sort, which skips the byte positions where all keys agree.
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

// Sorts vals by keys (both permuted), stable, LSD radix on bytes.
inline void radix_sort_by_key(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& vals) {
    const std::size_t n = keys.size();
    if (n < 2) return;
    std::vector<std::size_t> hist(8 * 256, 0);
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t k = keys[i];
        for (int b = 0; b < 8; ++b) ++hist[b * 256 + ((k >> (8 * b)) & 0xffu)];
    }
    std::vector<std::uint64_t> k2(n);
    std::vector<std::uint32_t> v2(n);
    for (int b = 0; b < 8; ++b) {
        std::size_t* h = &hist[b * 256];
        bool trivial = false;
        for (int j = 0; j < 256; ++j)
            if (h[j] == n) trivial = true;
        if (trivial) continue;  // every key has the same byte here
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

// Quantisation of a point set's bounding square onto a 2^levels grid.
struct HilbertFrame {
    double x0 = 0, y0 = 0, scale = 0, cells = 0;
    int levels = 16;

    // pts: n points with `stride` doubles each (x, y first); non-finite
    // coordinates are ignored for the frame.
    HilbertFrame(const double* pts, std::size_t stride, std::size_t n) {
        double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY;
        for (std::size_t i = 0; i < n; ++i) {
            const double x = pts[i * stride], y = pts[i * stride + 1];
            if (!(std::isfinite(x) && std::isfinite(y))) continue;
            xmin = std::min(xmin, x);
            xmax = std::max(xmax, x);
            ymin = std::min(ymin, y);
            ymax = std::max(ymax, y);
        }
        // Enough levels that a uniform set has ~2^8 cells per point (so that
        // ties are rare) while keeping the radix sort short; 24 levels at
        // most (2^48 cells) covers strongly clustered sets too.
        int lv = 8;
        while (lv < 24 && (std::uint64_t(1) << (2 * lv)) < std::uint64_t(n) * 256u) lv += 4;
        levels = lv;
        const double ext = std::max(xmax - xmin, ymax - ymin);
        x0 = xmin;
        y0 = ymin;
        // The largest cell index is 2^levels - 1; scale maps the extent just
        // inside it. A degenerate (single point) extent maps everything to 0.
        cells = std::ldexp(1.0, levels) - 1.0;
        scale = (ext > 0 && std::isfinite(ext)) ? cells / ext : 0.0;
    }

    std::uint64_t key(double x, double y) const {
        double fx = (x - x0) * scale, fy = (y - y0) * scale;
        // Clamp (queries may lie outside the frame; NaN goes to 0).
        fx = fx > 0 ? (fx < cells ? fx : cells) : 0.0;
        fy = fy > 0 ? (fy < cells ? fy : cells) : 0.0;
        return hilbert_index(static_cast<std::uint32_t>(fx), static_cast<std::uint32_t>(fy), levels);
    }
};

inline std::uint64_t splitmix64(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

// Indices 0..n-1 in Hilbert order of the points (stride doubles per point).
inline std::vector<std::uint32_t> hilbert_order(const double* pts, std::size_t stride, std::size_t n) {
    HilbertFrame frame(pts, stride, n);
    std::vector<std::uint64_t> keys(n);
    std::vector<std::uint32_t> idx(n);
    for (std::size_t i = 0; i < n; ++i) {
        keys[i] = frame.key(pts[i * stride], pts[i * stride + 1]);
        idx[i] = static_cast<std::uint32_t>(i);
    }
    radix_sort_by_key(keys, idx);
    return idx;
}

// Indices 0..n-1 in BRIO order: rounds coarse to fine, each along the Hilbert
// curve. The first round holds about 64 points or more.
inline std::vector<std::uint32_t> brio_order(const double* pts, std::size_t stride, std::size_t n,
                                             std::uint64_t seed = 0x9d2c5680f00dcafeull) {
    HilbertFrame frame(pts, stride, n);
    int rounds = 0;  // number of halvings: round r holds ~n / 2^(r+1) points
    while (rounds < 12 && (n >> (rounds + 1)) >= 64) ++rounds;
    std::vector<std::uint64_t> keys(n);
    std::vector<std::uint32_t> idx(n);
    const int key_bits = 2 * frame.levels;
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t h = splitmix64(seed ^ (std::uint64_t(i) * 0x2545f4914f6cdd1dull));
        int r = 0;  // geometric: P(r) = 2^-(r+1), capped
        std::uint64_t bits = h;
        while (r < rounds && (bits & 1u)) {
            ++r;
            bits >>= 1;
        }
        // The coarsest round (r == rounds) is inserted first.
        const std::uint64_t round_rank = static_cast<std::uint64_t>(rounds - r);
        keys[i] = (round_rank << key_bits) | frame.key(pts[i * stride], pts[i * stride + 1]);
        idx[i] = static_cast<std::uint32_t>(i);
    }
    radix_sort_by_key(keys, idx);
    return idx;
}

}  // namespace faultmesh::detail
