// Stitch steps 2 and 3, overlap and growth: the layer rows that touch the
// patch outline R, grown by the library's one grower (overlap_growth.hpp)
// with the stitcher's rules (stitch.hpp, steps 2 and 3).
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/errors.hpp>

#include "stitch_steps.hpp"

#include <algorithm>
#include <string>
#include <vector>

namespace faultmesh::detail {

bool LayerHooks::frozen(std::int64_t t) const {
    return s_.kind[static_cast<std::size_t>(t)] == static_cast<std::int8_t>(TriangleKind::patch);
}

std::int64_t LayerHooks::group_of(std::int64_t t) const {
    return s_.kind[static_cast<std::size_t>(t)] == static_cast<std::int8_t>(TriangleKind::gap)
               ? s_.owner[static_cast<std::size_t>(t)]
               : -1;
}

const std::vector<std::int64_t>& LayerHooks::group(std::int64_t g) const { return s_.gap_rows.at(g); }

namespace {

std::string patch_label(const StitcherState& s, std::int64_t id) {
    if (id >= 0 && static_cast<std::size_t>(id) < s.patch_names.size())
        return "'" + s.patch_names[static_cast<std::size_t>(id)] + "'";
    return "#" + std::to_string(id);
}

}  // namespace

void find_overlap(StitcherState& s, StitchJob& job) {
    job.removed.emplace(s.in_d, s.new_stamp(), &job.hooks);
    RemovedSet& D = *job.removed;
    const Region& region = job.region;
    // Stage 1: the base blocks whose box meets R's box, then the base rows in
    // them whose own box does, and every row of a later stitch's block.
    std::vector<std::int64_t> cand;
    const Box2 rb = region.drawn_bounds();
    s.base.visit(rb, [&](std::int64_t b) {
        const std::size_t r0 = static_cast<std::size_t>(b) * kBlock;
        const std::size_t r1 = std::min(s.n_base, r0 + kBlock);
        for (std::size_t r = r0; r < r1; ++r) {
            const std::int64_t* t = &s.tri[3 * r];
            if (boxes_meet(triangle_box(s.v(t[0]), s.v(t[1]), s.v(t[2])), rb))
                cand.push_back(static_cast<std::int64_t>(r));
        }
    });
    for (const auto& b : s.blocks)
        if (boxes_meet(b.box, rb))
            for (std::int64_t r = b.begin; r < b.end; ++r) cand.push_back(r);
    job.report.n_candidates = static_cast<std::int64_t>(cand.size());
    std::sort(cand.begin(), cand.end());
    // Stage 2: the closed-contact predicate. An earlier patch touching R is an error.
    for (std::int64_t r : cand) {
        if (!s.alive[static_cast<std::size_t>(r)]) continue;
        const std::int64_t* t = &s.tri[3 * static_cast<std::size_t>(r)];
        if (!region.meets_closed_triangle(s.v(t[0]), s.v(t[1]), s.v(t[2]))) continue;
        if (s.kind[static_cast<std::size_t>(r)] == static_cast<std::int8_t>(TriangleKind::patch)) {
            const std::string other = patch_label(s, s.owner[static_cast<std::size_t>(r)]);
            const std::int64_t oid = s.owner[static_cast<std::size_t>(r)];
            const std::string other_name =
                oid >= 0 && static_cast<std::size_t>(oid) < s.patch_names.size() ? s.patch_names[static_cast<std::size_t>(oid)] : other;
            throw PatchOverlapError("stitch: layer '" + s.name + "': fault patch '" + job.patch_name +
                                "' overlaps (or touches) fault patch " + other + " in XY (triangle " +
                                std::to_string(r) + " of " + other + " near " + fmt_point(s.v(t[0])) +
                                " meets the outline of '" + job.patch_name +
                                "'); model crossing faults together (same group) or separate them",
                                s.name, job.patch_name, other_name);
        }
        D.add(r);
    }
    if (D.size() == 0) throw GeometryError(job.fn + ": no triangle of the layer lies under the patch");
}

void grow_removed_set(StitcherState& s, StitchJob& job) {
    RemovedSet& D = *job.removed;
    const GrowthMesh mesh{s.xyz.data(), 3, s.xyz.size() / 3, s.tri.data(), s.adj.data(), s.n_tri()};
    // The stitcher's rules: the closed-contact overlap already holds R
    // strictly inside D, so growth only makes D a disk (earlier patches as
    // holes): pinch vertices pull in their star, inner loops are filled, then
    // the clearance from the outline; D may reach the study-area boundary.
    // Earlier gaps are atomic (LayerHooks).
    GrowthRules rules;
    rules.pinch = PinchRule::pull_star;
    rules.holes = HoleRule::fill_inner_loops;
    rules.allow_mesh_boundary = true;
    // An earlier patch piece that touches the study boundary at one vertex
    // (its gap was pinched there, stitch_contours) may lie inside D with D on
    // both sides of it: D's outline passes that vertex twice.
    rules.keep_frozen_pinches_on_mesh_boundary = true;
    rules.clearance = s.opt.clearance;
    rules.max_rounds = s.opt.max_grow_rounds;
    Grower grower(mesh, D, job.region, rules, job.fn);
    grower.close_groups(0);
    job.report.grow_rounds = grower.run();
    job.report.merged_gaps = grower.merged_groups();
    job.boundary = grower.boundary().halfedges;
    job.kept_pinches = grower.kept_pinches();
    job.report.removed = D.members();
    std::sort(job.report.removed.begin(), job.report.removed.end());
}

}  // namespace faultmesh::detail
