// The fdem command line. Exit codes: 0 success, 2 bad input, 3 run stopped (unstable),
// 4 writing output failed, 1 other.
#include <mpi.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "core/error.hpp"
#include "io/mesh_io.hpp"
#include "model/model.hpp"
#include "scene/scene.hpp"
#include "solver/run.hpp"

namespace {

int run_main(int argc, char** argv) {
  CLI::App app{"fdem " FDEM_VERSION
               ": 3D combined finite-discrete element modelling of rock fracture (TET4 + CE6 cohesive elements). "
               "All quantities in SI units."};
  app.set_version_flag("--version", "fdem " FDEM_VERSION);
  app.require_subcommand(1);

  std::string scene_path, output;
  int threads = 0;
  bool quiet = false;
  auto* run = app.add_subcommand("run", "Run a scene: writes monitors.csv, stress_strain.png and fields.xdmf/.h5");
  run->add_option("scene", scene_path, "Scene file (YAML)")->required();
  run->add_option("-o,--output", output, "Output folder (overrides output.folder)");
  run->add_option("-t,--threads", threads, "OpenMP threads (overrides solver.threads)")->check(CLI::NonNegativeNumber);
  run->add_flag("-q,--quiet", quiet, "No progress lines");
  std::string activation;
  run->add_option("--contact", activation, "Contact activation (overrides contact.activation)")
      ->check(CLI::IsMember({"adaptive", "full", "none"}));

  auto* check = app.add_subcommand("check", "Validate a scene, build its model and report counts and the time step");
  check->add_option("scene", scene_path, "Scene file (YAML)")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }

  fdem::Scene scene = fdem::load_scene(scene_path);
  if (!output.empty()) scene.output.folder = output;
  if (threads > 0) scene.solver.threads = threads;
  if (quiet) scene.output.progress_interval = 0;
  if (!activation.empty()) scene.contact.activation = activation;
  fdem::Mesh mesh;
  fdem::Model model;
  try {
    mesh = fdem::load_mesh(scene.mesh);
    model = fdem::build_model(mesh, scene);
  } catch (const fdem::InputError& e) {
    // Name the scene too: the mesh message names the mesh file and the element.
    throw fdem::InputError(scene.file + ": mesh: " + e.what());
  }
  fdem::Solver solver(scene, std::move(model));
  fdem::report_model(solver, std::cout);
  if (check->parsed()) return 0;

  const fdem::RunSummary s = fdem::run_scene(solver, std::cout);
  std::cout << "finished: " << s.end_reason << " after " << s.steps << " steps, t = " << s.time << " s, "
            << s.wall_seconds << " s wall\n"
            << "  peak axial stress " << s.peak_stress / 1e6 << " MPa at axial strain " << s.strain_at_peak
            << "; broken CE6 " << s.last.broken << " (mode I " << s.last.broken_I << ", II " << s.last.broken_II
            << ", mixed " << s.last.broken_mixed << "); energy error " << s.last.energy_error << "\n";
  if (s.peak_indirect_tensile > 0)
    std::cout << "  indirect tensile strength 2P/(pi D t) " << s.peak_indirect_tensile / 1e6 << " MPa\n";
  if (s.fracture.broken >= 3)
    std::cout << "  main failure plane at " << s.fracture.plane_angle_deg << " deg to the loading axis (planarity "
              << s.fracture.planarity << "; facets " << s.fracture.mean_facet_angle_deg << " deg on average)\n";
  std::cout << "  contact " << scene.contact.activation;
  if (solver.contacts.enabled()) {
    const fdem::ContactTimes& ct = solver.contacts.times;
    std::cout << ": " << s.last.active_tets << " of " << solver.model().tet_nodes.size() << " tets active, "
              << s.last.contact_pairs << " candidate pairs, " << ct.rebuilds << " broad-phase builds; wall time broad "
              << ct.broad << " s, narrow " << ct.narrow << " s, friction " << ct.friction << " s";
  }
  std::cout << "\n  outputs in " << s.folder
            << ": monitors.csv, summary.csv, stress_strain.png, fields.xdmf (open in ParaView; frames labelled "
               "pre-peak, peak, post-peak)\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int size = 1, code = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  try {
    if (size > 1)
      throw fdem::InputError("fdem runs on one MPI rank for now (got " + std::to_string(size) +
                             "); multi-rank distribution is not built yet: run without mpiexec or with -n 1");
    code = run_main(argc, argv);
  } catch (const fdem::InputError& e) {
    std::cerr << "error: " << e.what() << std::endl;
    code = 2;
  } catch (const fdem::OutputError& e) {
    std::cerr << "output failed: " << e.what() << std::endl;
    code = 4;
  } catch (const fdem::RunError& e) {
    std::cerr << "run stopped: " << e.what() << std::endl;
    code = 3;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << std::endl;
    code = 1;
  }
  MPI_Finalize();
  return code;
}
