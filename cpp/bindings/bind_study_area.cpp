// Bindings for the study-area polygon: faultmesh.StudyArea.
#include <faultmesh/study_area.hpp>

#include <cmath>
#include <limits>
#include <string>

#include "common.hpp"

namespace faultmesh::bindings {

namespace {

// Positions on the boundary: side (k,) non-negative integers below n_sides,
// s (k,) finite arc lengths; private copies.
struct SidePositions {
    IndexArray side;
    DoubleArray s;
};

SidePositions as_side_positions(const StudyArea& a, const py::handle& side, const py::handle& s, const char* fn) {
    SidePositions p{as_indices(side, fn, "side", 0), as_values(s, fn, "s")};
    if (p.s.shape(0) != p.side.shape(0))
        throw std::invalid_argument(std::string(fn) + ": side and s must have one length, got " +
                                    shape_str(p.side) + " and " + shape_str(p.s));
    const std::int64_t* k = p.side.data();
    for (py::ssize_t i = 0; i < p.side.shape(0); ++i)
        if (static_cast<std::size_t>(k[i]) >= a.n_sides())
            throw std::invalid_argument(std::string(fn) + ": side[" + std::to_string(i) + "] = " + std::to_string(k[i]) +
                                        " is not a side (0.." + std::to_string(a.n_sides() - 1) + ")");
    const double* v = p.s.data();
    for (py::ssize_t i = 0; i < p.s.shape(0); ++i)
        if (!std::isfinite(v[i]))
            throw std::invalid_argument(std::string(fn) + ": s row " + std::to_string(i) + " is not finite");
    return p;
}

}  // namespace

void bind_study_area(py::module_& m) {
    py::class_<StudyArea>(m, "StudyArea",
                          "The study-area polygon: which points lie on its boundary, and points placed\n"
                          "on it (study_area.hpp). Counter-clockwise; side i runs from corner i to\n"
                          "corner i + 1. Every method takes points (k, 2) (or (k, 3): z is ignored).")
        .def(py::init([](const py::handle& ring, py::object tolerance) {
                 auto R = as_coordinates(ring, "StudyArea", "ring", 2, 2, 2);
                 const double tol = tolerance.is_none() ? -1.0 : tolerance.cast<double>();
                 if (!tolerance.is_none() && !(tol >= 0.0 && std::isfinite(tol)))
                     throw std::invalid_argument("StudyArea: tolerance must be a finite number >= 0");
                 return StudyArea(R.data(), static_cast<std::size_t>(R.shape(0)), tol);
             }),
             py::arg("ring"), py::arg("tolerance") = py::none(),
             "ring (k, 2): a simple polygon, either orientation, closing point optional.\n"
             "tolerance: distance within which a point counts as on a side (default 64 eps\n"
             "max|coordinate|: the rounding of points constructed on a side).")
        .def_property_readonly("ring",
                               [](const StudyArea& a) {
                                   std::vector<double> r = a.ring();
                                   return to_numpy(std::move(r), 2);
                               },
                               "(k, 2) corners, counter-clockwise")
        .def_property_readonly("n_sides", &StudyArea::n_sides)
        .def_property_readonly("tolerance", &StudyArea::tolerance)
        .def_property_readonly("perimeter", &StudyArea::perimeter)
        .def(
            "contains",
            [](const StudyArea& a, const py::handle& points) {
                auto P = as_coordinates(points, "StudyArea.contains", "points", 2, 3, 2);
                const std::size_t n = static_cast<std::size_t>(P.shape(0)), st = static_cast<std::size_t>(P.shape(1));
                py::array_t<bool> out(static_cast<py::ssize_t>(n));
                auto o = out.mutable_unchecked<1>();
                for (std::size_t i = 0; i < n; ++i) o(static_cast<py::ssize_t>(i)) = a.contains(P.data() + st * i);
                return out;
            },
            py::arg("points"), "True for points inside or on the boundary (exact winding).")
        .def(
            "on_boundary",
            [](const StudyArea& a, const py::handle& points) {
                auto P = as_coordinates(points, "StudyArea.on_boundary", "points", 2, 3, 2);
                const std::size_t n = static_cast<std::size_t>(P.shape(0)), st = static_cast<std::size_t>(P.shape(1));
                py::array_t<bool> out(static_cast<py::ssize_t>(n));
                auto o = out.mutable_unchecked<1>();
                for (std::size_t i = 0; i < n; ++i)
                    o(static_cast<py::ssize_t>(i)) = a.on_boundary(P.data() + st * i);
                return out;
            },
            py::arg("points"), "True for points on a side (exactly or within the tolerance).")
        .def(
            "locate",
            [](const StudyArea& a, const py::handle& points) {
                auto P = as_coordinates(points, "StudyArea.locate", "points", 2, 3, 2);
                const std::size_t n = static_cast<std::size_t>(P.shape(0)), st = static_cast<std::size_t>(P.shape(1));
                std::vector<std::int64_t> side(n, -1);
                std::vector<double> s(n, std::numeric_limits<double>::quiet_NaN());
                std::vector<StudyArea::Hit> hits;
                for (std::size_t i = 0; i < n; ++i) {
                    a.locate(P.data() + st * i, hits);
                    if (hits.empty()) continue;
                    // A corner is reported on the side that starts there.
                    StudyArea::Hit h = hits[0];
                    for (const auto& x : hits)
                        if (x.s == 0.0) h = x;
                    if (h.s >= a.side_length(h.side)) h = {(h.side + 1) % a.n_sides(), 0.0};
                    side[i] = static_cast<std::int64_t>(h.side);
                    s[i] = h.s;
                }
                return py::make_tuple(to_numpy(std::move(side)), to_numpy(std::move(s)));
            },
            py::arg("points"),
            "(side (k,) int64, s (k,)): the side each point lies on (-1: not on the boundary;\n"
            "a corner gives the side that starts there) and the arc length along it.")
        .def(
            "nearest",
            [](const StudyArea& a, const py::handle& points, double max_distance) {
                auto P = as_coordinates(points, "StudyArea.nearest", "points", 2, 3, 2);
                if (!(max_distance >= 0.0))
                    throw std::invalid_argument("StudyArea.nearest: max_distance must be >= 0");
                const std::size_t n = static_cast<std::size_t>(P.shape(0)), st = static_cast<std::size_t>(P.shape(1));
                std::vector<std::int64_t> side(n, -1);
                std::vector<double> s(n, std::numeric_limits<double>::quiet_NaN());
                std::vector<double> d(n, std::numeric_limits<double>::infinity());
                for (std::size_t i = 0; i < n; ++i) {
                    const auto h = a.nearest(P.data() + st * i, max_distance);
                    if (!h.found) continue;
                    side[i] = static_cast<std::int64_t>(h.side);
                    s[i] = h.s;
                    d[i] = h.distance;
                }
                return py::make_tuple(to_numpy(std::move(side)), to_numpy(std::move(s)), to_numpy(std::move(d)));
            },
            py::arg("points"), py::arg("max_distance") = std::numeric_limits<double>::infinity(),
            "(side, s, distance) of the nearest boundary point within max_distance (side -1 if none).")
        .def(
            "place",
            [](const StudyArea& a, const py::handle& side, const py::handle& s) {
                const SidePositions p = as_side_positions(a, side, s, "StudyArea.place");
                const std::size_t n = static_cast<std::size_t>(p.side.shape(0));
                std::vector<double> out(2 * n);
                for (std::size_t i = 0; i < n; ++i)
                    a.place(static_cast<std::size_t>(p.side.data()[i]), p.s.data()[i], out.data() + 2 * i);
                return to_numpy(std::move(out), 2);
            },
            py::arg("side"), py::arg("s"),
            "(k, 2) points at arc length s along the sides: corners exact at the ends, the\n"
            "constant coordinate exact on axis-parallel sides.")
        .def(
            "arc_position",
            [](const StudyArea& a, const py::handle& side, const py::handle& s) {
                const SidePositions p = as_side_positions(a, side, s, "StudyArea.arc_position");
                const std::size_t n = static_cast<std::size_t>(p.side.shape(0));
                std::vector<double> out(n);
                for (std::size_t i = 0; i < n; ++i)
                    out[i] = a.arc_position({static_cast<std::size_t>(p.side.data()[i]), p.s.data()[i]});
                return to_numpy(std::move(out));
            },
            py::arg("side"), py::arg("s"), "Arc position from corner 0, in [0, perimeter).")
        .def(
            "ray_hit",
            [](const StudyArea& a, const py::handle& points, const py::handle& directions) {
                auto P = as_coordinates(points, "StudyArea.ray_hit", "points", 2, 3, 2);
                auto D = as_coordinates(directions, "StudyArea.ray_hit", "directions", 2, 3, 2);
                const std::size_t n = static_cast<std::size_t>(P.shape(0)), st = static_cast<std::size_t>(P.shape(1));
                const std::size_t m = static_cast<std::size_t>(D.shape(0)), sd = static_cast<std::size_t>(D.shape(1));
                if (m != n && m != 1)
                    throw std::invalid_argument("StudyArea.ray_hit: directions must have 1 or " +
                                                std::to_string(n) + " rows, got " + std::to_string(m));
                std::vector<double> t(n), s(n), xy(2 * n);
                std::vector<std::int64_t> side(n, -1);
                for (std::size_t i = 0; i < n; ++i) {
                    const auto h = a.ray_hit(P.data() + st * i, D.data() + sd * (m == 1 ? 0 : i));
                    t[i] = h.t;
                    if (std::isinf(h.t)) {
                        s[i] = xy[2 * i] = xy[2 * i + 1] = std::numeric_limits<double>::quiet_NaN();
                        continue;
                    }
                    side[i] = static_cast<std::int64_t>(h.side);
                    s[i] = h.s;
                    if (h.t == 0.0) {
                        xy[2 * i] = P.data()[st * i];
                        xy[2 * i + 1] = P.data()[st * i + 1];
                    } else {
                        a.place(h.side, h.s, xy.data() + 2 * i);
                    }
                }
                return py::make_tuple(to_numpy(std::move(t)), to_numpy(std::move(side)), to_numpy(std::move(s)),
                                      to_numpy(std::move(xy), 2));
            },
            py::arg("points"), py::arg("directions"),
            "(t, side, s, xy) of the first boundary point on each ray p + t d (t >= 0): t = 0\n"
            "and xy = p for a point on the boundary; t = inf (side -1, NaN) for a miss. The hit\n"
            "is placed on its side (place), not computed as p + t d.")
        .def(
            "clip_surface",
            [](const StudyArea& a, const py::handle& vertices, const py::handle& triangles, const std::string& what) {
                const char* fn = "StudyArea.clip_surface";
                auto V = as_coordinates(vertices, fn, "vertices", 3, 3, 3);
                auto T = as_indices(triangles, fn, "triangles", 3, V.shape(0));
                ClippedSurface c;
                {
                    py::gil_scoped_release release;
                    c = clip_to_study_area(a, V.data(), static_cast<std::size_t>(V.shape(0)), T.data(),
                                           static_cast<std::size_t>(T.shape(0)), what);
                }
                return py::make_tuple(to_numpy(std::move(c.vertices), 3), to_numpy(std::move(c.triangles), 3),
                                      to_numpy(std::move(c.vertex_of)), c.n_cut, c.n_dropped);
            },
            py::arg("vertices"), py::arg("triangles"), py::arg("what") = "surface",
            "(vertices (k, 3), triangles (m, 3), vertex_of (k,), n_cut, n_dropped): the surface\n"
            "clipped to the study area in XY, triangle by triangle (clip_to_study_area in\n"
            "study_area.hpp): the part inside kept, cut exactly where a side crosses it, new\n"
            "vertices placed on their sides with z interpolated; vertex_of gives each output\n"
            "vertex's input row (-1: new). Orientation kept (folded sheets too).");
}

}  // namespace faultmesh::bindings
