#include "model/structured.hpp"

#include <string>

namespace fdem {

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
  return m;
}

}  // namespace fdem
