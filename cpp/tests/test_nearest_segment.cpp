// GoogleTest: the nearest-segment query (nearest_segment.hpp) against a
// brute-force scan of every segment, on random, long, degenerate and
// UTM-offset segments.
#include <faultmesh/nearest_segment.hpp>
#include <faultmesh/segments.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace {

struct Brute {
    std::int64_t index = -1;
    double d2 = std::numeric_limits<double>::infinity();
};

Brute brute(const double* p, const std::vector<double>& a, const std::vector<double>& b) {
    Brute r;
    for (std::size_t j = 0; j < a.size() / 2; ++j) {
        const double d2 = faultmesh::segment_distance2(&a[2 * j], &b[2 * j], p);
        if (d2 < r.d2) {
            r.d2 = d2;
            r.index = static_cast<std::int64_t>(j);
        }
    }
    return r;
}

void check_against_brute(const std::vector<double>& P, const std::vector<double>& A, const std::vector<double>& B) {
    const auto got = faultmesh::nearest_segment(P.data(), P.size() / 2, A.data(), B.data(), A.size() / 2);
    for (std::size_t i = 0; i < P.size() / 2; ++i) {
        const Brute want = brute(&P[2 * i], A, B);
        // The same squared distance, the same (lowest) index among ties.
        EXPECT_EQ(got.index[i], want.index) << "point " << i;
        EXPECT_EQ(got.distance[i], std::sqrt(want.d2)) << "point " << i;
    }
}

TEST(NearestSegment, RandomSegmentsMatchBruteForce) {
    std::mt19937_64 rng(20261203);
    for (int round = 0; round < 40; ++round) {
        std::uniform_real_distribution<double> U(-1000.0, 1000.0);
        // Short and a few very long segments: the long ones widen the walk's bound.
        std::uniform_real_distribution<double> len(0.0, round % 4 == 0 ? 3000.0 : 30.0);
        const double off = round % 2 ? 5.0e5 : 0.0;  // UTM-sized coordinates every other round
        const std::size_t m = 1 + rng() % 200, n = 1 + rng() % 300;
        std::vector<double> A, B, P;
        for (std::size_t j = 0; j < m; ++j) {
            const double x = off + U(rng), y = off + U(rng), t = U(rng), l = len(rng);
            A.insert(A.end(), {x, y});
            B.insert(B.end(), {x + l * std::cos(t), y + l * std::sin(t)});
        }
        for (std::size_t i = 0; i < n; ++i) P.insert(P.end(), {off + 1.5 * U(rng), off + 1.5 * U(rng)});
        check_against_brute(P, A, B);
    }
}

TEST(NearestSegment, DegenerateAndTiedSegments) {
    // A zero-length segment, a repeated segment (ties go to the lower index),
    // vertical segments sharing one x, points on segments and at their ends.
    const std::vector<double> A = {0, 0, 5, 5, 2, 0, 2, 0, 2, 4, 10, -1};
    const std::vector<double> B = {4, 0, 5, 5, 2, 3, 2, 3, 2, 8, 10, 9};
    const std::vector<double> P = {1, 0, 5, 5, 2, 1, 2, 3.5, 6, 4, 10, 9, 10, 20, -3, -4, 2, 3};
    check_against_brute(P, A, B);
    const auto got = faultmesh::nearest_segment(P.data(), P.size() / 2, A.data(), B.data(), A.size() / 2);
    EXPECT_EQ(got.distance[0], 0.0);  // on the first segment
    EXPECT_EQ(got.index[1], 1);       // on the zero-length one
    EXPECT_EQ(got.index[2], 2);       // on segments 2 and 3 (the same): the lower index
    EXPECT_EQ(got.distance[6], 11.0);
    EXPECT_EQ(got.distance[7], 5.0);
}

TEST(NearestSegment, NoSegmentsOrNoPoints) {
    const std::vector<double> P = {1, 2};
    const auto none = faultmesh::nearest_segment(P.data(), 1, nullptr, nullptr, 0);
    ASSERT_EQ(none.index.size(), 1u);
    EXPECT_EQ(none.index[0], -1);
    EXPECT_TRUE(std::isinf(none.distance[0]));
    const std::vector<double> A = {0, 0}, B = {1, 1};
    EXPECT_TRUE(faultmesh::nearest_segment(nullptr, 0, A.data(), B.data(), 1).index.empty());
}

TEST(NearestSegment, StrideThreeReadsXYOnly) {
    const std::vector<double> A = {0, 0, 99, 10, 0, -99}, B = {0, 10, 99, 10, 10, -99};
    const std::vector<double> P = {3, 5, 1e30, 9, 9, -1e30};
    const auto got = faultmesh::nearest_segment(P.data(), 2, A.data(), B.data(), 2, 3);
    EXPECT_EQ(got.index[0], 0);
    EXPECT_EQ(got.distance[0], 3.0);
    EXPECT_EQ(got.index[1], 1);
    EXPECT_EQ(got.distance[1], 1.0);
}

}  // namespace

TEST(NearestSegment, IndexKeepsItsCopyAndAnswersAsTheBatch) {
    std::vector<double> A = {0, 0, 10, 0, 20, 5}, B = {5, 0, 10, 8, 30, 5};
    const faultmesh::SegmentIndex index(A.data(), B.data(), 3);
    std::fill(A.begin(), A.end(), 1e9);  // the caller's arrays may change
    std::fill(B.begin(), B.end(), 1e9);
    const double p[2] = {11, 4}, q[2] = {26, 9}, r[2] = {-3, 4};
    double d2;
    EXPECT_EQ(index.nearest(p, d2), 1);
    EXPECT_EQ(d2, 1.0);
    EXPECT_EQ(index.nearest(q, d2), 2);
    EXPECT_EQ(d2, 16.0);
    EXPECT_EQ(index.nearest(r, d2), 0);
    EXPECT_EQ(d2, 25.0);
    EXPECT_EQ(index.size(), 3u);
    const faultmesh::SegmentIndex empty;
    EXPECT_EQ(empty.nearest(p, d2), -1);
    EXPECT_TRUE(std::isinf(d2));
}
