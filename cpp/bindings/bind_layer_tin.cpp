// Bindings for the stratum TINs and the layer-crossing repair:
// faultmesh.LayerTin, faultmesh.repair_crossings.
#include <faultmesh/layer_tin.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "common.hpp"

namespace faultmesh::bindings {

namespace {

// A LayerTin shared with Python (common.hpp): insert() and
// repair_crossings() change it with the GIL released, so they take its lock
// exclusively; interpolate(), mesh() and the accessors share it.
using PyLayerTin = Shared<LayerTin>;

StudyArea as_area(const py::handle& boundary, const char* fn) {
    if (py::isinstance<StudyArea>(boundary)) return boundary.cast<StudyArea>();
    auto R = as_coordinates(boundary, fn, "boundary", 2, 2, 2);
    return StudyArea(R.data(), static_cast<std::size_t>(R.shape(0)));
}

RepairOptions repair_options(const std::string& fn, int max_rounds, const py::object& tol, int midpoint_rounds,
                             double max_inserted_per_vertex, double max_above_fraction) {
    RepairOptions opt;
    opt.max_rounds = max_rounds;
    opt.midpoint_rounds = midpoint_rounds;
    opt.max_inserted_per_vertex = max_inserted_per_vertex;
    opt.max_above_fraction = max_above_fraction;
    if (max_rounds < 1) throw std::invalid_argument(fn + ": max_rounds must be >= 1");
    if (!(max_above_fraction >= 0.0 && max_above_fraction <= 1.0))
        throw std::invalid_argument(fn + ": max_above_fraction must be in [0, 1]");
    if (!tol.is_none()) {
        opt.tolerance = tol.cast<double>();
        if (!(opt.tolerance >= 0.0)) throw std::invalid_argument(fn + ": tol must be >= 0");
    }
    return opt;
}

py::dict counts_dict(const RepairCounts& c) {
    py::dict d;
    d["rule1"] = c.rule1;
    d["rule1b"] = c.rule1b;
    d["rule2"] = c.rule2;
    d["rule2_crossing"] = c.rule2_crossing;
    d["rounds"] = c.rounds;
    d["data_above"] = c.data_above;
    d["max_lowered"] = c.max_lowered;
    d["max_data_lowered"] = c.max_data_lowered;
    return d;
}

py::tuple mesh_tuple(LayerTinMesh&& m, bool with_halfedges) {
    if (with_halfedges)
        return py::make_tuple(to_numpy(std::move(m.vertices), 3), to_numpy(std::move(m.triangles), 3),
                              to_numpy(std::move(m.halfedges)));
    return py::make_tuple(to_numpy(std::move(m.vertices), 3), to_numpy(std::move(m.triangles), 3));
}

}  // namespace

void bind_layer_tin(py::module_& m) {
    py::class_<PyLayerTin>(m, "LayerTin",
                           "The continuous stratum TIN of one layer over the whole study area\n"
                           "(layer_tin.hpp): the Delaunay TIN of the layer's data inside the study area\n"
                           "plus densified, protected boundary vertices, so that mesh() covers exactly\n"
                           "the study area.")
        .def(py::init([](std::string name, const py::handle& data, const py::handle& boundary,
                         py::object spacing) {
                 // x, y within the coordinate limit; z must be finite (LayerTin checks it).
                 auto D = as_coordinates(data, "LayerTin", "data", 3, 3, 2);
                 StudyArea area = as_area(boundary, "LayerTin");
                 LayerTinOptions opt;
                 if (!spacing.is_none()) {
                     opt.spacing = spacing.cast<double>();
                     if (!(opt.spacing > 0.0 && std::isfinite(opt.spacing)))
                         throw std::invalid_argument("LayerTin: spacing must be a finite number > 0");
                 }
                 py::gil_scoped_release release;  // D is a private copy (as_points)
                 return std::make_unique<PyLayerTin>(std::move(name), D.data(),
                                                     static_cast<std::size_t>(D.shape(0)), area, opt);
             }),
             py::arg("name"), py::arg("data"), py::arg("boundary"), py::arg("spacing") = py::none(),
             "name: the layer's name (in messages). data (n, 3): x, y, z points. boundary: a\n"
             "StudyArea or a ring (k, 2). spacing: boundary vertex spacing (default: about the\n"
             "data spacing).")
        // name, spacing and area are set by the constructor and never change.
        .def_property_readonly("name", [](const PyLayerTin& t) { return t.obj.name(); })
        .def_property_readonly("spacing", [](const PyLayerTin& t) { return t.obj.spacing(); })
        .def_property_readonly("area", [](const PyLayerTin& t) { return t.obj.area(); })
        .def_property_readonly(
            "n_data", [](const PyLayerTin& t) { return read_locked(t, [](const LayerTin& l) { return l.n_data(); }); },
            "data points used (inside or on the study area)")
        .def_property_readonly(
            "n_outside",
            [](const PyLayerTin& t) { return read_locked(t, [](const LayerTin& l) { return l.n_outside(); }); },
            "data points outside the study area (not used)")
        .def_property_readonly(
            "n_boundary_data",
            [](const PyLayerTin& t) { return read_locked(t, [](const LayerTin& l) { return l.n_boundary_data(); }); },
            "data points on the study-area boundary (boundary vertices)")
        .def_property_readonly(
            "n_shared",
            [](const PyLayerTin& t) { return read_locked(t, [](const LayerTin& l) { return l.n_shared(); }); },
            "vertices taken from the triangulation shared with other layers (build_layer_tins);\n"
            "0 for a LayerTin built alone")
        .def_property_readonly(
            "n_vertices",
            [](const PyLayerTin& t) { return read_locked(t, [](const LayerTin& l) { return l.n_vertices(); }); })
        .def_property_readonly(
            "vertices",
            [](const PyLayerTin& t) {
                return to_numpy(read_locked(t, [](const LayerTin& l) { return l.tin().vertices(); }), 3);
            },
            "(n, 3) every TIN vertex with its current elevation")
        .def_property_readonly("z",
                               [](const PyLayerTin& t) {
                                   return to_numpy(read_locked(t, [](const LayerTin& l) { return l.z(); }));
                               })
        .def_property_readonly(
            "boundary_vertices",
            [](const PyLayerTin& t) {
                return to_numpy(read_locked(t, [](const LayerTin& l) { return l.boundary_vertices(); }));
            },
            "TIN vertices on the study-area boundary, counter-clockwise")
        .def(
            "insert",
            [](PyLayerTin& t, const py::handle& xyz, bool as_data) {
                auto P = as_coordinates(xyz, "LayerTin.insert", "xyz", 3, 3, 2);
                const std::size_t n = static_cast<std::size_t>(P.shape(0));
                return write_locked(t, [&](LayerTin& l) { return l.insert(P.data(), n, as_data); });
            },
            py::arg("xyz"), py::arg("as_data") = false,
            "Insert points (k, 3) keeping the boundary protected (points on the boundary become\n"
            "boundary vertices, points outside are ignored); a point at an existing vertex's XY\n"
            "gives it its z, and so does a point on the boundary within 1e-9 of the perimeter of\n"
            "a boundary vertex along its side. Returns the number of new vertices. as_data=True:\n"
            "the points are data (the stitcher puts them back into a gap, as the constructor's).")
        .def(
            "interpolate",
            [](const PyLayerTin& t, const py::handle& xy) {
                auto P = as_points(xy, "LayerTin.interpolate", "xy", 2, 2);  // a private copy
                const std::size_t n = static_cast<std::size_t>(P.shape(0));
                return to_numpy(read_locked(t, [&](const LayerTin& l) { return l.interpolate(P.data(), n); }));
            },
            py::arg("xy"), "z at points (k, 2) with the current elevations; NaN outside the TIN's hull. A point on the\n"
            "study-area boundary (also one that rounding puts a hair outside the hull) gets the elevation\n"
            "of the boundary piece it lies on (linear along the side).")
        .def(
            "mesh",
            [](const PyLayerTin& t, bool halfedges) {
                LayerTinMesh mm = read_locked(t, [](const LayerTin& l) { return l.mesh(); });
                return mesh_tuple(std::move(mm), halfedges);
            },
            py::arg("halfedges") = false,
            "(vertices (n, 3), triangles (m, 3)) of the TIN inside the study area, compacted;\n"
            "with halfedges=True also the opposite half-edges (3 m,) within the mesh (-1: none).");

    m.def(
        "build_layer_tins",
        [](const py::typing::List<py::typing::Tuple<py::str, py::object>>& layers, const py::handle& boundary,
           py::object spacing, int threads) -> py::typing::List<PyLayerTin> {
            StudyArea area = as_area(boundary, "build_layer_tins");
            if (threads < 1) throw std::invalid_argument("build_layer_tins: threads must be >= 1, got " + std::to_string(threads));
            LayerTinOptions opt;
            if (!spacing.is_none()) {
                opt.spacing = spacing.cast<double>();
                if (!(opt.spacing > 0.0 && std::isfinite(opt.spacing)))
                    throw std::invalid_argument("build_layer_tins: spacing must be a finite number > 0");
            }
            // Private copies of every layer's data (as_coordinates), read with the GIL released.
            std::vector<DoubleArray> copies;
            std::vector<LayerTinInput> in;
            copies.reserve(layers.size());
            for (std::size_t i = 0; i < layers.size(); ++i) {
                const py::object item = layers[i];
                if (!py::isinstance<py::sequence>(item) || py::isinstance<py::str>(item) || py::len(item) != 2 ||
                    !py::isinstance<py::str>(item[py::int_(0)]))
                    throw std::invalid_argument("build_layer_tins: layers[" + std::to_string(i) +
                                                "] must be a pair (name: str, data (n, 3))");
                const std::string name = item[py::int_(0)].cast<std::string>();
                const std::string what = "data of layer '" + name + "'";
                copies.push_back(as_coordinates(item[py::int_(1)], "build_layer_tins", what.c_str(), 3, 3, 2));
                in.push_back({name, copies.back().data(), static_cast<std::size_t>(copies.back().shape(0))});
            }
            std::vector<LayerTin> tins;
            {
                py::gil_scoped_release release;
                tins = build_layer_tins(in, area, opt, static_cast<unsigned>(threads));
            }
            py::typing::List<PyLayerTin> out;
            for (auto& t : tins) out.append(py::cast(std::make_unique<PyLayerTin>(std::move(t))));
            return out;
        },
        py::arg("layers"), py::arg("boundary"), py::arg("spacing") = py::none(), py::arg("threads") = 1,
        "The LayerTins of several layers over one study area: [(name, data (n, 3)), ...] ->\n"
        "[LayerTin, ...], each as LayerTin(name, data, boundary, spacing) builds it (same\n"
        "vertices, elevations and triangles; the vertex numbering may differ). The interior\n"
        "XY points all layers share are triangulated once (layer_tin.hpp). threads: layers\n"
        "set up on up to that many threads (same result; the error of the first failing layer).");

    m.def(
        "repair_stack",
        [](const py::typing::List<PyLayerTin>& layers, int max_rounds, py::object tol, int midpoint_rounds,
           double max_inserted_per_vertex, double max_above_fraction, int threads) -> py::typing::List<py::dict> {
            RepairOptions opt = repair_options("repair_stack", max_rounds, tol, midpoint_rounds,
                                               max_inserted_per_vertex, max_above_fraction);
            if (threads < 1) throw std::invalid_argument("repair_stack: threads must be >= 1, got " + std::to_string(threads));
            std::vector<PyLayerTin*> shared;
            for (std::size_t i = 0; i < layers.size(); ++i) {
                py::object item = layers[i];
                if (!py::isinstance<PyLayerTin>(item))
                    throw std::invalid_argument("repair_stack: layers[" + std::to_string(i) + "] is not a LayerTin");
                shared.push_back(&item.cast<PyLayerTin&>());
            }
            std::vector<LayerTin*> stack;
            for (PyLayerTin* p : shared) stack.push_back(&p->obj);
            std::vector<RepairCounts> counts;
            {
                // Every layer locked exclusively, once, in address order (no
                // deadlock with another call taking some of them).
                std::vector<PyLayerTin*> order = shared;
                std::sort(order.begin(), order.end());
                order.erase(std::unique(order.begin(), order.end()), order.end());
                py::gil_scoped_release release;
                std::vector<std::unique_lock<std::shared_mutex>> locks;
                for (PyLayerTin* p : order) locks.emplace_back(p->mu);
                counts = repair_stack(stack, opt, static_cast<unsigned>(threads));
            }
            py::typing::List<py::dict> out;
            for (const auto& c : counts) out.append(counts_dict(c));
            return out;
        },
        py::arg("layers"), py::arg("max_rounds") = 200, py::arg("tol") = py::none(), py::arg("midpoint_rounds") = 8,
        py::arg("max_inserted_per_vertex") = 32.0, py::arg("max_above_fraction") = 0.5,
        py::arg("threads") = 1,
        "repair_crossings down a stack, layers[i] over layers[i + 1], with the same result as pair\n"
        "after pair: every pair's first test (are they apart everywhere?) at once on up to `threads`\n"
        "threads, the full repair top down only where needed. Returns the counts of each pair.");

    m.def(
        "repair_crossings",
        [](const PyLayerTin& upper, PyLayerTin& lower, int max_rounds, py::object tol, int midpoint_rounds,
           double max_inserted_per_vertex, double max_above_fraction) {
            RepairOptions opt = repair_options("repair_crossings", max_rounds, tol, midpoint_rounds,
                                               max_inserted_per_vertex, max_above_fraction);
            RepairCounts c;
            {
                // lower changes (exclusive lock), upper is read (shared, unless it is lower);
                // the two locks are taken in address order, so that two calls with the
                // layers swapped cannot deadlock.
                py::gil_scoped_release release;
                std::unique_lock<std::shared_mutex> lock_lower(lower.mu, std::defer_lock);
                std::shared_lock<std::shared_mutex> lock_upper(upper.mu, std::defer_lock);
                if (&upper == &lower) {
                    lock_lower.lock();
                } else if (&upper.mu < &lower.mu) {
                    lock_upper.lock();
                    lock_lower.lock();
                } else {
                    lock_lower.lock();
                    lock_upper.lock();
                }
                c = repair_crossings(upper.obj, lower.obj, opt);
            }
            return counts_dict(c);
        },
        py::arg("upper"), py::arg("lower"), py::arg("max_rounds") = 200, py::arg("tol") = py::none(),
        py::arg("midpoint_rounds") = 8, py::arg("max_inserted_per_vertex") = 32.0,
        py::arg("max_above_fraction") = 0.5,
        "Make `lower` lie nowhere above `upper` (paper 3.2, Figure 6; layer_tin.hpp): rule 1,\n"
        "rule 1b and rule 2. Returns the counts {rule1, rule1b, rule2, rule2_crossing, rounds},\n"
        "data_above (the lower layer's data points above the upper surface before the repair),\n"
        "max_lowered (m, the largest lowering of a lower vertex by rule 1) and max_data_lowered\n"
        "(m, the largest lowering of one of those data points: the most the layer misses a datum by).\n"
        "Raises GeometryError if, before the repair, lower lies above upper at more than\n"
        "max_above_fraction of its data points (a wrong layer order), if crossings remain after\n"
        "max_rounds rounds, or if the lower layer needed more than max_inserted_per_vertex new\n"
        "points per vertex of the two layers (a runaway refinement).");
}

}  // namespace faultmesh::bindings
