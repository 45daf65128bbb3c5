// faultmesh._core: the pybind11 module. Each algorithm has its own binding
// file (bind_<algorithm>.cpp) that registers its functions here.
#include <faultmesh/errors.hpp>

#include "common.hpp"

namespace faultmesh::bindings {
void bind_predicates(py::module_& m);
void bind_delaunay(py::module_& m);
void bind_aabb_tree(py::module_& m);
void bind_overlap(py::module_& m);
void bind_boundary(py::module_& m);
void bind_ear_clipping(py::module_& m);
void bind_loft(py::module_& m);
void bind_stitch(py::module_& m);
void bind_cutting(py::module_& m);
void bind_study_area(py::module_& m);
void bind_layer_tin(py::module_& m);
void bind_surface_sampling(py::module_& m);
void bind_fault_side(py::module_& m);
void bind_patch_data(py::module_& m);
void bind_nearest_segment(py::module_& m);
}  // namespace faultmesh::bindings

PYBIND11_MODULE(_core, m) {
    namespace fb = faultmesh::bindings;
    m.doc() = "faultmesh C++ kernels (exact predicates, Delaunay, AABB overlap, "
              "boundary loops, ear clipping, lofting, stitching)";
    m.attr("__version__") = FAULTMESH_VERSION;
    // GeometryError is a ValueError so callers that catch ValueError see it too.
    auto& geometry_error =
        pybind11::register_exception<faultmesh::GeometryError>(m, "GeometryError", PyExc_ValueError);
    // PatchOverlapError (a GeometryError) carries the names of what overlaps:
    // .layer, .patch, .other (errors.hpp).
    static pybind11::exception<faultmesh::PatchOverlapError> patch_overlap(m, "PatchOverlapError",
                                                                          geometry_error.ptr());
    pybind11::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const faultmesh::PatchOverlapError& e) {
            pybind11::object inst = pybind11::reinterpret_borrow<pybind11::object>(patch_overlap.ptr())(e.what());
            inst.attr("layer") = e.layer;
            inst.attr("patch") = e.patch;
            inst.attr("other") = e.other;
            PyErr_SetObject(patch_overlap.ptr(), inst.ptr());
        }
    });
    fb::bind_predicates(m);
    fb::bind_delaunay(m);
    fb::bind_aabb_tree(m);
    fb::bind_overlap(m);
    fb::bind_boundary(m);
    fb::bind_ear_clipping(m);
    fb::bind_loft(m);
    // A class is registered before the signatures that name it (the stub and
    // help() show its name): StudyArea before LayerTin before Stitcher.
    fb::bind_study_area(m);
    fb::bind_layer_tin(m);
    fb::bind_stitch(m);
    fb::bind_cutting(m);
    fb::bind_surface_sampling(m);
    fb::bind_fault_side(m);
    fb::bind_patch_data(m);
    fb::bind_nearest_segment(m);
}
