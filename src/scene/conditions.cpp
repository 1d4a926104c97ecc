// The scene's boundary_conditions: a list of conditions on the mesh's surface groups, each with
// its type and, where it has one, its value (a velocity, pressure or traction) and a time
// function. Which groups exist is known only with the mesh: build_model checks the names
// (model/conditions.cpp).
#include "scene/conditions.hpp"

#include <cctype>

namespace fdem::scene_reading {

namespace {

const char* const kForm =
    "write e.g. boundary_conditions: [{surface: zmin, type: fixed}, {surface: zmax, type: velocity, velocity: [0, "
    "0, -0.01], time_function: {shape: smooth, duration: 1e-4}}]";

/// time_function: {shape: constant | linear | smooth, duration: s} or {table: [[t, scale], ...]}.
void read_time_function(YamlReader& r, const YAML::Node& n, const std::string& p, TimeFunction& out) {
  if (!r.check_map(n, p, {"shape", "duration", "table"})) return;
  if (n["table"]) {
    if (n["shape"] || n["duration"])
      r.error(p, "a table gives the whole function", "give either table or shape with duration, not both");
    const YAML::Node t = n["table"];
    const std::string pt = p + ".table";
    if (!t.IsSequence() || t.size() == 0) {
      r.error(pt, "expected a list of [t, scale] rows, got " + describe(t), "write e.g. table: [[0, 0], [1e-3, 1]]");
      return;
    }
    out.shape = TimeShape::table;
    for (std::size_t k = 0; k < t.size(); ++k) {
      const std::string pk = pt + "[" + std::to_string(k) + "]";
      double time = 0, scale = 0;
      if (!t[k].IsSequence() || t[k].size() != 2) {
        r.error(pk, "expected a row [t, scale], got " + describe(t[k]), "write e.g. [1e-3, 1] (t in s)");
        continue;
      }
      if (!r.scalar_number(t[k][0], pk + "[0]", at_least(0), time) ||
          !r.scalar_number(t[k][1], pk + "[1]", closed(-1e6, 1e6), scale))
        continue;
      if (!out.table.empty() && !(time > out.table.back()[0]))
        r.error(pk, "t = " + fmt(time) + " s does not increase (the row before has " + fmt(out.table.back()[0]) + " s)",
                "give the rows in strictly increasing t");
      out.table.push_back({time, scale});
    }
    return;
  }
  r.choice(n, p, "shape", out.shape);
  if (out.shape == TimeShape::table)
    r.error(p + ".shape", "table is given by its rows", "write time_function: {table: [[0, 0], [1e-3, 1]]}");
  const bool ramp = out.shape == TimeShape::linear || out.shape == TimeShape::smooth;
  if (ramp && !n["duration"])
    r.error(p + ".duration", "missing", "give the ramp's rise time in s, e.g. duration: 1e-4");
  if (!ramp && n["duration"])
    r.error(p + ".duration", "is read only for the linear and smooth shapes", "remove it, or give shape: smooth");
  r.number(n, p, "duration", Range{0, kInf, true, false}, out.duration);
}

/// velocity: [vx, vy, vz] in m/s, a ~ (null) for a component left free.
void read_velocity(YamlReader& r, const YAML::Node& n, const std::string& p, BoundaryCondition& c) {
  const std::string form = "write e.g. velocity: [~, ~, -0.01] (m/s; ~ leaves a component free)";
  if (!n.IsSequence() || n.size() != 3) {
    r.error(p, "expected a list of three velocities [vx, vy, vz], got " + describe(n), form);
    return;
  }
  c.components = 0;
  for (int d = 0; d < 3; ++d) {
    if (n[d].IsNull()) continue;
    double v = 0;
    if (r.scalar_number(n[d], p + "[" + std::to_string(d) + "]", closed(-1e3, 1e3), v))
      c.velocity[d] = v, c.components |= 1 << d;
  }
  if (c.components == 0) r.error(p, "leaves every component free", form);
}

/// The key that gives condition c's value ("velocity", "traction", "pressure"), or "" (none).
std::string value_key(ConditionType t) {
  switch (t) {
    case ConditionType::velocity:
      return "velocity";
    case ConditionType::traction:
      return "traction";
    case ConditionType::pressure:
      return "pressure";
    default:
      return "";
  }
}

/// The value of a condition of type c.type under `key`, and its time function.
void read_value(YamlReader& r, const YAML::Node& n, const std::string& p, BoundaryCondition& c) {
  const std::string key = value_key(c.type);
  const std::string pk = p + "." + key;
  if (c.type == ConditionType::velocity) read_velocity(r, n[key], pk, c);
  if (c.type == ConditionType::traction) r.vec3(n[key], pk, closed(-1e10, 1e10), c.traction);
  if (c.type == ConditionType::pressure) r.number(n, p, key, closed(-1e10, 1e10), c.pressure);
  if (n["time_function"]) read_time_function(r, n["time_function"], p + ".time_function", c.time);
}

void read_condition(YamlReader& r, const YAML::Node& n, const std::string& p, BoundaryCondition& c) {
  if (!r.check_map(n, p, {"surface", "type", "velocity", "traction", "pressure", "time_function"})) return;
  if (!n["surface"]) r.error(p + ".surface", "missing", "name a surface group of the mesh (fdem check lists them)");
  r.text(n, p, "surface", c.surface, "name a surface group of the mesh (fdem check lists them)");
  if (!n["type"]) r.error(p + ".type", "missing", "give the condition's type: " + choice_list<ConditionType>(" | "));
  if (!r.choice(n, p, "type", c.type)) return;
  const std::string key = value_key(c.type);
  const char* units = c.type == ConditionType::velocity   ? "[vx, vy, vz] in m/s"
                      : c.type == ConditionType::traction ? "[tx, ty, tz] in Pa"
                                                          : "in Pa, compression positive";
  if (!key.empty() && !n[key]) r.error(p + "." + key, "missing", "give the surface's " + key + " " + units);
  for (const char* other : {"velocity", "traction", "pressure"})
    if (n[other] && key != other)
      r.error(p + "." + other, std::string("is not read for type ") + name_of(c.type),
              "remove it, or give type: " + std::string(other));
  if (n["time_function"] && key.empty())
    r.error(p + ".time_function",
            c.type == ConditionType::absorbing
                ? std::string("an absorbing boundary has no value to scale")
                : std::string("a ") + name_of(c.type) + " condition holds its value at zero",
            "remove it, or give type velocity, traction or pressure");
  else if (!key.empty() && n[key])
    read_value(r, n, p, c);
}

}  // namespace

void read_boundary_conditions(YamlReader& r, const YAML::Node& n, std::vector<BoundaryCondition>& out) {
  const std::string p = "boundary_conditions";
  if (!n.IsSequence()) {
    r.error(p, "expected a list of conditions, got " + describe(n), kForm);
    return;
  }
  if (n.size() > std::size_t(BoundaryCondition::kMax)) {
    r.error(p, std::to_string(n.size()) + " conditions", "give at most " + std::to_string(BoundaryCondition::kMax));
    return;
  }
  for (std::size_t i = 0; i < n.size(); ++i) {
    BoundaryCondition c;
    read_condition(r, n[i], BoundaryCondition::key(i), c);
    out.push_back(c);
  }
}

void read_history(YamlReader& r, const YAML::Node& n, std::vector<HistoryPoint>& out) {
  const std::string form = "write e.g. history: [{name: crown, at: [0, 0, 2.5]}] (positions in m)";
  if (!n.IsSequence() || n.size() == 0) {
    r.error("history", "expected a list of points, got " + describe(n), form);
    return;
  }
  if (n.size() > HistoryPoint::kMax) {
    r.error("history", std::to_string(n.size()) + " points", "give at most " + std::to_string(HistoryPoint::kMax));
    return;
  }
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string p = "history[" + std::to_string(i) + "]";
    if (!r.check_map(n[i], p, {"name", "at", "group"})) continue;
    HistoryPoint h;
    if (!n[i]["name"]) r.error(p + ".name", "missing", "give the point a name (its columns are h_<name>_...)");
    if (r.text(n[i], p, "name", h.name, "give the point a name")) {
      for (const char c : h.name)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-')
          r.error(p + ".name", "'" + h.name + "' holds '" + std::string(1, c) + "'",
                  "use letters, digits, '_' and '-' (the name is part of column names)");
      for (const HistoryPoint& o : out)
        if (o.name == h.name) r.error(p + ".name", "'" + h.name + "' names two points", "give each its own name");
    }
    if (bool(n[i]["at"]) == bool(n[i]["group"]))
      r.error(p + (n[i]["at"] ? ".group" : ".at"), n[i]["at"] ? "given with at" : "missing",
              "give a point's reference position, e.g. at: [0, 0, 2.5] (m), or a mesh group, e.g. group: roof");
    else if (n[i]["at"])
      r.vec3(n[i]["at"], p + ".at", closed(-1e7, 1e7), h.at);
    else
      r.text(n[i], p, "group", h.group, "name a volume or surface group of the mesh");
    out.push_back(h);
  }
}

}  // namespace fdem::scene_reading
