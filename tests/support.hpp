#pragma once
// Shared helpers for the regression tests: scenes built in code, quasi-static loading runs.
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "model/model.hpp"
#include "model/structured.hpp"
#include "scene/scene.hpp"
#include "solver/solver.hpp"

namespace fdem::test {

/// The value of E whose scene-file word is `word` (tests name choices by their words).
template <class E>
E named(const std::string& word) {
  E e{};
  if (!choice_named(word, e)) throw std::invalid_argument("not a choice: " + word);
  return e;
}

/// A scene with the Table 2 limestone and no output, for tests.
inline Scene test_scene() {
  Scene s;
  s.name = "test";
  s.file = "(test)";
  s.output.progress_interval = 0;
  s.output.plot = false;
  return s;
}

/// The InputError text of parsing scene text `yaml` (labelled `file`) and building `mesh` with
/// it, or "" when both succeed.
inline std::string build_error(const std::string& yaml, const std::string& file, const Mesh& mesh) {
  try {
    build_model(mesh, parse_scene(yaml, file));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

/// A 10 x 10 x 20 mm box (structured, 4 x 4 x 8 cells) whose volume groups 'lower' (z < 10 mm,
/// tag 1) and 'upper' (tag 2) split it at mid-height, on a plane of mesh faces.
/// `scale`: every length times it (1000: a 10 x 10 x 20 m column).
inline Mesh layered_box(real scale = 1) {
  Mesh mesh = structured_box_mesh({0.01 * scale, 0.01 * scale, 0.02 * scale}, 4, 4, 8);
  MeshGroup lower{"lower", 3, 1, {}, {}}, upper{"upper", 3, 2, {}, {}};
  for (int t = 0; t < int(mesh.tets.size()); ++t) {
    real z = 0;
    for (int v : mesh.tets[t]) z += 0.25 * mesh.vertices[v].z;
    (z < 0.01 * scale ? lower : upper).tets.push_back(t);
  }
  mesh.groups.insert(mesh.groups.begin(), {lower, upper});
  return mesh;
}

/// The layered box with its mid-plane (z = 10 mm) as the surface group 'joint' (tag 7).
inline Mesh jointed_box() {
  Mesh mesh = test::layered_box();
  MeshGroup joint{"joint", 2, 7, {}, {}};
  for (int t : mesh.groups[0].tets) {  // (the lower layer's tets: each face of the plane once)
    const auto& q = mesh.tets[t];
    for (int i = 0; i < 4; ++i) {
      std::array<int, 3> f{q[(i + 1) % 4], q[(i + 2) % 4], q[(i + 3) % 4]};
      bool on = true;
      for (int v : f) on = on && std::fabs(mesh.vertices[v].z - 0.01) < 1e-9;
      if (on) joint.faces.push_back(f);
    }
  }
  mesh.groups.push_back(joint);
  return mesh;
}

/// A 10 x 10 x 20 mm box scene (the tests build its model from their own mesh of it) on rollers at
/// xmin, ymin and zmin, its zmax moved by a velocity condition, CE6s in `fracture`, no platens
/// and no contact, one thread. The other fields are YAML text put in as they are.
struct RollerBox {
  std::string rock;  // material keys ("material: {...}\n", "materials: [...]\n"), or none
  std::string top = "velocity: [~, ~, -0.05], time_function: {table: [[0, 0], [2e-5, 1], [6e-5, 1], [8e-5, 0]]}";
  std::string extra;  // more conditions, as list entries after zmax's
  std::string fracture = "none";
  std::string backend = "cpu";
  std::string end = "time: 3e-4";
};
// (top by default: pressed down at 0.05 m/s along a table, up over 20 us, held 40 us, down over
// 20 us, so it moves 3 um in all and then rests.)

inline std::string roller_box_scene(const RollerBox& b) {
  return "name: roller_box\n"
         "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.0025}}\n" +
         b.rock + "fracture_regions: " + b.fracture +
         "\n"
         "platens: none\n"
         "contact: {activation: none}\n"
         "boundary_conditions:\n"
         "  - {surface: xmin, type: roller}\n"
         "  - {surface: ymin, type: roller}\n"
         "  - {surface: zmin, type: roller}\n"
         "  - {surface: zmax, type: velocity, " +
         b.top + "}\n" + b.extra + "solver: {threads: 1, backend: " + b.backend + ", end: {" + b.end +
         "}}\n"
         "output: {progress_interval: 0, plot: false}\n";
}

/// The largest distance between the same node in two lists of positions, m.
inline real largest_distance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  real worst = 0;
  for (std::size_t n = 0; n < a.size(); ++n) worst = std::max(worst, norm(a[n] - b[n]));
  return worst;
}

/// A gmsh cylinder (axis z) of the given diameter, height and element size, m.
inline MeshSpec cylinder(real diameter, real height, real element_size) {
  return MeshSpec::round(MeshShape::cylinder, diameter, height, element_size);
}

/// Load along z until `strain` (platen approach / height), measuring every `every` steps.
inline std::vector<Monitors> load_to_strain(Solver& solver, real strain, int every = 50) {
  std::vector<Monitors> rows{solver.measure()};
  while (solver.platen_travel() / solver.model().height0 < strain) {
    solver.step();
    if (solver.step_count() % every == 0) rows.push_back(solver.measure());
  }
  rows.push_back(solver.measure());
  return rows;
}

/// Least-squares slope of axial stress against axial strain for strains in [a, b].
inline real secant_modulus(const std::vector<Monitors>& rows, real a, real b) {
  real n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const Monitors& r : rows)
    if (r.axial_strain >= a && r.axial_strain <= b) {
      n += 1;
      sx += r.axial_strain;
      sy += r.axial_stress;
      sxx += r.axial_strain * r.axial_strain;
      sxy += r.axial_strain * r.axial_stress;
    }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

}  // namespace fdem::test
