// Internal to the library (faultmesh::detail): the stitcher's state and the
// steps of one stitch (stitch.hpp gives the algorithm; the numbers below are
// its steps). LayerStitcher::stitch is the sequence
//
//     StitchJob job(state, patch ...);   // the patch, validated
//     outline_patch(state, job);         // 1. outline: orientation, loops, region R
//     find_overlap(state, job);          // 2. overlap: AABB candidates, closed-contact test
//     grow_removed_set(state, job);      // 3. growth: the grower with the stitcher's rules
//     build_gap_polygons(state, job);    // 4. contours: gap rings, outer rings and holes
//     clip_gap_polygons(state, job);     // 5. bridging + clipping: ear clipping of each gap
//     link_new_triangles(state, job);    // 6. merge (local part): adjacency of the new triangles
//     commit(state, job);                // 6. merge (commit): the only step that changes the layer
//
// Each step reads what the steps before it put into the job; every step up
// to link_new_triangles may throw and leaves the layer as it was (only the
// scratch marks and the lazily verified flags of base triangles change).
// Files by phase: stitch.cpp (set-up, the sequence, export), stitch_outline.cpp,
// stitch_overlap.cpp (overlap and growth), stitch_contours.cpp,
// stitch_clip.cpp, stitch_merge.cpp.
#pragma once

#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/stitch.hpp>
#include <faultmesh/study_area.hpp>

#include "overlap_growth.hpp"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace faultmesh::detail {

constexpr std::size_t kBlock = 8;  // triangles per leaf box of the stitcher's AABB tree

std::string fmt_point(const double* p);  // "(x, y)" with 10 significant digits

// ---------------------------------------------------------------- the layer
// The layer surface a LayerStitcher owns, kept from one stitch to the next.
// Rows are never reused: a removed triangle is marked dead, new ones are
// appended (mesh() compacts).
struct StitcherState {
    std::string name;
    StitchOptions opt;
    std::vector<double> xyz;
    std::vector<std::int64_t> tri;
    std::vector<std::int64_t> adj;   // opposite half-edge or -1 (triangle_adjacency.hpp)
    std::vector<std::int8_t> kind;   // TriangleKind
    std::vector<std::int64_t> owner;
    std::vector<char> alive;
    std::vector<char> checked;  // base triangles verified (orientation, half-edges)
    // Per layer vertex of the start: 1 where it is a datum that a gap may
    // take back (step 5), from LayerTin::measured() for a stratum TIN, every
    // vertex for a mesh given as arrays. Patch vertices (appended) are not.
    std::vector<char> measured;
    bool is_measured(std::int64_t v) const {
        return v >= 0 && static_cast<std::size_t>(v) < measured.size() && measured[static_cast<std::size_t>(v)];
    }
    std::size_t n_live = 0;
    // Stage-1 index: a tree over blocks of kBlock base rows, plus one box per
    // later stitch for the rows it appended.
    AabbTree base;
    std::size_t n_base = 0;
    struct Block {
        Box2 box;
        std::int64_t begin, end;
    };
    std::vector<Block> blocks;
    std::unordered_map<std::int64_t, std::vector<std::int64_t>> gap_rows;     // live gaps
    std::unordered_map<std::int64_t, std::vector<std::int64_t>> gap_patches;  // live gaps
    std::int64_t next_gap = 0;
    std::vector<std::string> patch_names;
    StudyArea study;
    // Scratch marks of the removed set, with stamps: no O(mesh) clearing per stitch.
    std::vector<std::uint32_t> in_d;
    std::uint32_t stamp = 0;

    std::size_t n_tri() const { return kind.size(); }
    const double* v(std::int64_t i) const { return xyz.data() + 3 * i; }
    // Verify a base triangle before a stitch relies on it: counter-clockwise
    // with non-zero area in XY, and each half-edge's opposite points back at
    // it with the same two vertices.
    void ensure(std::int64_t r);
    void grow_markers() { in_d.resize(n_tri(), 0); }
    std::uint32_t new_stamp();
};

StitcherState& state_of(LayerStitcher& st);  // for the step tests

// ---------------------------------------------------------------- the outline
// An outline edge of a patch (patch-local vertices a -> b, as its loop runs),
// classified as lying along one side of the study area or not.
struct OutlineEdge {
    std::int64_t a, b;
    bool study;
    std::size_t side;
    double sa, sb;  // arc lengths of a and b along that side
};

// The edges of the outline loops, loop after loop, each classified by
// StudyArea::along_one_side (an edge of length 0 at a point of a side runs
// along it: a vertical fault's cutoffs carried onto the boundary); with no
// study area none is. The boundary hits of the loop vertices that lie on the
// study-area boundary go into *hits when it is given.
std::vector<OutlineEdge> classify_outline(
    const StudyArea* study, const double* vertices, std::size_t stride,
    const std::vector<std::vector<std::int64_t>>& loops,
    std::unordered_map<std::int64_t, std::vector<StudyArea::Hit>>* hits = nullptr);

// The pairs (i, j), i < j, of outline edges that meet where the outline
// must be simple in XY (stitch step 1): two edges that share no vertex meet
// if their closed segments share a point; two that share a vertex if they
// fold back onto each other there (collinear, the same way from it). Pairs of
// edges that both run along the study-area boundary are exempt (a reverse
// fault that runs out of the area folds along it). In the order i, then the
// AABB tree's order of j; only the first pair with first_only. Exact
// (orient2d); the vertices are checked by the caller.
std::vector<std::pair<std::size_t, std::size_t>> meeting_outline_edges(const double* vertices,
                                                                       std::size_t n_vertices,
                                                                       std::size_t stride,
                                                                       const std::vector<OutlineEdge>& edges,
                                                                       bool first_only);

// What the grower needs to know about the layer's triangles: base triangles
// are verified lazily, earlier fault patches are frozen (they become holes of
// the gap), earlier gaps are atomic groups.
class LayerHooks : public GrowthHooks {
public:
    explicit LayerHooks(StitcherState& s) : s_(s) {}
    void verify(std::int64_t t) override { s_.ensure(t); }
    bool frozen(std::int64_t t) const override;
    std::int64_t group_of(std::int64_t t) const override;
    const std::vector<std::int64_t>& group(std::int64_t g) const override;

private:
    StitcherState& s_;
};

// ---------------------------------------------------------------- one stitch
// One stitch in progress: the patch, then what each step adds to it.
struct StitchJob {
    // The patch: vertices (3 per vertex, not owned), triangles (copied;
    // re-oriented by step 1), name; `fn` starts every message.
    StitchJob(StitcherState& s, const double* patch_vertices, std::size_t n_patch_vertices,
              std::vector<std::int64_t> patch_triangles, std::string patch_name);
    StitchJob(const StitchJob&) = delete;
    StitchJob& operator=(const StitchJob&) = delete;

    const double* pv;
    std::size_t npv;
    std::vector<std::int64_t> ptri;
    std::size_t npt;
    std::string patch_name, fn;
    const double* P(std::int64_t i) const { return pv + 3 * i; }
    StitchReport report;

    // 1. outline: R's edges (patch-local vertices, patch on the left), each
    // classified as lying on one side of the study area or not.
    using OutlineEdge = detail::OutlineEdge;
    std::vector<OutlineEdge> outline;
    Region region;

    // 2. overlap, 3. growth: the removed set D (rows in the order they
    // joined; sorted by step 3) and its boundary half-edges (D on the left).
    LayerHooks hooks;
    std::optional<RemovedSet> removed;
    std::vector<std::int64_t> boundary;
    std::vector<std::int64_t> kept_pinches;  // layer vertices D's outline passes twice (sorted)

    // 4. contours. Gap vertices: stitcher vertices below n_layer_vertices,
    // patch vertex i as n_layer_vertices + i.
    std::int64_t n_layer_vertices = 0;
    struct GapEdge {
        std::int64_t a, b;
        std::int64_t tag;  // patch id whose outline this edge is, or -1
    };
    std::vector<GapEdge> gap_edges;
    std::unordered_set<std::uint64_t> study_keys;        // directed gap edges along the study boundary
    std::unordered_map<std::uint64_t, std::int64_t> dside;  // edge (a, b) of D's boundary -> kept half-edge across
    std::vector<std::vector<std::int64_t>> rings;  // gap-edge indices, chained
    std::vector<double> ring_area;                 // twice the signed area
    std::vector<std::size_t> outers;               // CCW rings
    std::vector<std::vector<std::size_t>> holes_of;  // outer ring -> its holes (CW rings)
    const double* X(std::int64_t g) const;  // coordinates of gap vertex g

    // 5. clipping: the new rows (patch triangles first, then the gaps'), from row0.
    std::int64_t row0 = 0;
    std::vector<std::int64_t> new_tri;
    std::vector<std::int8_t> new_kind;
    std::vector<std::int64_t> new_owner;

    // 6. merge: adjacency of the new rows, and the kept half-edges to relink.
    std::vector<std::int64_t> new_adj;
    std::vector<std::pair<std::int64_t, std::int64_t>> relink;

private:
    const StitcherState& s_;
};

// A directed edge as one key.
inline std::uint64_t edge_key(std::int64_t a, std::int64_t b) {
    return (static_cast<std::uint64_t>(a) << 32) ^ static_cast<std::uint64_t>(b);
}

// 1. Outline: each edge-connected component of the patch oriented so that its
// signed XY area is positive; boundary loops (boundary.hpp); the checks of
// stitch.hpp step 1; job.outline and job.region.
void outline_patch(const StitcherState& s, StitchJob& job);
// 2. Overlap: the layer rows whose closed XY projection meets the closed
// region R (stage 1: the AABB index; stage 2: Region::meets_closed_triangle)
// form the first removed set; an earlier patch among them is an error.
void find_overlap(StitcherState& s, StitchJob& job);
// 3. Growth: the grower (overlap_growth.hpp) with the stitcher's rules; D is
// sorted and its boundary half-edges kept.
void grow_removed_set(StitcherState& s, StitchJob& job);
// 4. Contours: D's boundary and R's outline reversed (plus the pieces of the
// study-area boundary that D covers and R does not) chained into rings;
// outer rings (CCW) get their holes (CW).
void build_gap_polygons(const StitcherState& s, StitchJob& job);
// 5. Bridging + clipping: the patch rows, then each gap polygon ear-clipped
// (ear_clipping.hpp bridges the holes); n + 2h - 2 triangles checked.
void clip_gap_polygons(const StitcherState& s, StitchJob& job);
// 6a. The adjacency of the new rows among themselves and with the kept rows
// across D's boundary (still local: may throw, changes nothing).
void link_new_triangles(const StitcherState& s, StitchJob& job);
// 6b. Commit: D removed, the patch's vertices and the new rows appended, the
// kept half-edges relinked, gap records updated. Returns the report.
StitchReport commit(StitcherState& s, StitchJob& job);

}  // namespace faultmesh::detail
