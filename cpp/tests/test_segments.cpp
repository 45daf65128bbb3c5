// GoogleTest: the exact segment helpers (segments.hpp), against exact
// rational-free references on small integer coordinates (every product is
// exact in doubles there, so a plain cross product is the reference).
#include <faultmesh/segments.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <random>

namespace {

using P = std::array<double, 2>;

double cross(const P& a, const P& b, const P& c) {
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}
bool on_seg_ref(const P& a, const P& b, const P& p) {
    return cross(a, b, p) == 0 && std::min(a[0], b[0]) <= p[0] && p[0] <= std::max(a[0], b[0]) &&
           std::min(a[1], b[1]) <= p[1] && p[1] <= std::max(a[1], b[1]);
}
// Closed segments meet: proper crossing or an endpoint on the other segment.
bool meet_ref(const P& a, const P& b, const P& c, const P& d) {
    const double o1 = cross(a, b, c), o2 = cross(a, b, d), o3 = cross(c, d, a), o4 = cross(c, d, b);
    if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) return true;
    return on_seg_ref(a, b, c) || on_seg_ref(a, b, d) || on_seg_ref(c, d, a) || on_seg_ref(c, d, b);
}
bool in_tri_ref(const P& p, const P& a, const P& b, const P& c) {
    const double o = cross(a, b, c);
    if (o == 0) return on_seg_ref(a, b, p) || on_seg_ref(b, c, p) || on_seg_ref(c, a, p);
    const double s1 = cross(a, b, p) * o, s2 = cross(b, c, p) * o, s3 = cross(c, a, p) * o;
    return s1 >= 0 && s2 >= 0 && s3 >= 0;
}
// The closed segment meets the open CCW triangle: some point of the segment
// is strictly inside. Reference: sample the segment at its end points, its
// midpoint and its crossings with the triangle's edge lines, each tested
// strictly (the segment's part inside the open triangle, if any, contains a
// midpoint of two consecutive such parameters).
bool meets_open_ref(const P& p, const P& q, const P& a, const P& b, const P& c) {
    const P t[3] = {a, b, c};
    double ts[8] = {0.0, 1.0};
    int n = 2;
    for (int e = 0; e < 3; ++e) {
        const double dp = cross(t[e], t[(e + 1) % 3], p), dq = cross(t[e], t[(e + 1) % 3], q);
        if (dp != dq) {
            const double s = dp / (dp - dq);
            if (s > 0 && s < 1) ts[n++] = s;
        }
    }
    std::sort(ts, ts + n);
    auto strictly_in = [&](double s) {
        const P x{p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])};
        return cross(a, b, x) > 0 && cross(b, c, x) > 0 && cross(c, a, x) > 0;
    };
    for (int i = 0; i < n; ++i)
        if (strictly_in(ts[i]) || (i + 1 < n && strictly_in(0.5 * (ts[i] + ts[i + 1])))) return true;
    return false;
}

}  // namespace

TEST(Segments, PointsAndCollinearTests) {
    const double a[] = {0, 0}, b[] = {4, 2}, m[] = {2, 1}, off[] = {2, 1.5}, beyond[] = {6, 3};
    EXPECT_TRUE(faultmesh::same_point(a, a));
    EXPECT_FALSE(faultmesh::same_point(a, b));
    EXPECT_TRUE(faultmesh::strictly_between(a, b, m));
    EXPECT_FALSE(faultmesh::strictly_between(a, b, a));
    EXPECT_FALSE(faultmesh::strictly_between(a, b, beyond));
    EXPECT_TRUE(faultmesh::on_segment(a, b, m));
    EXPECT_TRUE(faultmesh::on_segment(a, b, b));
    EXPECT_FALSE(faultmesh::on_segment(a, b, off));
    EXPECT_FALSE(faultmesh::on_segment(a, b, beyond));
    EXPECT_TRUE(faultmesh::in_segment_box(a, b, off));  // the box only: collinearity is the caller's
    // Vertical segment: strictly_between decides on y.
    const double v0[] = {1, 0}, v1[] = {1, 5}, vm[] = {1, 2};
    EXPECT_TRUE(faultmesh::strictly_between(v0, v1, vm));
    EXPECT_FALSE(faultmesh::strictly_between(v0, v1, v1));
}

TEST(Segments, MeetAndTriangleTestsMatchReferences) {
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> c(-3, 3);
    auto pt = [&] { return P{double(c(rng)), double(c(rng))}; };
    for (int it = 0; it < 20000; ++it) {
        const P a = pt(), b = pt(), d = pt(), e = pt(), f = pt();
        EXPECT_EQ(faultmesh::segments_meet(a.data(), b.data(), d.data(), e.data()), meet_ref(a, b, d, e));
        EXPECT_EQ(faultmesh::in_closed_triangle(a.data(), b.data(), d.data(), e.data()), in_tri_ref(a, b, d, e));
        const bool closed_ref = in_tri_ref(a, d, e, f) || meet_ref(a, b, d, e) || meet_ref(a, b, e, f) ||
                                meet_ref(a, b, f, d);
        EXPECT_EQ(faultmesh::segment_meets_closed_triangle(a.data(), b.data(), d.data(), e.data(), f.data()),
                  closed_ref);
        if (cross(d, e, f) > 0 && a != b)  // a real segment (the contract)
            EXPECT_EQ(faultmesh::segment_meets_open_triangle(a.data(), b.data(), d.data(), e.data(), f.data()),
                      meets_open_ref(a, b, d, e, f))
                << a[0] << "," << a[1] << " " << b[0] << "," << b[1];
    }
}

TEST(Segments, OpenTriangleIgnoresContactAlongItsEdges) {
    const double a[] = {0, 0}, b[] = {4, 0}, c[] = {0, 4};
    const double p[] = {-1, 0}, q[] = {5, 0};  // along the edge a-b
    EXPECT_FALSE(faultmesh::segment_meets_open_triangle(p, q, a, b, c));
    EXPECT_TRUE(faultmesh::segment_meets_closed_triangle(p, q, a, b, c));
    const double r[] = {1, -1}, s[] = {1, 1};  // crosses into the interior
    EXPECT_TRUE(faultmesh::segment_meets_open_triangle(r, s, a, b, c));
    const double u[] = {4, 0}, w[] = {5, 5};  // touches the vertex b only
    EXPECT_FALSE(faultmesh::segment_meets_open_triangle(u, w, a, b, c));
    EXPECT_TRUE(faultmesh::segment_meets_closed_triangle(u, w, a, b, c));
}
