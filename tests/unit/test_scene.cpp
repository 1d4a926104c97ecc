// Scene files: the default scene, defaults of a minimal scene, and one test per kind of bad input.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "core/error.hpp"
#include "scene/scene.hpp"

#ifndef FDEM_TEST_DATA
#define FDEM_TEST_DATA "/work/main/tests/data"
#endif
#ifndef FDEM_SOURCE_DIR
#define FDEM_SOURCE_DIR FDEM_TEST_DATA "/../.."
#endif

using namespace fdem;

namespace {

const std::string kData = FDEM_TEST_DATA;

/// The message of the InputError that loading `path` throws ("" if none is thrown).
std::string load_error(const std::string& path) {
  try {
    load_scene(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

std::string parse_error(const std::string& text, const std::string& file = "mem.yaml") {
  try {
    parse_scene(text, file);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Scene, EveryShippedSceneParsesWithSiValues) {
  namespace fs = std::filesystem;
  int n = 0, lab = 0;
  for (const auto& e : fs::directory_iterator(fs::path(FDEM_SOURCE_DIR) / "scenes")) {
    if (e.path().extension() != ".yaml") continue;
    const Scene s = load_scene(e.path().string());
    ++n;
    EXPECT_EQ(s.name, e.path().stem().string());
    EXPECT_EQ(s.output.folder, "out/" + s.name) << e.path();
    if (!s.mesh.generated()) {  // a rock-engineering model from its .geo, lengths in m too
      EXPECT_TRUE(fs::exists(s.mesh.file)) << e.path();
      EXPECT_GT(s.mesh.element_size, 0.001) << e.path();
      EXPECT_LT(s.mesh.element_size, 10) << e.path();
      continue;
    }
    ++lab;
    // Lengths in m: a laboratory specimen is centimetres, not millimetres or metres.
    EXPECT_GT(s.mesh.diameter, 0.01) << e.path();
    EXPECT_LT(s.mesh.diameter, 0.2) << e.path();
    EXPECT_GT(s.mesh.element_size, 0.0005) << e.path();
    EXPECT_LT(s.mesh.element_size, s.mesh.diameter / 4) << e.path();
    EXPECT_LE(s.platens.velocity, 0.2) << e.path() << ": the paper's quasi-static limit";
  }
  EXPECT_GE(lab, 4);
  EXPECT_GT(n, lab) << "and a model read from its .geo";
  const Scene paper = load_scene(std::string(FDEM_SOURCE_DIR) + "/scenes/ucs_paper.yaml");
  EXPECT_DOUBLE_EQ(paper.mesh.diameter, 0.057);
  EXPECT_DOUBLE_EQ(paper.mesh.height, 0.129);
  EXPECT_DOUBLE_EQ(paper.mesh.element_size, 0.00129);
  EXPECT_DOUBLE_EQ(paper.mesh.optimize_threshold, 0.5);  // a larger stable step (docs/scene-format.md)
  EXPECT_EQ(paper.mesh.smoothing, 20);
  EXPECT_DOUBLE_EQ(paper.solver.mass_scaling, 5);
}

TEST(Scene, TheHeterogeneousUcsIsTheDefaultSceneWithWeibullStrengths) {
  const Scene h = load_scene(std::string(FDEM_SOURCE_DIR) + "/scenes/ucs_heterogeneous.yaml");
  const Scene s = load_scene(std::string(FDEM_SOURCE_DIR) + "/scenes/ucs_small.yaml");
  EXPECT_EQ(h.material().heterogeneity.distribution, StrengthSpread::weibull);
  EXPECT_DOUBLE_EQ(h.material().heterogeneity.modulus, 6);
  EXPECT_EQ(h.material().heterogeneity.seed, 1u);
  EXPECT_DOUBLE_EQ(h.material().tensile_strength, s.material().tensile_strength);
  EXPECT_DOUBLE_EQ(h.mesh.element_size, s.mesh.element_size);
  EXPECT_DOUBLE_EQ(h.platens.velocity, s.platens.velocity);
  EXPECT_EQ(h.output.folder, "out/ucs_heterogeneous");
}

TEST(Scene, DefaultSceneParses) {
  const Scene s = load_scene(std::string(FDEM_SOURCE_DIR) + "/scenes/ucs_small.yaml");
  EXPECT_EQ(s.name, "ucs_small");
  const Material def;
  EXPECT_DOUBLE_EQ(s.material().density, def.density);
  EXPECT_DOUBLE_EQ(s.material().youngs_modulus, 12.2e9);
  EXPECT_DOUBLE_EQ(s.material().cohesive_penalty_overlap, 12200e9);
  EXPECT_EQ(s.material().softening, Softening::munjiza);
  EXPECT_EQ(s.mesh.shape, MeshShape::cylinder);
  EXPECT_TRUE(s.mesh.file.empty());
  EXPECT_DOUBLE_EQ(s.mesh.diameter, 0.02);
  EXPECT_DOUBLE_EQ(s.mesh.height, 0.04);
  EXPECT_DOUBLE_EQ(s.mesh.element_size, 0.003);
  EXPECT_TRUE(s.fracture.everywhere);
  EXPECT_TRUE(s.fracture.boxes.empty());
  EXPECT_TRUE(s.platens.enabled);
  EXPECT_DOUBLE_EQ(s.platens.velocity, 0.1);
  EXPECT_DOUBLE_EQ(s.platens.ramp_time, 0);
  EXPECT_EQ(s.contact.activation, Activation::adaptive);
  EXPECT_DOUBLE_EQ(s.contact.buffer, 0);
  EXPECT_DOUBLE_EQ(s.gravity.z, 0);
  EXPECT_DOUBLE_EQ(s.solver.mass_scaling, 5);
  EXPECT_DOUBLE_EQ(s.solver.time_step_safety, 0.9);
  EXPECT_DOUBLE_EQ(s.solver.end.axial_strain, 0.006);
  EXPECT_DOUBLE_EQ(s.solver.end.post_peak_fraction, 0.3);
  EXPECT_DOUBLE_EQ(s.solver.end.time, 0);
  EXPECT_EQ(s.solver.end.steps, 0);
  EXPECT_EQ(s.output.folder, "out/ucs_small");
  EXPECT_EQ(s.output.monitor_interval, 50);
  EXPECT_EQ(s.output.field_interval, 0);
  EXPECT_TRUE(s.output.plot);
}

TEST(Scene, MinimalSceneGetsTable2Defaults) {
  const Scene s = load_scene(kData + "/scenes/minimal.yaml");
  EXPECT_EQ(s.name, "minimal");  // the file stem
  const Material& m = s.material();
  EXPECT_DOUBLE_EQ(m.density, 1800);
  EXPECT_DOUBLE_EQ(m.youngs_modulus, 12.2e9);
  EXPECT_DOUBLE_EQ(m.poisson_ratio, 0.25);
  EXPECT_DOUBLE_EQ(m.tensile_strength, 1.2e6);
  EXPECT_DOUBLE_EQ(m.cohesion, 4.2e6);
  EXPECT_DOUBLE_EQ(m.friction_angle, 25);
  EXPECT_DOUBLE_EQ(m.fracture_energy_I, 2.0);
  EXPECT_DOUBLE_EQ(m.fracture_energy_II, 26.5);
  EXPECT_DOUBLE_EQ(m.contact_penalty, 122e9);
  EXPECT_DOUBLE_EQ(m.cohesive_penalty_open, 1220e9);
  EXPECT_DOUBLE_EQ(m.cohesive_penalty_tangential, 1220e9);
  EXPECT_DOUBLE_EQ(m.cohesive_penalty_overlap, 12200e9);
  EXPECT_DOUBLE_EQ(m.friction_platen, 0.1);
  EXPECT_DOUBLE_EQ(m.friction_rock, 0.5);
  EXPECT_EQ(m.softening, Softening::munjiza);
  EXPECT_DOUBLE_EQ(s.mesh.optimize_threshold, 0.3);  // gmsh's own default
  EXPECT_EQ(s.mesh.smoothing, 5);
  const Platens pl;
  EXPECT_TRUE(s.platens.enabled);
  EXPECT_DOUBLE_EQ(s.platens.velocity, pl.velocity);
  EXPECT_TRUE(s.fracture.everywhere);
  const SolverSettings so;
  EXPECT_DOUBLE_EQ(s.solver.time_step_safety, so.time_step_safety);
  EXPECT_DOUBLE_EQ(s.solver.mass_scaling, so.mass_scaling);
  EXPECT_DOUBLE_EQ(s.solver.damping_scale, so.damping_scale);
  EXPECT_EQ(s.solver.threads, 0);
  EXPECT_EQ(s.solver.end.steps, 1000);
  EXPECT_EQ(s.output.folder, "out/minimal");  // default: out/<name>
  EXPECT_EQ(s.output.monitor_interval, 100);
  EXPECT_TRUE(s.output.plot);
  // Stability watch and checkpoints: on by default (10 % energy error; every 30 min of wall time).
  EXPECT_DOUBLE_EQ(s.solver.max_energy_error, 0.1);
  EXPECT_EQ(s.output.checkpoint_interval, 0);
  EXPECT_DOUBLE_EQ(s.output.checkpoint_wall_interval, 1800);
}

TEST(Scene, CheckpointAndEnergyWatchKeysAreRead) {
  const Scene s = parse_scene(
      "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.005}}\n"
      "solver: {max_energy_error: 0, end: {steps: 10}}\n"
      "output: {checkpoint_interval: 500, checkpoint_wall_interval: 0}\n",
      "mem.yaml");
  EXPECT_DOUBLE_EQ(s.solver.max_energy_error, 0);
  EXPECT_EQ(s.output.checkpoint_interval, 500);
  EXPECT_DOUBLE_EQ(s.output.checkpoint_wall_interval, 0);
}

TEST(Scene, MeshFileRelativeToSceneFolderWithRegions) {
  const Scene s = load_scene(kData + "/scenes/from_file.yaml");
  EXPECT_EQ(s.name, "tiny_from_file");
  EXPECT_FALSE(s.mesh.generated());
  EXPECT_EQ(s.mesh.file, kData + "/scenes/tiny.msh");
  EXPECT_DOUBLE_EQ(s.mesh.scale, 1e-3);
  EXPECT_FALSE(s.platens.enabled);
  EXPECT_FALSE(s.fracture.everywhere);
  ASSERT_EQ(s.fracture.boxes.size(), 2u);
  EXPECT_DOUBLE_EQ(s.fracture.boxes[1].min.x, -1);
  EXPECT_DOUBLE_EQ(s.fracture.boxes[1].max.z, 0.2);
  EXPECT_DOUBLE_EQ(s.solver.end.time, 1e-3);
  EXPECT_FALSE(s.output.plot);
  EXPECT_DOUBLE_EQ(s.output.progress_interval, 0);
}

TEST(Scene, MeshOptimisationKeysAreRead) {
  const Scene s = parse_scene(
      "mesh: {generate: {shape: cylinder, diameter: 0.02, height: 0.04, element_size: 0.004, "
      "optimize_threshold: 0.5, smoothing: 20}}\n"
      "solver: {end: {steps: 10}}\n",
      "mem.yaml");
  EXPECT_DOUBLE_EQ(s.mesh.optimize_threshold, 0.5);
  EXPECT_EQ(s.mesh.smoothing, 20);
}

TEST(Scene, BoxAndNoFractureRegions) {
  const Scene s = load_scene(kData + "/scenes/box.yaml");
  EXPECT_EQ(s.mesh.shape, MeshShape::box);
  EXPECT_DOUBLE_EQ(s.mesh.size.y, 0.02);
  EXPECT_DOUBLE_EQ(s.mesh.size.z, 0.03);
  EXPECT_FALSE(s.fracture.everywhere);
  EXPECT_TRUE(s.fracture.boxes.empty());
  EXPECT_DOUBLE_EQ(s.platens.velocity, 0.05);
  EXPECT_DOUBLE_EQ(s.platens.ramp_time, 1e-4);
  EXPECT_EQ(s.solver.end.steps, 50000);
}

TEST(Scene, ParseFromTextLabelsMessages) {
  const Scene s = parse_scene(
      "mesh: {generate: {shape: disc, diameter: 0.05, height: 0.025, element_size: 0.002}}\n"
      "solver: {end: {time: 0.01}}\n",
      "brazilian.yaml");
  EXPECT_EQ(s.name, "brazilian");
  EXPECT_EQ(s.file, "brazilian.yaml");
  EXPECT_EQ(s.mesh.shape, MeshShape::disc);
  const std::string msg = parse_error(
      "mesh: {generate: {shape: disc, diameter: 0.05, height: 0.025, "
      "element_size: 0.002}}\nsolver: {end: {time: -1}}\n");
  EXPECT_NE(msg.find("mem.yaml: solver.end.time: -1 is out of range; allowed time >= 0"), std::string::npos) << msg;
}

TEST(Scene, MessageFormatMatchesTheContract) {
  const std::string f = kData + "/bad_scenes/poisson_half.yaml";
  EXPECT_EQ(load_error(f), f + ": material.poisson_ratio: 0.5 is out of range; allowed 0 <= poisson_ratio < 0.5");
}

TEST(Scene, TypoGetsASuggestion) {
  const std::string msg = load_error(kData + "/bad_scenes/typo_key.yaml");
  EXPECT_NE(msg.find("did you mean 'density'?"), std::string::npos) << msg;
  EXPECT_NE(msg.find("youngs_modulus"), std::string::npos) << msg;  // lists the allowed keys
}

TEST(Scene, AllErrorsAreCollected) {
  const std::string msg = load_error(kData + "/bad_scenes/many_errors.yaml");
  for (const char* key : {"material.density", "material.poisson_ratio", "solver.mass_scaling", "output.plott"})
    EXPECT_NE(msg.find(key), std::string::npos) << key << " not in:\n" << msg;
}

TEST(Scene, MissingOrUnreadableSceneFile) {
  const std::string nowhere = kData + "/bad_scenes/no_such_scene.yaml";
  const std::string msg = load_error(nowhere);
  EXPECT_NE(msg.find(nowhere), std::string::npos) << msg;
  EXPECT_NE(msg.find("does not exist"), std::string::npos) << msg;
  const std::string folder = load_error(kData + "/bad_scenes");
  EXPECT_NE(folder.find("folder"), std::string::npos) << folder;
  // A file with no end (it grew to gigabytes of memory): refused after 16 MiB.
  const std::string endless = load_error("/dev/zero");
  EXPECT_NE(endless.find("/dev/zero: more than 16 MiB, not a scene file"), std::string::npos) << endless;
}

TEST(Scene, AMeshOrALongTextGivenAsTheSceneGetsAShortMessage) {
  // fdem check mesh.msh put the whole mesh file into one error line.
  const std::string mesh = load_error(kData + "/meshes/cube6_v22.msh");
  EXPECT_NE(mesh.find("cube6_v22.msh: is a gmsh mesh, not a scene. Fix: give a scene .yaml file with mesh: {file: "
                      "cube6_v22.msh}"),
            std::string::npos)
      << mesh;
  EXPECT_EQ(mesh.find("$Nodes"), std::string::npos) << mesh;
  try {
    parse_scene(std::string(5000, 'x'), "long.yaml");
    FAIL() << "a plain text was accepted as a scene";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("got '" + std::string(60, 'x') + "...' (5000 bytes)"), std::string::npos) << msg;
    EXPECT_LT(msg.size(), 400u) << msg;
  }
}

// One bad file per row: the file (in tests/data/bad_scenes) and what its message must contain besides the
// file name: the key path, or for files without a usable tree the kind of problem.
struct BadScene {
  const char* file;
  const char* key;
};

class BadScenes : public ::testing::TestWithParam<BadScene> {};

TEST_P(BadScenes, ThrowsInputErrorNamingFileAndKey) {
  const std::string path = kData + "/bad_scenes/" + GetParam().file;
  try {
    load_scene(path);
    FAIL() << path << " was accepted";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path + ": "), std::string::npos) << msg;
    EXPECT_NE(msg.find(GetParam().key), std::string::npos) << "expected '" << GetParam().key << "' in:\n" << msg;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Files, BadScenes,
    ::testing::Values(
        BadScene{"missing_mesh.yaml", ": mesh: missing"}, BadScene{"missing_end.yaml", "solver.end: missing"},
        BadScene{"end_all_zero.yaml", "solver.end: no end condition"},
        BadScene{"negative_modulus.yaml", "material.youngs_modulus: -12.2e9 is out of range"},
        BadScene{"poisson_half.yaml", "material.poisson_ratio"},
        BadScene{"unknown_top_key.yaml", ": lateral_pressure: unknown key"},
        BadScene{"typo_key.yaml", "material.densty: unknown key"},
        BadScene{"string_for_number.yaml", "material.density: 'heavy' is not a number"},
        BadScene{"map_for_number.yaml", "material.density: expected a number, got a map"},
        BadScene{"list_for_map.yaml", "material: expected a map of keys, got a list"},
        BadScene{"element_too_large.yaml", "mesh.generate.element_size"},
        BadScene{"missing_mesh_file.yaml", "mesh.file: '"},
        BadScene{"generate_and_file.yaml", "mesh: both generate and file"},
        BadScene{"bad_shape.yaml", "mesh.generate.shape: 'sphere'"},
        BadScene{"optimize_threshold_above_one.yaml",
                 "mesh.generate.optimize_threshold: 1.5 is out of range; allowed 0 < optimize_threshold <= 1"},
        BadScene{"smoothing_fraction.yaml", "mesh.generate.smoothing: 2.5 is not a whole number"},
        BadScene{"missing_diameter.yaml", "mesh.generate.diameter: missing"},
        BadScene{"box_size_two.yaml", "mesh.generate.size"}, BadScene{"scale_with_generate.yaml", "mesh.scale"},
        BadScene{"invalid_yaml.yaml", "invalid YAML"}, BadScene{"empty.yaml", "empty"},
        BadScene{"comments_only.yaml", "empty"}, BadScene{"scalar_document.yaml", "expected a map of keys"},
        BadScene{"gi_too_small.yaml", "material.fracture_energy_I"},
        BadScene{"gii_too_small.yaml", "material.fracture_energy_II"},
        BadScene{"box_min_above_max.yaml", "fracture_regions[1].box"},
        BadScene{"bad_fracture_regions.yaml", "fracture_regions: 'some'"},
        BadScene{"friction_angle_90.yaml", "material.friction_angle"},
        BadScene{"bad_softening.yaml", "material.softening"},
        BadScene{"platen_too_fast.yaml", "platens.velocity: 20 is out of range; allowed 0 < velocity <= 10"},
        BadScene{"no_platens_strain_end.yaml", "solver.end"},
        BadScene{"safety_too_big.yaml", "solver.time_step_safety"},
        BadScene{"threads_too_many.yaml", "solver.threads: 65536 is out of range; allowed 0 <= threads <= 1024"},
        BadScene{"negative_mass_scaling.yaml", "solver.mass_scaling"},
        BadScene{"fractional_steps.yaml", "solver.end.steps: 10.5 is not a whole number"},
        BadScene{"unknown_end_key.yaml", "solver.end.strain: unknown key"},
        BadScene{"monitor_interval_zero.yaml", "output.monitor_interval"},
        BadScene{"plot_not_bool.yaml", "output.plot"},
        BadScene{"checkpoint_interval_fraction.yaml", "output.checkpoint_interval: 2.5 is not a whole number"},
        BadScene{"negative_max_energy_error.yaml", "solver.max_energy_error: -0.1 is out of range"},
        BadScene{"duplicate_key.yaml", "material.density: key given twice"},
        BadScene{"bad_activation.yaml",
                 "contact.activation: 'everywhere' is not recognised; allowed: adaptive | full | none"},
        BadScene{"negative_buffer.yaml", "contact.buffer: -0.001 is out of range"},
        BadScene{"contact_typo.yaml", "contact.activaton: unknown key"},
        BadScene{"bad_contact_law.yaml", "contact.law: 'penalty' is not recognised; allowed: volume | munjiza"},
        BadScene{"element_size_with_msh.yaml", "mesh.element_size: only applies to a .geo file"},
        BadScene{"gravity_two.yaml", "gravity: expected a list of three numbers"},
        BadScene{"confinement_no_pressure.yaml", "confinement.pressure: missing"},
        BadScene{"confinement_bad_path.yaml", "confinement.path: 'rising' is not recognised"},
        BadScene{"hydrostatic_without_platens.yaml", "confinement.path: hydrostatic follows the axial stress"},
        BadScene{"many_errors.yaml", "material.density"}, BadScene{"name_outside_out.yaml", "name: holds '/'"},
        BadScene{"second_document.yaml", "line 6: a second YAML document"},
        BadScene{"custom_tag.yaml", "material.density: has the tag '!kg_per_m3'"},
        BadScene{"density_beyond_any_solid.yaml",
                 "material.density: 1e300 is out of range; allowed 0 < density <= 100000"},
        BadScene{"friction_huge.yaml",
                 "material.friction_rock: 1e300 is out of range; allowed 0 <= friction_rock <= 10"}),
    [](const ::testing::TestParamInfo<BadScene>& info) {
      std::string n = info.param.file;
      n = n.substr(0, n.find('.'));
      return n;
    });

TEST(Scene, TheNameIsOneFolder) {
  const std::string body =
      "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.004}}\n"
      "solver: {end: {steps: 10}}\n";
  // Names a lab gives: commas, quotes, a leading '-', spaces, UTF-8 (summary.csv quotes them).
  for (const std::string name : {"Berea, dry", "NX 2.1\" core", "-20C frozen", " Äspö granite v1.2 "}) {
    std::string quoted = "\"";
    for (char c : name) quoted += c == '"' ? std::string("\\\"") : std::string(1, c);
    const Scene s = parse_scene("name: " + quoted + "\"\n" + body, "a.yaml");
    EXPECT_EQ(s.name, name);
    EXPECT_EQ(s.output.folder, "out/" + name);
  }
  // Without a name key, the file's name.
  EXPECT_EQ(parse_scene(body, "some/dir/granite, dry.yaml").name, "granite, dry");
  // Not a folder name: refused (../.. wrote outside out/, a NUL cut the name).
  for (const char* bad : {"name: \"a\\0b\"\n", "name: ..\n", "name: a/b\n", "name: a\\b\n"})
    EXPECT_THROW(parse_scene(bad + body, "a.yaml"), InputError) << bad;
}

TEST(Scene, OneDocumentWithoutTagsAndAliasesWalkedOnce) {
  const std::string body =
      "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.004}}\n"
      "solver: {end: {steps: 10}}\n";
  // Empty documents around the scene are no second scene.
  EXPECT_EQ(parse_scene("---\nname: n\n" + body + "---\n", "a.yaml").name, "n");
  EXPECT_EQ(parse_scene("---\n# notes\n---\nname: n\n" + body + "...\n", "a.yaml").name, "n");
  EXPECT_EQ(parse_scene("%YAML 1.2\r\n--- # scene\r\nname: n\r\n" + body, "a.yaml").name, "n");
  EXPECT_EQ(parse_scene("--- {name: n, mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: "
                        "0.004}}, solver: {end: {steps: 10}}}\n",
                        "a.yaml")
                .name,
            "n");
  // Notes after a '...' are a second document, named at their line; '---' inside a block scalar
  // (indented) is text.
  auto refusal = [](const std::string& text) {
    try {
      parse_scene(text, "doc.yaml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refusal(body + "...\nnotes: dry\n").find("doc.yaml: line 4: a second YAML document"), std::string::npos);
  EXPECT_NE(refusal(body + "notes: |\n  ---\n  dry\n").find("doc.yaml: notes: unknown key"), std::string::npos);
  // A lone ',' (from the fuzzing corpus): yaml-cpp's LoadAll never returned; an error now.
  EXPECT_NE(refusal(",").find("doc.yaml: "), std::string::npos);
  // An alias that holds itself, and aliases nested ten deep (10^10 nodes if each were walked):
  // the unknown key is named at once (a stack overflow, and minutes, before).
  EXPECT_NE(refusal(body + "notes: &a [1, *a]\n").find("notes: unknown key"), std::string::npos);
  std::string bomb = "notes:\n  l0: &l0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n";
  for (int k = 1; k <= 10; ++k) {
    const std::string p = "*l" + std::to_string(k - 1);
    bomb += "  l" + std::to_string(k) + ": &l" + std::to_string(k) + " [" + p;
    for (int r = 1; r < 10; ++r) bomb += ", " + p;
    bomb += "]\n";
  }
  EXPECT_NE(refusal(body + bomb).find("notes: unknown key"), std::string::npos);  // ctest's limit ends a hang
}

TEST(Scene, ContactAndGravityAreRead) {
  const Scene s = parse_scene(
      "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.004}}\n"
      "contact: {activation: full, buffer: 2.5e-4}\n"
      "gravity: [0, 0, -9.81]\n"
      "platens: none\n"
      "solver: {end: {steps: 10}}\n",
      "inline.yaml");
  EXPECT_EQ(s.contact.activation, Activation::full);
  EXPECT_TRUE(s.contact.enabled());
  EXPECT_DOUBLE_EQ(s.contact.buffer, 2.5e-4);
  EXPECT_DOUBLE_EQ(s.gravity.x, 0);
  EXPECT_DOUBLE_EQ(s.gravity.z, -9.81);
  const Scene none = parse_scene(
      "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.004}}\n"
      "contact: {activation: none}\nplatens: none\nsolver: {end: {steps: 10}}\n",
      "inline.yaml");
  EXPECT_FALSE(none.contact.enabled());
  EXPECT_FALSE(none.confinement.enabled);
  const Scene tri = parse_scene(
      "mesh: {generate: {shape: cylinder, diameter: 0.02, height: 0.04, element_size: 0.004}}\n"
      "confinement: {pressure: 5e6}\nsolver: {end: {axial_strain: 0.005}}\n",
      "inline.yaml");
  EXPECT_TRUE(tri.confinement.enabled);
  EXPECT_DOUBLE_EQ(tri.confinement.pressure, 5e6);
  EXPECT_EQ(tri.confinement.path, ConfinementPath::hydrostatic);
}

TEST(Scene, InvalidYamlReportsLineAndColumn) {
  const std::string msg = load_error(kData + "/bad_scenes/invalid_yaml.yaml");
  EXPECT_NE(msg.find("line "), std::string::npos) << msg;
  EXPECT_NE(msg.find("column "), std::string::npos) << msg;
}

TEST(Scene, CohesiveCheckSkippedForMeshFiles) {
  // A G_I far too small for generated 4 mm elements is not checked when the mesh comes from a file.
  const std::string dir = kData + "/scenes/";
  const Scene s = parse_scene(
      "material: {fracture_energy_I: 1e-6}\nmesh: {file: tiny.msh}\nsolver: {end: {steps: 1}}\n", dir + "inline.yaml");
  EXPECT_DOUBLE_EQ(s.material().fracture_energy_I, 1e-6);
  const std::string msg = parse_error(
      "material: {fracture_energy_I: 1e-6}\n"
      "mesh: {generate: {shape: cylinder, diameter: 0.02, height: 0.04, element_size: 0.004}}\n"
      "solver: {end: {steps: 1}}\n");
  EXPECT_NE(msg.find("material.fracture_energy_I"), std::string::npos) << msg;
  EXPECT_NE(msg.find("raise fracture_energy_I"), std::string::npos) << msg;
}

TEST(Scene, EmptySectionsKeepDefaults) {
  const Scene s = parse_scene(
      "name: empty_sections\nmaterial:\nplatens:\noutput:\n"
      "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.002}}\n"
      "solver: {end: {axial_strain: 0.01}}\n",
      "x.yaml");
  EXPECT_DOUBLE_EQ(s.material().density, 1800);
  EXPECT_TRUE(s.platens.enabled);
  EXPECT_EQ(s.output.folder, "out/empty_sections");
  const std::string msg = parse_error("mesh:\nsolver:\n");
  EXPECT_NE(msg.find("mem.yaml: mesh: has no value"), std::string::npos) << msg;
  EXPECT_NE(msg.find("mem.yaml: solver.end: missing"), std::string::npos) << msg;
}
