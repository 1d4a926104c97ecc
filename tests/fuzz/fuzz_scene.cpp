// libFuzzer target: the bytes are the text of a scene file, parsed by fdem::parse_scene as
// load_scene does. The documented outcome for bad input is fdem::InputError naming the file;
// anything else (another exception such as a YAML::Exception, a crash, a sanitizer report, a
// hang, a huge allocation) is a bug. A scene that is accepted must satisfy what the solver
// relies on (checked below).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/error.hpp"
#include "scene/scene.hpp"

namespace {

const char* const kLabel = "fuzz_scene.yaml";

[[noreturn]] void invariant_broken(const char* what) {
  std::fprintf(stderr, "fuzz_scene: parse_scene accepted a scene where %s\n", what);
  std::abort();
}

bool finite_positive(double v) {
  return std::isfinite(v) && v > 0;
}

void check(const fdem::Scene& s) {
  const fdem::Material& m = s.material();
  for (double v :
       {m.density, m.youngs_modulus, m.tensile_strength, m.cohesion, m.fracture_energy_I, m.fracture_energy_II,
        m.contact_penalty, m.cohesive_penalty_open, m.cohesive_penalty_tangential, m.cohesive_penalty_overlap})
    if (!finite_positive(v)) invariant_broken("a material constant is not a positive finite number");
  // Not checked: lame_lambda() is finite (youngs_modulus has no upper bound, so 1e303 with
  // poisson_ratio 0.4999999 gives inf; a limit on the moduli is a physics decision).
  if (!(m.poisson_ratio >= 0 && m.poisson_ratio < 0.5)) invariant_broken("poisson_ratio is outside [0, 0.5)");
  const fdem::MeshSpec& mesh = s.mesh;
  if (mesh.file.empty() != mesh.generated()) invariant_broken("the mesh is neither generated nor read (or both)");
  if (mesh.generated()) {
    if (mesh.shape != fdem::MeshShape::cylinder && mesh.shape != fdem::MeshShape::disc &&
        mesh.shape != fdem::MeshShape::box)
      invariant_broken("mesh.generate.shape is unknown");
    if (!finite_positive(mesh.element_size)) invariant_broken("mesh.generate.element_size is not positive");
  } else if (!finite_positive(mesh.scale)) {
    invariant_broken("mesh.scale is not positive");
  }
  const fdem::EndCondition& e = s.solver.end;
  if (!(e.time > 0 || e.steps > 0 || e.axial_strain > 0 || e.post_peak_fraction > 0))
    invariant_broken("no end condition is set");
  if (!finite_positive(s.solver.time_step_safety) || !(s.solver.mass_scaling >= 1) || s.solver.threads < 0)
    invariant_broken("a solver setting is out of range");
  if (s.output.monitor_interval < 1 || s.output.field_interval < 0) invariant_broken("an output interval is < 1");
  for (const auto& b : s.fracture.boxes)
    for (int c = 0; c < 3; ++c)
      if (!(b.min[c] < b.max[c])) invariant_broken("a fracture region box has min >= max");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  fdem::Scene scene;
  try {
    scene = fdem::parse_scene(text, kLabel);
  } catch (const fdem::InputError& e) {
    // The documented answer to bad input; it must name the file.
    if (std::string(e.what()).find(kLabel) == std::string::npos) {
      std::fprintf(stderr, "fuzz_scene: an InputError does not name the file: %s\n", e.what());
      std::abort();
    }
    return 0;
  }
  check(scene);
  return 0;
}
