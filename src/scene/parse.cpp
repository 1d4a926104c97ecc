// Scene file reader: YAML text -> validated Scene. Every problem found is reported as
// "<file>: <key.path>: <what is wrong>; <what is allowed / the fix>", all of them at once.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/format.hpp"
#include "scene/conditions.hpp"
#include "scene/materials.hpp"
#include "scene/reader.hpp"
#include "scene/scene.hpp"

namespace fdem {
namespace {

namespace fs = std::filesystem;
using namespace scene_reading;

/// What a run's name may not hold: control characters, and what ends a folder name.
bool bad_name_char(char c) {
  const unsigned char u = c;
  return u < 0x20 || u == 0x7f || c == '/' || c == '\\';
}

/// Walks the YAML tree, fills the Scene and collects every error.
class Reader : public YamlReader {
 public:
  using YamlReader::YamlReader;

  // ---- sections -------------------------------------------------------------------------

  void mesh(const YAML::Node& n, const std::string& scene_dir, MeshSpec& m) {
    const std::string p = "mesh";
    if (n.IsNull()) {
      error(p, "has no value", "give exactly one of mesh.generate or mesh.file");
      return;
    }
    if (!check_map(n, p, {"generate", "file", "scale", "element_size", "min_element_size"})) return;
    const bool gen = bool(n["generate"]), file = bool(n["file"]);
    if (gen == file) {
      error(p, gen ? "both generate and file are given" : "neither generate nor file is given",
            "give exactly one of mesh.generate (shape cylinder|disc|box) or mesh.file (a gmsh .msh file)");
      return;
    }
    if (gen) {
      if (n["scale"]) error(p + ".scale", "only applies to mesh.file", "remove it; give generated sizes in m");
      if (n["element_size"])
        error(p + ".element_size", "belongs in mesh.generate, or with a .geo mesh.file", "move it into mesh.generate");
      generate(n["generate"], m);
      return;
    }
    number(n, p, "scale", positive(), m.scale);
    std::string f;
    if (!text(n, p, "file", f, "give the path of a gmsh .msh or .geo file, relative to the scene file's folder"))
      return;
    const fs::path resolved = fs::path(f).is_absolute() ? fs::path(f) : (fs::path(scene_dir) / f).lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(resolved, ec))
      error(p + ".file", "'" + resolved.string() + "' does not exist or is not a file",
            "paths are relative to the scene file's folder" +
                (scene_dir.empty() ? std::string() : " (" + scene_dir + ")"));
    m.file = resolved.string();
    m.shape = MeshShape::file;
    if (n["element_size"]) {
      if (!m.geo())
        error(p + ".element_size", "only applies to a .geo file, which fdem meshes; a .msh file is meshed already",
              "remove it, or give the .geo file");
      number(n, p, "element_size", positive(), m.element_size);
    }
    if (n["min_element_size"]) {
      if (!m.geo() || !n["element_size"])
        error(p + ".min_element_size", "only applies with element_size to a .geo file",
              "remove it, or give the .geo file its element_size too");
      else if (number(n, p, "min_element_size", positive(), m.min_element_size) &&
               !(m.min_element_size <= m.element_size))
        error(p + ".min_element_size",
              fmt(m.min_element_size) + " m is above element_size " + fmt(m.element_size) + " m",
              "give the smallest element at most the largest");
    }
  }

  void generate(const YAML::Node& n, MeshSpec& m) {
    const std::string p = "mesh.generate";
    const std::vector<std::string> kGenerateKeys = {"shape",        "diameter",           "height",   "size",
                                                    "element_size", "optimize_threshold", "smoothing"};
    const std::vector<std::string> shapes = {"cylinder", "disc", "box"};
    if (!n.IsMap()) {
      check_map(n, p, kGenerateKeys);
      return;
    }
    if (!n["shape"]) {
      error(p + ".shape", "missing", "allowed: cylinder | disc | box");
      check_map(n, p, kGenerateKeys);
      return;
    }
    std::string shape;
    if (!choice(n, p, "shape", shapes, shape)) {
      check_map(n, p, kGenerateKeys);
      return;
    }
    const size_t errors_before = errors_.size();
    const bool round = shape != "box";
    choice_named(shape, m.shape);  // one of `shapes`
    check_map(n, p,
              round ? std::vector<std::string>{"shape", "diameter", "height", "element_size", "optimize_threshold",
                                               "smoothing"}
                    : std::vector<std::string>{"shape", "size", "element_size", "optimize_threshold", "smoothing"});
    m.file.clear();
    auto require = [&](const std::string& key, const std::string& what) {
      if (!n[key]) error(p + "." + key, "missing for shape " + shape, "give " + what);
    };
    if (round) {
      require("diameter", "the diameter in m");
      require("height", shape == "disc" ? "the thickness in m" : "the height in m");
      number(n, p, "diameter", positive(), m.diameter);
      number(n, p, "height", positive(), m.height);
    } else {
      require("size", "the edge lengths [lx, ly, lz] in m");
      if (n["size"]) vec3(n["size"], p + ".size", positive(), m.size);
    }
    require("element_size", "the target element edge length in m");
    number(n, p, "element_size", positive(), m.element_size);
    number(n, p, "optimize_threshold", Range{0, 1, true, false}, m.optimize_threshold);
    number(n, p, "smoothing", count_at_least(0, 1000), m.smoothing);
    if (errors_.size() != errors_before) return;
    const double smallest = round ? std::min(m.diameter, m.height) : std::min({m.size.x, m.size.y, m.size.z});
    if (!(m.element_size < smallest))
      error(p + ".element_size",
            fmt(m.element_size) + " m is not smaller than the specimen (smallest dimension " + fmt(smallest) + " m)",
            "use element_size < " + fmt(smallest) + " m (several elements across the specimen)");
  }

  void fracture_regions(const YAML::Node& n, FractureRegions& fr) {
    const std::string p = "fracture_regions";
    const std::string allowed = "allowed: all | none | a list of {box: {min: [x, y, z], max: [x, y, z]}}";
    if (n.IsScalar() && (n.Scalar() == "all" || n.Scalar() == "none")) {
      fr.everywhere = n.Scalar() == "all";
      fr.boxes.clear();
      return;
    }
    if (!n.IsSequence()) {
      error(p, describe(n) + " is not recognised", allowed);
      return;
    }
    if (n.size() == 0) {
      error(p, "the list is empty", "write `fracture_regions: none` for no cohesive elements");
      return;
    }
    fr.everywhere = false;
    fr.boxes.clear();
    for (size_t i = 0; i < n.size(); ++i) {
      const std::string pi = p + "[" + std::to_string(i) + "]";
      if (!check_map(n[i], pi, {"box"})) continue;
      const YAML::Node b = n[i]["box"];
      if (!b) {
        error(pi + ".box", "missing", allowed);
        continue;
      }
      const std::string pb = pi + ".box";
      if (!check_map(b, pb, {"min", "max"})) continue;
      FractureRegions::Box box{{0, 0, 0}, {0, 0, 0}};
      bool ok = true;
      for (const char* k : {"min", "max"}) {
        if (!b[k]) {
          error(pb + "." + k, "missing", "give the corner as [x, y, z] in m");
          ok = false;
        } else {
          ok = vec3(b[k], pb + "." + k, Range{}, std::string(k) == "min" ? box.min : box.max) && ok;
        }
      }
      if (!ok) continue;
      for (int c = 0; c < 3; ++c) {
        if (!(box.min[c] < box.max[c])) {
          error(pb,
                "min " + std::string(1, "xyz"[c]) + " = " + fmt(box.min[c]) + " is not below max " +
                    std::string(1, "xyz"[c]) + " = " + fmt(box.max[c]),
                "each component of min must be smaller than the same component of max");
          ok = false;
          break;
        }
      }
      if (ok) fr.boxes.push_back(box);
    }
  }

  /// A section that is either the word `none` (enabled = false) or a map of `keys` (checked;
  /// enabled = true). Returns true when the map's values should be read.
  bool none_or_map(const YAML::Node& n, const std::string& p, const std::vector<std::string>& keys, bool& enabled) {
    if (n.IsScalar() && n.Scalar() == "none") {
      enabled = false;
      return false;
    }
    if (n.IsScalar() || n.IsNull()) {
      std::string list;
      for (const auto& k : keys) list += (list.empty() ? "" : ", ") + k;
      error(p, describe(n) + " is not recognised", "allowed: none | a map with " + list);
      return false;
    }
    if (!check_map(n, p, keys)) return false;
    enabled = true;
    return true;
  }

  void platens(const YAML::Node& n, Platens& pl) {
    const std::string p = "platens";
    if (!none_or_map(n, p, {"velocity", "ramp_time"}, pl.enabled)) return;
    number(n, p, "velocity", Range{0, Platens::kMaxVelocity, true, false}, pl.velocity);
    number(n, p, "ramp_time", at_least(0), pl.ramp_time);
  }

  void confinement(const YAML::Node& n, Confinement& c, bool platens_on) {
    const std::string p = "confinement";
    if (!none_or_map(n, p, {"pressure", "path", "ramp_time"}, c.enabled)) return;
    if (!n["pressure"]) error(p + ".pressure", "missing", "give the confining stress sigma_3 in Pa, e.g. 5e6");
    number(n, p, "pressure", Range{0, Confinement::kMaxPressure, true, false}, c.pressure);
    choice(n, p, "path", c.path);
    number(n, p, "ramp_time", at_least(0), c.ramp_time);
    if (c.path == ConfinementPath::hydrostatic && !platens_on)
      error(p + ".path", "hydrostatic follows the axial stress of the platens, and `platens: none` is set",
            "use path: constant, or enable the platens");
  }

  void contact(const YAML::Node& n, ContactSettings& c) {
    const std::string p = "contact";
    if (!check_map(n, p, {"activation", "law", "buffer"})) return;
    choice(n, p, "activation", c.activation);
    choice(n, p, "law", c.law);
    number(n, p, "buffer", closed(0, 1e3), c.buffer);
  }

  void solver(const YAML::Node& n, SolverSettings& s, bool platens_on) {
    const std::string p = "solver";
    if (!check_map(n, p,
                   {"time_step_safety", "time_step", "mass_scaling", "damping_scale", "threads", "max_energy_error",
                    "backend", "end"}))
      return;
    number(n, p, "time_step_safety", Range{0, SolverSettings::kMaxSafety, true, false}, s.time_step_safety);
    number(n, p, "time_step", at_least(0), s.time_step);
    number(n, p, "mass_scaling", closed(1, SolverSettings::kMaxMassScaling), s.mass_scaling);
    number(n, p, "damping_scale", closed(0, 100), s.damping_scale);
    number(n, p, "threads", count_at_least(0, SolverSettings::kMaxThreads), s.threads);
    choice(n, p, "backend", s.backend);
    number(n, p, "max_energy_error", closed(0, 1e3), s.max_energy_error);
    const std::string need = "give at least one of axial_strain, post_peak_fraction, time, steps > 0";
    const YAML::Node e = n["end"];
    if (!e) {
      error(p + ".end", "missing", need + ", e.g. end: {axial_strain: 0.004, post_peak_fraction: 0.6}");
      return;
    }
    const std::string pe = p + ".end";
    const size_t errors_before = errors_.size();
    if (!check_map(e, pe, {"axial_strain", "post_peak_fraction", "time", "steps"})) return;
    EndCondition& end = s.end;
    number(e, pe, "axial_strain", closed(0, 1), end.axial_strain);
    number(e, pe, "post_peak_fraction", Range{0, 1, false, true}, end.post_peak_fraction);
    number(e, pe, "time", at_least(0), end.time);
    number(e, pe, "steps", count_at_least(0), end.steps);
    if (errors_.size() != errors_before) return;
    if (end.axial_strain <= 0 && end.post_peak_fraction <= 0 && end.time <= 0 && end.steps <= 0)
      error(pe, "no end condition is set (all values are 0)", need);
    else if (!platens_on && end.time <= 0 && end.steps <= 0)
      error(pe, "axial_strain and post_peak_fraction need platens, and `platens: none` is set",
            "give end.time or end.steps > 0");
  }

  void output(const YAML::Node& n, OutputSettings& o) {
    const std::string p = "output";
    if (!check_map(n, p,
                   {"folder", "monitor_interval", "field_interval", "progress_interval", "plot", "peak_frames",
                    "checkpoint_interval", "checkpoint_wall_interval"}))
      return;
    text(n, p, "folder", o.folder, "give a folder path, relative to the current directory");
    number(n, p, "monitor_interval", count_at_least(1), o.monitor_interval);
    number(n, p, "field_interval", count_at_least(0), o.field_interval);
    number(n, p, "progress_interval", at_least(0), o.progress_interval);
    boolean(n, p, "plot", o.plot);
    boolean(n, p, "peak_frames", o.peak_frames);
    number(n, p, "checkpoint_interval", count_at_least(0), o.checkpoint_interval);
    number(n, p, "checkpoint_wall_interval", at_least(0), o.checkpoint_wall_interval);
  }

  /// `material` (one, every tet) or `materials` (on volume groups) with their `interfaces`.
  void rock(const YAML::Node& root, Scene& s) {
    const bool one = root["material"] && !root["material"].IsNull(), many = bool(root["materials"]);
    if (one && many)
      error("materials", "given with material",
            "give material (one for every tet) or materials (each on its volume groups), not both");
    if (one && check_map(root["material"], "material", scene_reading::material_keys()))
      read_material_keys(*this, root["material"], "material", s.material());
    if (many) read_materials(*this, root["materials"], s);
    if (root["interfaces"]) {
      if (!many)
        error("interfaces", "given without materials", "interfaces join two of the materials listed under materials");
      else
        read_interfaces(*this, root["interfaces"], s);
    }
    if (root["joints"]) read_joints(*this, root["joints"], s);
  }

  /// The name is the default output folder out/<name>: one folder name (summary.csv quotes it
  /// as a field, so commas, quotes and a leading '-' are fine).
  void name_check(const std::string& name) {
    std::string why;
    for (const char c : name)
      if (bad_name_char(c))
        why = (unsigned char)c < 0x20 || c == 0x7f ? "holds a control character" : "holds '" + std::string(1, c) + "'";
    if (name == "." || name == "..") why = "is a folder reference";
    if (name.size() > 200) why = "is longer than 200 bytes";
    if (!why.empty())
      error("name", why,
            "give a short name without '/', '\\' or control characters (it names the output folder out/<name>)");
  }

  /// yaml-cpp nodes seen by strange_yaml (by their place in the file): an alias is walked once,
  /// so that `&a [1, *a]` ends and nested aliases do not multiply the work.
  std::set<std::pair<int, int>> walked_;

  /// What YAML allows and a scene has no use for, anywhere in the tree: a tag of one's own
  /// (`!weird 2000` was read as 2000) and a NUL character in a value (it cut names and paths).
  void strange_yaml(const YAML::Node& n, const std::string& path) {
    if ((n.IsMap() || n.IsSequence()) && !walked_.insert({n.Mark().line, n.Mark().column}).second) return;
    const std::string& tag = n.Tag();
    if (!tag.empty() && tag != "?" && tag != "!" && tag.rfind("tag:yaml.org,2002:", 0) != 0)
      error(path.empty() ? "(top level)" : path, "has the tag '" + tag + "', which fdem does not read",
            "remove the tag (a scene holds plain numbers, words, lists and maps)");
    if (n.IsScalar() && n.Scalar().find('\0') != std::string::npos)
      error(path.empty() ? "(top level)" : path, "holds a NUL character", "remove it");
    if (n.IsSequence())
      for (std::size_t i = 0; i < n.size(); ++i) strange_yaml(n[i], path + "[" + std::to_string(i) + "]");
    if (n.IsMap())
      for (const auto& kv : n)
        strange_yaml(kv.second, join_path(path, kv.first.IsScalar() ? kv.first.Scalar() : std::string("?")));
  }

  Scene scene(const YAML::Node& root, const std::string& file) {
    Scene s;
    s.file = file;
    // Without a name key, the file's name, with what name_check refuses replaced by '_'.
    std::string stem = fs::path(file).stem().string();
    for (char& c : stem)
      if (bad_name_char(c)) c = '_';
    s.name = stem.empty() || stem == "." || stem == ".." ? "scene" : stem;
    strange_yaml(root, "");
    if (!check_map(root, "",
                   {"name", "material", "materials", "interfaces", "joints", "mesh", "fracture_regions", "platens",
                    "confinement", "contact", "gravity", "initial_stress", "excavate", "boundary_conditions", "history",
                    "solver", "output"}))
      return s;
    const std::string scene_dir = fs::path(file).parent_path().string();
    if (text(root, "", "name", s.name, "give a short name for the run")) name_check(s.name);
    const size_t before = errors_.size();
    // A section left empty (`material:` with nothing under it) keeps its defaults.
    auto given = [&](const char* key) { return root[key] && !root[key].IsNull(); };
    rock(root, s);
    if (root["mesh"])
      mesh(root["mesh"], scene_dir, s.mesh);
    else
      error("mesh", "missing",
            "give mesh.generate (e.g. {shape: cylinder, diameter: 0.02, height: 0.04, "
            "element_size: 0.004}) or mesh.file");
    if (errors_.size() == before) check_materials(*this, s);
    if (root["fracture_regions"]) fracture_regions(root["fracture_regions"], s.fracture);
    if (given("platens")) platens(root["platens"], s.platens);
    if (given("confinement")) confinement(root["confinement"], s.confinement, s.platens.enabled);
    if (given("contact")) contact(root["contact"], s.contact);
    if (root["gravity"]) vec3(root["gravity"], "gravity", closed(-1e4, 1e4), s.gravity);
    if (root["boundary_conditions"]) read_boundary_conditions(*this, root["boundary_conditions"], s.conditions);
    if (root["history"]) read_history(*this, root["history"], s.history);
    if (given("solver"))
      solver(root["solver"], s.solver, s.platens.enabled);
    else
      error("solver.end", "missing (no solver section)",
            "give solver.end with at least one of axial_strain, post_peak_fraction, time, steps > 0");
    if (given("initial_stress")) read_initial_stress(*this, root["initial_stress"], s);
    if (root["excavate"]) read_excavation(*this, root["excavate"], s.excavation);
    s.output.folder = (fs::path("out") / s.name).string();
    if (given("output")) output(root["output"], s.output);
    return s;
  }
};

/// The scene's YAML document: the text with the empty documents before it blanked (line numbers
/// kept), for YAML::Load, which reads only the first. A second document that holds something is
/// an InputError. Documents are told apart by their markers, '---' or '...' at the start of a
/// line, which YAML forbids inside scalars; not by YAML::LoadAll, which hangs on some inputs
/// (yaml-cpp 0.7: a lone ',').
std::string one_document(const std::string& text, const std::string& label) {
  std::vector<std::string> lines;
  for (std::size_t at = 0; at <= text.size();) {
    const std::size_t end = std::min(text.find('\n', at), text.size());
    lines.push_back(text.substr(at, end - at));
    at = end + 1;
  }
  // A line's content, without a document marker that starts it; blank, comments and directives
  // hold nothing.
  auto marker = [](const std::string& l) {
    return (l.rfind("---", 0) == 0 || l.rfind("...", 0) == 0) && (l.size() == 3 || std::isspace((unsigned char)l[3]));
  };
  auto holds_something = [&](const std::string& l) {
    const std::string rest = marker(l) ? l.substr(3) : l;
    const std::size_t c = rest.find_first_not_of(" \t\r");
    return c != std::string::npos && rest[c] != '#' && !(c == 0 && rest[0] == '%');
  };
  long doc_start = 0, scene_start = -1;  // line of the current document's marker; of the scene's
  bool counted = false;                  // the current document holds something
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (marker(lines[i])) {
      doc_start = long(i);
      counted = false;
    }
    if (!holds_something(lines[i]) || counted) continue;
    counted = true;
    if (scene_start >= 0)
      throw InputError(label + ": line " + std::to_string(i + 1) +
                       ": a second YAML document (after a '---' or '...' line); a scene is one document. Fix: "
                       "merge them, put each scene in a file of its own, or make notes comments (#)");
    scene_start = doc_start;
  }
  std::string out;
  for (std::size_t i = 0; i < lines.size(); ++i)
    out += (long(i) < scene_start ? std::string() : lines[i]) + (i + 1 < lines.size() ? "\n" : "");
  return out;
}

}  // namespace

Scene parse_scene(const std::string& yaml_text, const std::string& file) {
  const std::string label = file.empty() ? "<scene>" : file;
  if (yaml_text.find_first_not_of(" \t\r\n") != std::string::npos &&
      yaml_text.compare(yaml_text.find_first_not_of(" \t\r\n"), 11, "$MeshFormat") == 0)
    throw InputError(label + ": is a gmsh mesh, not a scene. Fix: give a scene .yaml file with mesh: {file: " +
                     fs::path(label).filename().string() + "} (scenes/ucs_small.yaml is an example)");
  YAML::Node root;
  try {
    root = YAML::Load(one_document(yaml_text, label));
  } catch (const YAML::Exception& e) {
    std::string where;
    if (!e.mark.is_null())
      where = "line " + std::to_string(e.mark.line + 1) + ", column " + std::to_string(e.mark.column + 1) + ": ";
    throw InputError(label + ": " + where + "invalid YAML: " + e.msg +
                     "; check indentation, colons and brackets near that place");
  }
  if (!root || root.IsNull())
    throw InputError(label +
                     ": the file is empty; a scene needs at least mesh and solver.end "
                     "(see docs/scene-format.md)");
  Reader reader(label);
  Scene s = reader.scene(root, file);
  const auto& errors = reader.errors();
  if (!errors.empty()) {
    std::string msg;
    for (const auto& e : errors) msg += (msg.empty() ? "" : "\n") + e;
    throw InputError(msg);
  }
  return s;
}

Scene load_scene(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec))
    throw InputError(path + ": the scene file does not exist; check the path (scenes/ucs_small.yaml is an example)");
  if (fs::is_directory(path, ec)) throw InputError(path + ": is a folder, not a scene file; give a .yaml file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the scene file; check its permissions");
  // Read up to a bound: a device or pipe (/dev/zero) need not end. A scene is a few kB.
  constexpr std::size_t kMaxBytes = std::size_t(16) << 20;
  std::string text;
  char chunk[1 << 16];
  while (text.size() <= kMaxBytes && in.read(chunk, sizeof chunk).gcount() > 0)
    text.append(chunk, std::size_t(in.gcount()));
  if (in.bad()) throw InputError(path + ": cannot read the scene file; check its permissions");
  if (text.size() > kMaxBytes)
    throw InputError(path + ": more than 16 MiB, not a scene file (a scene is a few kB of YAML; the mesh goes in " +
                     "a .msh file named by mesh.file); give the scene's .yaml file");
  return parse_scene(text, path);
}

}  // namespace fdem
