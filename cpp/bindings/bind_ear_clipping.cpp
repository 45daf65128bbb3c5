// Bindings for ear_clipping (triangulate_polygon, join_holes, check_polygon)
// and the constrained-Delaunay flips of polygon_cdt.
#include <faultmesh/ear_clipping.hpp>
#include <faultmesh/polygon_cdt.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

namespace {

BridgeMethod parse_bridge(const std::string& s, const char* fn) {
    if (s == "extreme" || s == "extreme_point") return BridgeMethod::extreme_point;
    if (s == "eberly") return BridgeMethod::eberly;
    throw std::invalid_argument(std::string(fn) + ": bridge must be 'extreme' or 'eberly', got '" + s + "'");
}

EarOrder parse_order(const std::string& s, const char* fn) {
    if (s == "quality") return EarOrder::quality;
    if (s == "plain") return EarOrder::plain;
    throw std::invalid_argument(std::string(fn) + ": order must be 'quality' or 'plain', got '" + s + "'");
}

}  // namespace

void bind_ear_clipping(py::module_& m) {
    m.def(
        "triangulate_polygon",
        [](const py::handle& rings, bool refine, const std::string& order, const std::string& bridge,
           bool strict, int threads, py::ssize_t split_min) {
            const char* fn = "triangulate_polygon";
            RingsData R = as_rings(rings, fn, 2, 3);
            const std::vector<double>& xy = R.xy;
            const std::vector<std::int64_t>& offsets = R.offsets;
            EarClipOptions opt;
            opt.refine = refine;
            opt.order = parse_order(order, fn);
            opt.bridge = parse_bridge(bridge, fn);
            opt.strict = strict;
            if (threads != 0 && threads != 1)
                throw std::invalid_argument(std::string(fn) + ": threads must be 0 (automatic) or 1, got " +
                                            std::to_string(threads));
            if (split_min < 0)
                throw std::invalid_argument(std::string(fn) + ": split_min must be >= 0, got " +
                                            std::to_string(split_min));
            opt.threads = threads;
            opt.split_min = static_cast<std::size_t>(split_min);
            std::vector<std::int64_t> tris;
            {
                py::gil_scoped_release release;
                tris = triangulate_polygon(xy.data(), offsets.data(), offsets.size() - 1, opt);
            }
            return to_numpy(std::move(tris), 3);
        },
        py::arg("rings"), py::arg("refine") = true, py::arg("order") = "quality",
        py::arg("bridge") = "extreme", py::arg("strict") = false, py::arg("threads") = 0,
        py::arg("split_min") = 4096,
        "Triangulate a polygon with holes by ear clipping.\n\n"
        "rings: list of (k, 2) arrays, the outer ring first (at least 3 rows), then the holes (any orientation;\n"
        "a closing point equal to the first and consecutive duplicates are ignored).\n"
        "Returns (m, 3) int64 triangles, counter-clockwise, indexing the rings' points\n"
        "concatenated. A valid polygon with n vertices and h holes gives n + 2h - 2 triangles.\n"
        "refine: Lawson flips to the constrained Delaunay triangulation (ring edges kept).\n"
        "order: 'quality' (clip the ear with the largest minimum angle first) or 'plain'\n"
        "(Eberly's order). bridge: 'extreme' (paper's extreme-point preference, Eberly as\n"
        "fallback) or 'eberly'. strict: raise GeometryError naming the ring and vertex of an\n"
        "invalid polygon instead of a best-effort triangulation.\n"
        "split_min: plain order on valid-looking input: a joined loop of at least this many\n"
        "vertices is split along an inside diagonal into two parts of 40-60%, clipped\n"
        "concurrently (0: never). threads: 0 = the second part on another thread if the machine\n"
        "has more than one core, 1 = the calling thread only; the triangles are the same.");
    m.def(
        "join_holes",
        [](const py::handle& rings, const std::string& bridge) {
            const char* fn = "join_holes";
            RingsData R = as_rings(rings, fn, 2, 3);
            const std::vector<double>& xy = R.xy;
            const std::vector<std::int64_t>& offsets = R.offsets;
            const BridgeMethod method = parse_bridge(bridge, fn);
            JoinedPolygon j;
            {
                py::gil_scoped_release release;
                j = faultmesh::join_holes(xy.data(), xy.size() / 2, nullptr, offsets.data(),
                                          offsets.size() - 1, method);
            }
            return py::make_tuple(to_numpy(std::move(j.loop)), to_numpy(std::move(j.bridges), 2),
                                  to_numpy(std::move(j.skipped_rings)));
        },
        py::arg("rings"), py::arg("bridge") = "extreme",
        "Join the holes to the outer ring by bridges between mutually visible vertices.\n"
        "Returns (loop, bridges, skipped): loop (k,) int64 vertex indices of one closed,\n"
        "counter-clockwise, weakly simple polygon (bridge endpoints appear twice); bridges\n"
        "(b, 2) int64 (outer-side vertex, hole vertex); skipped: rings left out.");
    m.def(
        "check_polygon",
        [](const py::handle& rings) {
            const char* fn = "check_polygon";
            RingsData R = as_rings(rings, fn, 2, 0);
            const std::vector<double>& xy = R.xy;
            const std::vector<std::int64_t>& offsets = R.offsets;
            PolygonCheck c;
            {
                py::gil_scoped_release release;
                c = faultmesh::check_polygon(xy.data(), xy.size() / 2, nullptr, offsets.data(),
                                             offsets.size() - 1);
            }
            return py::make_tuple(c.valid, c.message, c.ring, c.vertex);
        },
        py::arg("rings"),
        "Validity of a polygon with holes: (valid, message, ring, vertex). Valid: every ring\n"
        "has >= 3 vertices and non-zero area, edges meet only at shared vertices, holes\n"
        "inside the outer ring and outside each other.");
    m.def(
        "flip_to_constrained_delaunay",
        [](const py::handle& xy_obj, const py::handle& tri_obj, const py::handle& cons_obj) {
            const char* fn = "flip_to_constrained_delaunay";
            DoubleArray xy = as_points(xy_obj, fn, "xy", 2, 2);
            IndexArray t = as_indices(tri_obj, fn, "triangles", 3, xy.shape(0));
            IndexArray c = as_indices(cons_obj, fn, "constrained_edges", 2, xy.shape(0));
            std::vector<std::int64_t> tris(t.data(), t.data() + t.size());
            {
                py::gil_scoped_release release;
                faultmesh::flip_to_constrained_delaunay(xy.data(), static_cast<std::size_t>(xy.shape(0)), tris,
                                                        c.data(), static_cast<std::size_t>(c.shape(0)));
            }
            return to_numpy(std::move(tris), 3);
        },
        py::arg("xy"), py::arg("triangles"), py::arg("constrained_edges"),
        "Lawson flips (exact incircle, CGAL's symbolic perturbation for ties) until every\n"
        "non-constrained interior edge is locally Delaunay. Returns the new (m, 3) triangles.");
}

}  // namespace faultmesh::bindings
