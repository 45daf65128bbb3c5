// Stitch step 6, merge: the new rows linked to each other and to the kept
// rows across D's boundary (local, may throw), then committed to the layer
// (stitch.hpp, step 6).
#include <faultmesh/errors.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include "stitch_steps.hpp"

#include <algorithm>
#include <limits>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace faultmesh::detail {

void link_new_triangles(const StitcherState& s, StitchJob& job) {
    (void)s;
    const std::string& fn = job.fn;
    const std::vector<std::int64_t>& new_tri = job.new_tri;
    const std::int64_t row0 = job.row0;
    auto X = [&](std::int64_t g) { return job.X(g); };
    const std::unordered_map<std::uint64_t, std::int64_t>& dside = job.dside;
    const std::size_t nnew = job.new_kind.size();
    std::vector<std::int64_t>& new_adj = job.new_adj;
    new_adj.assign(3 * nnew, -1);
    std::vector<std::pair<std::int64_t, std::int64_t>>& relink = job.relink;  // kept half-edge -> new half-edge
    {
        // Twins among the new rows: the shared builder on the new rows with
        // their vertices numbered locally (the layer's numbering would make
        // its counting sort O(mesh)).
        std::unordered_map<std::int64_t, std::int64_t> local;
        std::vector<std::int64_t> global, lt(new_tri.size()), rows(nnew);
        local.reserve(2 * nnew);
        for (std::size_t i = 0; i < new_tri.size(); ++i) {
            auto ins = local.emplace(new_tri[i], static_cast<std::int64_t>(global.size()));
            if (ins.second) global.push_back(new_tri[i]);
            lt[i] = ins.first->second;
        }
        for (std::size_t t = 0; t < nnew; ++t) rows[t] = row0 + static_cast<std::int64_t>(t);
        AdjacencyLabels labels;
        labels.vertex_ids = global.data();
        labels.row_ids = rows.data();
        const std::vector<std::int64_t> twin = halfedge_twins(
            lt.data(), nnew, global.size(), EdgeOrientation::consistent, fn + ": internal error: new triangles",
            labels);
        for (std::size_t h = 0; h < 3 * nnew; ++h) {
            if (twin[h] >= 0) {
                new_adj[h] = row0 * 3 + twin[h];
                continue;
            }
            // Across D's boundary: the kept half-edge on the other side.
            const std::int64_t a = new_tri[h], b = new_tri[static_cast<std::size_t>(next_halfedge(static_cast<std::int64_t>(h)))];
            auto ds = dside.find(edge_key(a, b));
            if (ds != dside.end()) {
                new_adj[h] = ds->second;
                relink.emplace_back(ds->second, row0 * 3 + static_cast<std::int64_t>(h));
                continue;
            }
            if (!job.study_keys.count(edge_key(a, b)))
                throw GeometryError(fn + ": internal error: new edge (" + std::to_string(a) + ", " +
                                    std::to_string(b) + ") near " + fmt_point(X(a)) +
                                    " has no neighbour and is not on the study boundary");
        }
        if (relink.size() != dside.size())
            throw GeometryError(fn + ": internal error: " + std::to_string(dside.size() - relink.size()) +
                                " edges of the hole are not covered by the gap");
    }
}

StitchReport commit(StitcherState& s, StitchJob& job) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    const double* pv = job.pv;
    const std::size_t npv = job.npv;
    const std::vector<std::int64_t>& new_tri = job.new_tri;
    const std::vector<std::int64_t>& new_adj = job.new_adj;
    const std::int64_t row0 = job.row0, nV = job.n_layer_vertices;
    const std::int64_t pid = static_cast<std::int64_t>(s.patch_names.size());
    const std::size_t nnew = job.new_kind.size();
    const std::vector<std::int8_t>& new_kind = job.new_kind;
    const std::vector<std::int64_t>& new_owner = job.new_owner;
    StitchReport& rep = job.report;
    auto X = [&](std::int64_t g) { return job.X(g); };
    s.xyz.insert(s.xyz.end(), pv, pv + 3 * npv);
    Box2 box{kInf, kInf, -kInf, -kInf};
    for (std::int64_t vtx : new_tri) {
        const double* p = X(vtx);
        box.xmin = std::min(box.xmin, p[0]);
        box.ymin = std::min(box.ymin, p[1]);
        box.xmax = std::max(box.xmax, p[0]);
        box.ymax = std::max(box.ymax, p[1]);
    }
    s.tri.insert(s.tri.end(), new_tri.begin(), new_tri.end());
    s.adj.insert(s.adj.end(), new_adj.begin(), new_adj.end());
    for (const auto& rl : job.relink) s.adj[static_cast<std::size_t>(rl.first)] = rl.second;
    s.kind.insert(s.kind.end(), new_kind.begin(), new_kind.end());
    s.owner.insert(s.owner.end(), new_owner.begin(), new_owner.end());
    s.alive.insert(s.alive.end(), nnew, 1);
    for (std::int64_t r : rep.removed) s.alive[static_cast<std::size_t>(r)] = 0;
    s.n_live = s.n_live + nnew - rep.removed.size();
    s.blocks.push_back({box, row0, row0 + static_cast<std::int64_t>(nnew)});
    for (std::int64_t g : rep.merged_gaps) {
        s.gap_rows.erase(g);
        s.gap_patches.erase(g);
    }
    for (const auto& gap : rep.gaps) {
        s.gap_rows[gap.id] = gap.triangles;
        s.gap_patches[gap.id] = gap.patches;
    }
    s.next_gap += static_cast<std::int64_t>(rep.gaps.size());
    s.patch_names.push_back(job.patch_name);
    s.grow_markers();

    rep.patch_id = pid;
    rep.patch_vertex_offset = nV;
    rep.patch_triangle_offset = row0;
    return std::move(rep);
}

}  // namespace faultmesh::detail
