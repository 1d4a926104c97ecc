#include "model/structured.hpp"

#include <string>

namespace fdem {

namespace {

/// The box's six sides as surface groups, named and tagged as a generated box's: xmin, xmax,
/// ymin, ymax, zmin, zmax (tags 1 to 6). A side holds the tet faces whose corners lie on it.
void name_sides(int nx, int ny, int nz, Mesh& m) {
  const int last[3] = {nx, ny, nz};
  auto lattice = [&](int v, int axis) {
    const int i = v % (nx + 1), j = v / (nx + 1) % (ny + 1), k = v / ((nx + 1) * (ny + 1));
    return axis == 0 ? i : (axis == 1 ? j : k);
  };
  for (int side = 0; side < 6; ++side) {
    MeshGroup g;
    g.name = std::string(1, "xyz"[side / 2]) + (side % 2 ? "max" : "min");
    g.dim = 2;
    g.tag = side + 1;
    const int axis = side / 2, at = side % 2 ? last[axis] : 0;
    for (const auto& t : m.tets)
      for (int skip = 0; skip < 4; ++skip) {
        std::array<int, 3> f;
        int n = 0;
        for (int c = 0; c < 4; ++c)
          if (c != skip) f[n++] = t[c];
        if (lattice(f[0], axis) == at && lattice(f[1], axis) == at && lattice(f[2], axis) == at) g.faces.push_back(f);
      }
    m.groups.push_back(std::move(g));
  }
}

}  // namespace

Mesh structured_box_mesh(Vec3 size, int nx, int ny, int nz) {
  Mesh m;
  m.source = "structured box " + std::to_string(nx) + "x" + std::to_string(ny) + "x" + std::to_string(nz);
  auto id = [&](int i, int j, int k) { return (k * (ny + 1) + j) * (nx + 1) + i; };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) m.vertices.push_back({size.x * i / nx, size.y * j / ny, size.z * k / nz});
  // The six monotone lattice paths from corner 000 to 111 (one per axis permutation).
  static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        for (const auto& p : perm) {
          int c[3] = {i, j, k};
          std::array<int, 4> t;
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          m.tets.push_back(t);
        }
  name_sides(nx, ny, nz, m);
  return m;
}

}  // namespace fdem
