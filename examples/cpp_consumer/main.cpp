// Triangulates the points of a whitespace-separated "x y" file (or a built-in
// square with its centre) and prints the triangle count and the triangles.
#include <faultmesh/delaunay.hpp>
#include <faultmesh/errors.hpp>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <vector>

int main(int argc, char** argv) {
    std::vector<double> xy;
    if (argc > 1) {
        std::ifstream in(argv[1]);
        if (!in) {
            std::cerr << "cannot open " << argv[1] << "\n";
            return 2;
        }
        double x, y;
        while (in >> x >> y) {
            xy.push_back(x);
            xy.push_back(y);
        }
    } else {
        xy = {0, 0, 1, 0, 1, 1, 0, 1, 0.5, 0.5};
    }
    try {
        const faultmesh::DelaunayResult d = faultmesh::delaunay(xy.data(), xy.size() / 2);
        std::printf("triangles %zu\n", d.triangles.size() / 3);
        for (std::size_t t = 0; t < d.triangles.size(); t += 3)
            std::printf("%lld %lld %lld\n", static_cast<long long>(d.triangles[t]),
                        static_cast<long long>(d.triangles[t + 1]), static_cast<long long>(d.triangles[t + 2]));
    } catch (const faultmesh::GeometryError& e) {
        std::cerr << "geometry error: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
