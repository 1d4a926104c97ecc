#pragma once
// Shared helpers for the regression tests: scenes built in code, quasi-static loading runs.
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "model/model.hpp"
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
