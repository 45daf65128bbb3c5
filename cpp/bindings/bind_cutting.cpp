// Binding of the surface-cutting baseline (cutting.hpp).
#include <faultmesh/cutting.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

void bind_cutting(py::module_& m) {
    m.def(
        "cut_layer",
        [](const py::handle& layer_vertices, const py::handle& layer_triangles, const py::handle& fault_vertices,
           const py::handle& fault_triangles, double displacement, double taper_length, bool refine,
           const std::string& order, double min_edge_fraction, double extension) {
            const char* fn = "cut_layer";
            DoubleArray lv = as_points(layer_vertices, fn, "layer_vertices", 3, 3);
            IndexArray lt = as_indices(layer_triangles, fn, "layer_triangles", 3);
            DoubleArray fv = as_points(fault_vertices, fn, "fault_vertices", 3, 3);
            IndexArray ft = as_indices(fault_triangles, fn, "fault_triangles", 3);
            CutOptions opt;
            opt.displacement = displacement;
            opt.taper_length = taper_length;
            opt.min_edge_fraction = min_edge_fraction;
            opt.extension = extension;
            opt.triangulation.refine = refine;
            if (order == "quality")
                opt.triangulation.order = EarOrder::quality;
            else if (order == "plain")
                opt.triangulation.order = EarOrder::plain;
            else
                throw std::invalid_argument(std::string(fn) + ": order must be 'quality' or 'plain', got '" +
                                            order + "'");
            CutResult r;
            {
                py::gil_scoped_release release;
                r = cut_layer(lv.data(), static_cast<std::size_t>(lv.shape(0)), lt.data(),
                              static_cast<std::size_t>(lt.shape(0)), fv.data(), static_cast<std::size_t>(fv.shape(0)),
                              ft.data(), static_cast<std::size_t>(ft.shape(0)), opt);
            }
            const std::int64_t nt = static_cast<std::int64_t>(r.triangles.size() / 3);
            std::vector<std::int64_t> created(r.n_created);
            for (std::size_t i = 0; i < r.n_created; ++i)
                created[i] = nt - static_cast<std::int64_t>(r.n_created) + static_cast<std::int64_t>(i);
            py::dict d;
            d["vertices"] = to_numpy(std::move(r.vertices), 3);
            d["triangles"] = to_numpy(std::move(r.triangles), 3);
            d["created"] = to_numpy(std::move(created));
            d["removed"] = to_numpy(std::move(r.removed));
            d["split"] = to_numpy(std::move(r.split));
            d["line_offsets"] = to_numpy(std::move(r.line_offsets));
            d["footwall_line"] = to_numpy(std::move(r.footwall_line));
            d["hanging_line"] = to_numpy(std::move(r.hanging_line));
            d["line_weight"] = to_numpy(std::move(r.line_weight));
            d["n_examined_triangles"] = r.n_examined_triangles;
            d["n_classified_vertices"] = r.n_classified_vertices;
            return d;
        },
        py::arg("layer_vertices"), py::arg("layer_triangles"), py::arg("fault_vertices"),
        py::arg("fault_triangles"), py::kw_only(), py::arg("displacement") = 0.0, py::arg("taper_length") = 0.0,
        py::arg("refine") = true, py::arg("order") = "quality", py::arg("min_edge_fraction") = 1e-3, py::arg("extension") = 0.0,
        "Cut a layer TIN along its intersection line with a fault surface (the\n"
        "surface-cutting baseline of the paper's comparison, not faultmesh's method).\n\n"
        "layer_vertices (n, 3), layer_triangles (m, 3) counter-clockwise in XY;\n"
        "fault_vertices (k, 3), fault_triangles (f, 3). The layer triangles crossed by\n"
        "the fault are re-triangulated with the intersection line as a constraint\n"
        "(ear clipping, refine=True: constrained Delaunay), the line's vertices are\n"
        "doubled and the hanging-wall copies (the side above the fault) get\n"
        "z += displacement * weight, the weight growing from 0 at a tip over\n"
        "taper_length. extension: on the layer's boundary edges, crossings up to this XY\n"
        "distance outside the fault's projection are cut too (a fault surface ending just\n"
        "short of the study-area boundary still cuts to it). Returns a dict: vertices (n', 3) (input vertices first),\n"
        "triangles (m', 3), created (row indices of the new triangles), removed and\n"
        "split (input rows replaced), line_offsets / footwall_line / hanging_line /\n"
        "line_weight (the intersection polylines, hanging wall on the left), and the\n"
        "diagnostics n_examined_triangles, n_classified_vertices.");
}

}  // namespace faultmesh::bindings
