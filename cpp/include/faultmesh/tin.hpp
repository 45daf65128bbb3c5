// faultmesh/tin.hpp -- a triangulated irregular network (TIN) that grows.
//
// A Tin is the Delaunay triangulation of points in XY with an elevation z per
// vertex (paper section 2.3). New points are inserted into the existing
// triangulation one by one (paper 2.3.2: new data enter the TIN without
// rebuilding it); because the triangulation is canonical (see delaunay.hpp),
// a Tin grown by insert() has exactly the triangles a Tin built from all the
// points at once would have.
//
// Vertices are numbered in order of first appearance: the distinct points of
// the constructor's input, then every new distinct point of each insert().
// Duplicate policy: a point whose XY equals an existing vertex (or an earlier
// point of the same input) does not create a vertex; the existing vertex and
// its z are kept unchanged, and the point is reported as mapping to it
// (vertex_of_input() for the constructor, the return value of insert()).
//
// Only x and y must be finite; z may be NaN (a layer without a value there).
//
// Triangle indices (triangles(), halfedges(), locate()) refer to the compacted
// list of finite triangles and are valid until the next insert(). insert()
// only marks that numbering stale; the first reader after it rebuilds it
// (O(triangles) once), so inserting point by point costs a walk and a cavity
// per point, however large the TIN.
//
// Thread safety: const member functions may run concurrently (the lazy
// rebuild is internally synchronised); insert() and set_z() must not run
// concurrently with anything else on the same Tin.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace faultmesh {

namespace detail {
struct TinImpl;
}

class Tin {
public:
    // n points interleaved as x0, y0, z0, x1, y1, z1, ... Throws
    // std::invalid_argument for a NaN/inf x or y or one beyond kMaxCoordinate
    // (predicates.hpp; naming the row) and
    // GeometryError for fewer than 3 distinct points or all-collinear XY.
    Tin(const double* xyz, std::size_t n);
    ~Tin();
    Tin(Tin&&) noexcept;
    Tin& operator=(Tin&&) noexcept;
    Tin(const Tin&);
    // A copy with room for extra_vertices more vertices: inserting them
    // then reallocates (and copies) none of the arrays.
    Tin(const Tin& other, std::size_t extra_vertices);
    Tin& operator=(const Tin&);

    // Inserts n points (x, y, z interleaved) and returns, for each, the index of
    // the vertex it maps to (a new vertex, or the existing one of equal XY).
    // Throws std::invalid_argument for a NaN/inf x or y before changing anything.
    std::vector<std::int64_t> insert(const double* xyz, std::size_t n);

    // Sets the z of n vertices (vertices[i] gets z[i]; later entries win for a
    // repeated vertex). The triangulation depends on XY only and is unchanged.
    // Throws std::invalid_argument naming the entry if an index is out of
    // range, before changing anything.
    void set_z(const std::int64_t* vertices, const double* z, std::size_t n);

    std::size_t n_vertices() const;
    std::size_t n_triangles() const;
    // For each point of the constructor's input: the vertex it maps to.
    const std::vector<std::int64_t>& vertex_of_input() const;
    // Number of input points (constructor and inserts) merged into an existing vertex.
    std::size_t n_duplicates() const;

    std::vector<double> vertices() const;          // 3 per vertex: x, y, z
    std::vector<std::int64_t> triangles() const;   // 3 per triangle, CCW, vertex indices
    std::vector<std::int64_t> halfedges() const;   // opposite half-edge or -1 (hull), as in DelaunayResult
    // triangles() and halfedges() in one pass (either pointer may be null).
    void mesh(std::vector<std::int64_t>* triangles, std::vector<std::int64_t>* halfedges) const;
    // The vertices (3 per vertex) without a copy; valid until the next
    // insert() or set_z().
    const std::vector<double>& vertex_array() const;

    // Index of a triangle whose closed region contains (x, y), or -1 if the
    // point is outside the convex hull.
    std::int64_t locate(double x, double y) const;
    // Batched locate of n points (x, y interleaved); queries are walked in
    // Hilbert order internally, results are in input order.
    std::vector<std::int64_t> locate(const double* xy, std::size_t n) const;
    // z at n points (x, y interleaved) by linear interpolation in the containing
    // triangle; NaN outside the convex hull (and for NaN queries or queries
    // beyond kMaxCoordinate). Containment and weights come from the exact
    // predicates (the three orient2d values normalised by their sum): z is a
    // convex combination, exact at a vertex, on an edge from the edge's two
    // vertices only, never outside the triangle's z range, never NaN from the
    // geometry (a NaN z of a contributing vertex gives NaN).
    std::vector<double> interpolate(const double* xy, std::size_t n) const;

private:
    std::unique_ptr<detail::TinImpl> impl_;
};

}  // namespace faultmesh
