#include "solver/run.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "core/error.hpp"
#include "io/fields.hpp"

namespace fdem {
namespace {

const char* kCsvHeader =
    "step,time_s,axial_strain,axial_stress_Pa,lateral_strain,volumetric_strain,force_top_N,force_bottom_N,"
    "damaged_ce6,broken_ce6,broken_mode_I,broken_mode_II,broken_mixed,kinetic_J,strain_J,cohesive_stored_J,"
    "cohesive_dissipated_J,friction_J,viscous_J,platen_stored_J,platen_friction_J,external_work_J,energy_error,"
    "contact_J,contact_friction_J,active_tets,contact_pairs,contacts,confining_pressure_Pa,"
    "indirect_tensile_Pa";

void write_row(std::ostream& o, const Monitors& m) {
  o << m.step << ',' << m.time << ',' << m.axial_strain << ',' << m.axial_stress << ',' << m.lateral_strain << ','
    << m.volumetric_strain << ',' << m.force_top << ',' << m.force_bottom << ',' << m.damaged << ',' << m.broken << ','
    << m.broken_I << ',' << m.broken_II << ',' << m.broken_mixed << ',' << m.kinetic << ',' << m.strain << ','
    << m.cohesive_stored << ',' << m.cohesive_dissipated << ',' << m.friction << ',' << m.viscous << ','
    << m.platen_stored << ',' << m.platen_friction << ',' << m.external_work << ',' << m.energy_error << ','
    << m.contact << ',' << m.contact_friction << ',' << m.active_tets << ',' << m.contact_pairs << ',' << m.contacts
    << ',' << m.confining_pressure << ',' << m.indirect_tensile << '\n';
}

std::string duration(real s) {
  if (!std::isfinite(s) || s < 0) return "?";
  char b[32];
  if (s < 60)
    std::snprintf(b, sizeof b, "%.0fs", s);
  else if (s < 3600)
    std::snprintf(b, sizeof b, "%dm%02ds", int(s / 60), int(s) % 60);
  else
    std::snprintf(b, sizeof b, "%dh%02dm", int(s / 3600), int(s / 60) % 60);
  return b;
}

void write_frame(FieldWriter& w, const Solver& s, const std::string& label) {
  std::vector<Vec3> u(s.x.size());
  for (std::size_t n = 0; n < u.size(); ++n) u[n] = s.x[n] - s.model().X[n];
  std::vector<Sym3> stress;
  std::vector<real> vm;
  s.tet_stress(stress, vm);
  std::vector<std::array<int, 3>> faces;
  std::vector<real> damage;
  std::vector<int> mode;
  s.crack_faces(faces, damage, mode);
  FieldFrame fr;
  fr.time = s.time();
  fr.step = s.step_count();
  fr.label = label;
  fr.x = &s.x;
  fr.u = &u;
  fr.v = &s.v;
  fr.tets = &s.model().tet_nodes;
  fr.stress = &stress;
  fr.von_mises = &vm;
  fr.crack_faces = &faces;
  fr.crack_damage = &damage;
  fr.crack_mode = &mode;
  std::vector<real> active;
  if (s.contacts.enabled()) {
    active.assign(s.contacts.active().begin(), s.contacts.active().end());
    fr.extra.push_back({"active", &active});
  }
  w.write(fr);
}

/// Run scripts/plot_curves.py without a shell (names with quotes stay harmless).
bool plot_curves(const std::string& csv, const std::string& png, const std::string& title) {
  const std::string py = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  const std::string script = std::string(FDEM_SCRIPTS_DIR) + "/plot_curves.py";
  std::vector<std::string> args = {py, script, csv, png, "--title", title};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t quiet;
  posix_spawn_file_actions_init(&quiet);
  posix_spawn_file_actions_addopen(&quiet, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&quiet, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, argv[0], &quiet, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&quiet);
  int status = 0;
  return rc == 0 && waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace

void report_model(const Solver& solver, std::ostream& out) {
  const Model& m = solver.model();
  const StableStep& st = solver.stable_step();
  out << "model " << m.source << "\n"
      << "  tets " << m.tet_nodes.size() << ", CE6 " << m.ce6_nodes.size() << ", nodes " << m.X.size()
      << ", surface faces " << m.surface_faces.size() << "\n"
      << "  height " << m.height0 << " m, loaded area " << m.area0 << " m^2, mean edge " << m.mean_edge
      << " m, minimum altitude " << m.min_altitude << " m\n"
      << "  stable step " << st.dt / solver.scene().solver.time_step_safety << " s limited by " << st.limit << " (TET4 "
      << st.dt_tet << " s, CE6 " << st.dt_ce6 << " s, platens " << st.dt_platen << " s, contact " << st.dt_contact
      << " s)\n"
      << "  time step " << solver.dt() << " s (safety " << solver.scene().solver.time_step_safety << ", mass scaling "
      << solver.scene().solver.mass_scaling << ")\n";
}

RunSummary run_scene(Solver& solver, std::ostream& log) {
  namespace fs = std::filesystem;
  const Scene& scene = solver.scene();
  const OutputSettings& out = scene.output;
  const EndCondition& end = scene.solver.end;
  RunSummary sum;
  sum.folder = out.folder;
  std::error_code ec;
  fs::create_directories(out.folder, ec);
  if (ec) throw InputError(scene.file + ": output.folder: cannot create '" + out.folder + "': " + ec.message());
  const std::string csv_path = (fs::path(out.folder) / "monitors.csv").string();
  std::ofstream csv(csv_path);
  if (!csv) throw InputError(scene.file + ": output.folder: cannot write '" + csv_path + "'");
  csv << std::setprecision(10) << kCsvHeader << '\n';
  FieldWriter fields(out.folder, "fields");

  // Expected number of steps, for the ETA and the automatic field interval.
  const real dt = solver.dt();
  real expected = 0;
  if (end.steps > 0) expected = real(end.steps);
  if (end.time > 0) expected = expected > 0 ? std::min(expected, end.time / dt) : end.time / dt;
  if (end.axial_strain > 0 && scene.platens.enabled) {
    const real t = end.axial_strain * solver.model().height0 / scene.platens.velocity;
    expected = expected > 0 ? std::min(expected, t / dt) : t / dt;
  }
  const long field_interval = out.field_interval > 0 ? out.field_interval : std::max<long>(1, long(expected / 20));

  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<real>(std::chrono::steady_clock::now() - t0).count(); };
  real next_progress = out.progress_interval;
  Monitors mon = solver.measure();
  write_row(csv, mon);
  write_frame(fields, solver, "initial");
  bool peak_written = false;
  try {
    for (;;) {
      solver.step();
      const long n = solver.step_count();
      const bool monitor_now = n % out.monitor_interval == 0;
      if (monitor_now) {
        mon = solver.measure();
        write_row(csv, mon);
        csv.flush();
        if (!csv) throw OutputError("cannot write " + csv_path + " (disk full or file removed?)");
        if (mon.axial_stress > sum.peak_stress) {
          sum.peak_stress = mon.axial_stress;
          sum.strain_at_peak = mon.axial_strain;
          peak_written = false;
        } else if (!peak_written && sum.peak_stress > 0 && mon.axial_stress < 0.95 * sum.peak_stress) {
          peak_written = true;  // the frame just past the peak marks the fracture pattern at failure
          write_frame(fields, solver, "post-peak");
        }
      }
      if (n % field_interval == 0) write_frame(fields, solver, "");
      const real strain = solver.top_offset / solver.model().height0;
      std::string reason;
      if (end.steps > 0 && n >= end.steps) reason = "step count " + std::to_string(end.steps) + " reached";
      if (end.time > 0 && solver.time() >= end.time) reason = "end time reached";
      if (end.axial_strain > 0 && strain >= end.axial_strain) reason = "axial strain reached";
      if (monitor_now && end.post_peak_fraction > 0 && sum.peak_stress > 0 &&
          mon.axial_stress < end.post_peak_fraction * sum.peak_stress)
        reason = "stress fell below " + std::to_string(end.post_peak_fraction) + " of the peak";
      const real wall = elapsed();
      if (!reason.empty() || (out.progress_interval > 0 && wall >= next_progress)) {
        real frac = expected > 0 ? n / expected : 0;
        char line[256];
        std::snprintf(line, sizeof line,
                      "step %ld  t %.4g s  axial strain %.3e  stress %.3f MPa  broken CE6 %ld  %.0f steps/s  ETA %s", n,
                      solver.time(), strain, mon.axial_stress / 1e6, mon.broken, n / std::max(wall, 1e-9),
                      !reason.empty() ? "done"
                      : frac > 0      ? duration(wall / frac - wall).c_str()
                                      : "?");
        log << line << std::endl;
        next_progress = wall + out.progress_interval;
      }
      if (!reason.empty()) {
        sum.end_reason = reason;
        break;
      }
    }
  } catch (const RunError&) {
    try {
      write_frame(fields, solver, "diagnostic");
    } catch (const std::exception&) {
      // The state is not finite; the frames written before remain valid.
    }
    throw;
  }
  mon = solver.measure();
  if (solver.step_count() % out.monitor_interval != 0) write_row(csv, mon);
  csv.close();
  if (!csv) throw OutputError("cannot write " + csv_path + " (disk full or file removed?)");
  write_frame(fields, solver, "final");
  sum.steps = solver.step_count();
  sum.time = solver.time();
  sum.wall_seconds = elapsed();
  sum.last = mon;
  if (out.plot) {
    const std::string png = (fs::path(out.folder) / "stress_strain.png").string();
    if (!plot_curves(csv_path, png, scene.name))
      log << "warning: could not plot " << png << " (needs python3-matplotlib); the curves are in " << csv_path
          << std::endl;
  }
  return sum;
}

}  // namespace fdem
