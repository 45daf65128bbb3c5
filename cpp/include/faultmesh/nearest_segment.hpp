// faultmesh/nearest_segment.hpp -- the nearest of many segments to each of
// many points, in XY.
//
// The distance is the one floating-point measure of segments.hpp
// (segment_distance2), so a point at equal distance from two segments may get
// either; everything else is exact. Used where a point set is measured
// against polylines: the room between faults in fault derivation (points
// along a section against other faults' contour lines) and the model checks
// (TIN vertices against the study-area boundary).
//
// Method: the segments sorted by the x of their box centres; from each
// point's place in that order the search walks out both ways and stops in a
// direction once |x - centre x| less the widest box's half width is no
// smaller than the best distance so far (no segment further along can be
// nearer). Long segments widen that bound and the walk sees more of them; the
// answer never depends on it. n points and m segments cost O((n + m) log m)
// on spread-out data, O(n m) at worst.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace faultmesh {

// The segments indexed once for many nearest-segment queries (the walk
// above). Keeps its own copy of the segments' x, y.
class SegmentIndex {
public:
    SegmentIndex() = default;
    // starts, ends: m rows of `stride` doubles (x, y first).
    SegmentIndex(const double* starts, const double* ends, std::size_t m, std::size_t stride = 2);
    // The nearest segment to p (x, y): its index, or -1 with no segment;
    // its squared XY distance in `d2` (+inf with no segment). Ties: the
    // lowest index.
    std::int64_t nearest(const double* p, double& d2) const;
    std::size_t size() const { return order_.size(); }

private:
    std::vector<double> ab_;         // per segment x0, y0, x1, y1
    std::vector<std::size_t> order_;  // segments by the x of their box centres
    std::vector<double> sorted_cx_;   // those x, in that order
    double half_w_ = 0.0;             // the widest box's half width
};

struct NearestSegment {
    std::vector<std::int64_t> index;  // per point: the nearest segment (-1 if m == 0)
    std::vector<double> distance;     // per point: its XY distance (+inf if m == 0)
};

// points: n rows of `stride` doubles (x, y first); segment j runs from
// starts[j] to ends[j] (rows of `stride` doubles, x, y first). Coordinates
// must be finite (checked by the caller). A segment of zero length is a
// point. Among segments at the same distance the lowest index wins.
NearestSegment nearest_segment(const double* points, std::size_t n, const double* starts, const double* ends,
                               std::size_t m, std::size_t stride = 2);

}  // namespace faultmesh
