#pragma once
// Scenes and comparisons shared by the backend tests: tests/regression/test_backends.cpp (the
// debug backend against the CPU backend, everywhere) and tests/gpu/test_cuda_backend.cpp (CUDA
// against the CPU backend, where a GPU exists).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "model/structured.hpp"
#include "support.hpp"

namespace fdem::test {

/// A structured 6 x 6 x 12 mm box (3 x 3 x 6 cells, 324 tets) between platens at 0.5 m/s:
/// elastic over the first steps.
inline Scene backend_elastic_scene(const std::string& backend) {
  Scene s = test_scene();
  s.solver.backend = named<Backend>(backend);
  s.solver.threads = 1;
  s.platens.velocity = 0.5;
  s.contact.activation = Activation::none;
  return s;
}

/// The same box loaded fast (4 m/s) with weak CE6s, adaptive contact and a constant 0.2 MPa confining
/// pressure: damage, breaking, activation, broad phase, narrow phase and friction all run.
inline Scene backend_fracture_scene(const std::string& backend) {
  Scene s = backend_elastic_scene(backend);
  s.platens.velocity = 4.0;
  s.material().tensile_strength = 0.3e6;
  s.material().cohesion = 1.0e6;
  s.contact.activation = Activation::adaptive;
  s.confinement.enabled = true;
  s.confinement.pressure = 0.2e6;
  s.confinement.path = ConfinementPath::constant;
  s.solver.max_energy_error = 0;  // violent on purpose (see test_determinism)
  return s;
}

/// Environment variable `name` set to `value` while in scope (left unset where value is null),
/// unset after: the settings a solver reads when it makes its device loop, such as
/// FDEM_DEVICE_SCHEDULE (colour, or auto: fused where the mesh allows) and FDEM_GPU_AWARE_MPI.
struct EnvSetting {
  EnvSetting(const char* name, const char* value) : name_(name) {
    if (value) setenv(name, value, 1);
  }
  ~EnvSetting() { unsetenv(name_); }
  EnvSetting(const EnvSetting&) = delete;
  EnvSetting& operator=(const EnvSetting&) = delete;

 private:
  const char* name_;
};

/// The 3 x 3 x 6 box's solver of scene s. A cpu solver runs its default schedule, the colour
/// passes, whatever FDEM_DEVICE_SCHEDULE says, so that a debug run of another schedule is held
/// against the colour passes.
inline std::unique_ptr<Solver> backend_solver(const Scene& s) {
  const char* set = std::getenv("FDEM_DEVICE_SCHEDULE");
  const std::string schedule = set ? set : "";
  const bool unset = set && s.solver.backend == Backend::cpu;
  if (unset) unsetenv("FDEM_DEVICE_SCHEDULE");
  auto solver = std::make_unique<Solver>(s, build_model(structured_box_mesh({0.006, 0.006, 0.012}, 3, 3, 6), s));
  if (unset) setenv("FDEM_DEVICE_SCHEDULE", schedule.c_str(), 1);
  return solver;
}

/// The elastic box with gravity, a confining pressure on `path` (hydrostatic: it follows the
/// measured axial stress, up to 2 MPa; constant: it rises to 2 MPa) and node 0 held at a
/// prescribed horizontal velocity, given in two calls (x and y, then x again: (0.015, -0.02)
/// m/s, z free).
inline std::unique_ptr<Solver> backend_gravity_solver(const std::string& backend,
                                                      const std::string& path = "hydrostatic") {
  Scene s = backend_elastic_scene(backend);
  s.gravity = {0, 0, -9.81};
  s.confinement.enabled = true;
  s.confinement.pressure = 2e6;
  s.confinement.path = named<ConfinementPath>(path);
  auto solver = backend_solver(s);
  solver->prescribe(0, 0b011, Vec3{0.01, -0.02, 0});
  solver->prescribe(0, 0b001, Vec3{0.015, 7, 7});  // the 7s are not prescribed
  return solver;
}

/// True when two arrays (of nodes, or of plain structs without padding) hold the same bits.
template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

/// Largest |a - b| / max(|a|, |b|, floor) over the components of two node arrays.
inline real max_rel_diff(const std::vector<Vec3>& a, const std::vector<Vec3>& b, real floor) {
  real m = a.size() == b.size() ? 0 : 1e300;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    for (int d = 0; d < 3; ++d) {
      const real s = std::max({std::fabs(a[i][d]), std::fabs(b[i][d]), floor});
      const real r = std::fabs(a[i][d] - b[i][d]) / s;
      m = std::max(m, std::isfinite(r) ? r : real(1e300));
    }
  return m;
}

/// The largest node force magnitude, N (a scale for comparing forces).
inline real max_force(const std::vector<Vec3>& f) {
  real m = 0;
  for (const Vec3& v : f) m = std::max(m, norm(v));
  return m;
}

/// Peak axial stress (Pa) and broken CE6 count of a run of `steps` steps, measured every 50.
struct FractureResult {
  real peak = 0;
  long broken = 0;
};
inline FractureResult run_fracture(Solver& s, int steps) {
  FractureResult r;
  for (int i = 0; i < steps; ++i) {
    s.step();
    if (s.step_count() % 50 == 0) {
      const Monitors m = s.measure();
      r.peak = std::max(r.peak, m.axial_stress);
      r.broken = m.broken;
    }
  }
  return r;
}

/// The contact flags a run should have (adaptive activation): those of a run of the same scene
/// that has not started (the tets at the loaded ends), raised around every CE6 that `run` has
/// broken (ContactSet::activate_ce6), their faces released. `run` synchronised to the host
/// (sync_host).
inline std::vector<std::uint8_t> flags_from_breaks(const Solver& run) {
  Scene scene = run.scene();
  scene.solver.backend = Backend::cpu;
  std::unique_ptr<Solver> start = backend_solver(scene);
  for (std::size_t c = 0; c < run.state.ce6.size(); ++c)
    if (run.state.ce6[c].mode != 0) start->contacts.activate_ce6(start->model(), int(c));
  return start->contacts.tet_flags;
}

}  // namespace fdem::test
