// The fdem command line. Exit codes: 0 success, 2 bad input, 3 run stopped (unstable),
// 4 writing output failed, 5 stopped by SIGTERM/SIGINT after a checkpoint, 1 other.
#include <mpi.h>
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "analysis/mohr_coulomb.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "io/atomic_file.hpp"
#include "io/fields.hpp"
#include "io/run_lock.hpp"
#include "model/model.hpp"
#include "partition/halo.hpp"
#include "partition/partition.hpp"
#include "partition/plex.hpp"
#include "scene/scene.hpp"
#include "solver/pipeline.hpp"
#include "solver/run.hpp"
#include "solver/series.hpp"
#include "solver/study.hpp"

namespace {

/// The series commands: run, tabulate, fit (triaxial) and plot.
int run_series_command(const std::string& scene_path, const std::vector<fdem::SeriesAxis>& axes, std::string folder,
                       int threads, bool quiet, bool triaxial) {
  namespace fs = std::filesystem;
  const fdem::Scene scene = fdem::load_scene(scene_path);
  if (folder.empty()) folder = scene.output.folder;
  std::unique_ptr<fdem::RunLock> lock;  // the folder's, held to the end of the command
  const auto rows = fdem::run_series(scene_path, axes, folder, threads, quiet, std::cout, &lock);
  const std::string csv = (fs::path(folder) / "series.csv").string();
  fdem::write_series_csv(csv, rows);
  std::cout << "series: " << rows.size() << " runs in " << folder << "; table " << csv << "\n";
  std::vector<std::string> plot_args = {csv, folder};
  if (triaxial) {
    std::vector<fdem::real> s3, s1;
    for (const auto& r : rows) {
      std::cout << "  sigma3 " << r.number("confining_pressure_Pa") / 1e6 << " MPa: peak sigma1 "
                << r.number("peak_stress_Pa") / 1e6 << " MPa at axial strain " << r.number("strain_at_peak")
                << ", failure plane " << r.number("failure_plane_angle_deg") << " deg to the axis\n";
      s3.push_back(r.number("confining_pressure_Pa"));
      s1.push_back(r.number("peak_stress_Pa"));
    }
    const std::string mc = (fs::path(folder) / "mohr_coulomb.csv").string();
    try {
      const fdem::MohrCoulombFit f = fdem::fit_mohr_coulomb(s3, s1);
      std::ostringstream o;
      o << std::setprecision(10)
        << "cohesion_Pa,cohesion_se_Pa,friction_angle_deg,friction_angle_se_deg,intercept_Pa,slope,rms_misfit_Pa,"
           "peaks\n"
        << f.cohesion << ',' << f.cohesion_se << ',' << f.friction_angle << ',' << f.friction_angle_se << ','
        << f.intercept << ',' << f.slope << ',' << f.rms_misfit << ',' << s3.size() << '\n';
      fdem::write_file_atomically(mc, o.str());
      std::cout << "  Mohr-Coulomb envelope: c = " << f.cohesion / 1e6 << " +- " << f.cohesion_se / 1e6
                << " MPa, phi = " << f.friction_angle << " +- " << f.friction_angle_se << " deg (" << mc << ")\n";
      const fdem::Material& mat = scene.material();
      plot_args.insert(plot_args.end(), {"--mohr", mc, "--input",
                                         fdem::fmt(mat.cohesion, 10) + "," + fdem::fmt(mat.friction_angle, 10)});
    } catch (const fdem::InputError& e) {
      std::error_code ec;
      fs::remove(mc, ec);
      std::cout << "  no Mohr-Coulomb envelope: " << e.what() << "\n";
    }
  }
  if (!fdem::run_python_script("plot_series.py", plot_args))
    std::cout << "warning: could not plot the series (needs python3-matplotlib); the table is " << csv << "\n";
  else
    std::cout << "  plots: " << (fs::path(folder) / "series_curves.png").string()
              << (triaxial ? ", " + (fs::path(folder) / "mohr_circles.png").string() : std::string()) << "\n";
  return 0;
}

/// Discards what is written to it (the progress of ranks other than 0).
struct NullBuffer : std::streambuf {
  int overflow(int c) override { return c; }
};

int world_rank() {
  return fdem::rank_in(MPI_COMM_WORLD);
}
int world_size() {
  return fdem::size_of(MPI_COMM_WORLD);
}

/// Every option of every command, as given.
struct CliOptions {
  std::string scene_path, output;
  int threads = 0;
  bool quiet = false;
  std::string activation, backend, partitioned, distribute, write_mesh;
  double contact_reach = 0;  // m
  fdem::RunOptions run_options;
  int parts = 0;
  std::string sigma3, reference;
  std::vector<std::string> vary, budget;
};

struct Commands {
  CLI::App *run, *check, *partition, *triaxial, *series, *study;
};

void define_run(CLI::App* run, CliOptions& o) {
  run->add_option("scene", o.scene_path, "Scene file (YAML)")->required();
  run->add_option("-o,--output", o.output,
                  "Output folder (overrides output.folder); one run at a time: a folder another run is writing is "
                  "refused (docs/restart.md)");
  run->add_option("-t,--threads", o.threads, "OpenMP threads (overrides solver.threads)")
      ->check(CLI::Range(0, fdem::SolverSettings::kMaxThreads));
  run->add_flag("-q,--quiet", o.quiet, "No progress lines");
  run->add_option("--contact", o.activation, "Contact activation (overrides contact.activation)")
      ->check(CLI::IsMember({"adaptive", "full", "none"}));
  run->add_option("--backend", o.backend,
                  "Time loop (overrides solver.backend), one loop on three backends: cpu (OpenMP, in place), cuda "
                  "(the GPU), or debug (the CPU with separate device memory and each pass's iterations scrambled, "
                  "for checking; FDEM_DEBUG_ORDER=forward keeps index order). FDEM_DEVICE_SCHEDULE=colour computes "
                  "TET4 and CE6 colour by colour (cpu's default), =fused in one pass, =auto in one pass that also "
                  "integrates (debug's and cuda's default). "
                  "Several ranks: the halo hands device buffers "
                  "to a CUDA-aware MPI, else stages them through host memory; FDEM_GPU_AWARE_MPI=auto|1|0 overrides "
                  "(docs/cluster.md)")
      ->check(CLI::IsMember({"cpu", "cuda", "debug"}));
  run->add_option("--partitioned", o.partitioned,
                  "Folder of rank files written by fdem partition (one per MPI rank): no mesh reading, model build, "
                  "METIS or PETSc at start");
  run->add_option("--distribute", o.distribute,
                  "Several ranks without --partitioned: how rank 0's model reaches the ranks. plex: METIS's "
                  "partition through PETSc DMPlex (DMPlexDistribute, overlap 1, the tet data as cell data; the "
                  "default where fdem is built with PETSc); root: rank 0 sends each rank its part (the default "
                  "without PETSc). Both give the same rank models")
      ->check(CLI::IsMember({"plex", "root"}));
  run->add_option("--restart", o.run_options.restart,
                  "Continue an interrupted run from its newest checkpoint: the run's output folder, its "
                  "checkpoints/ folder or a .ckpt file (same scene and mesh; solver.end and output may change; on "
                  "any number of ranks)");
}

void define_check_and_partition(CLI::App* check, CLI::App* partition, CliOptions& o) {
  check->add_option("scene", o.scene_path, "Scene file (YAML)")->required();
  check->add_option(
      "--write-mesh", o.write_mesh,
      "Also write the scene's mesh (generated or read) to this gmsh .msh file (ASCII 2.2, coordinates "
      "in m, the same mesh and groups bit for bit when read back): give it as mesh.file where fdem has no "
      "gmsh");
  partition->add_option("scene", o.scene_path, "Scene file (YAML)")->required();
  partition->add_option("-n,--ranks", o.parts, "Number of MPI ranks")->required()->check(CLI::PositiveNumber);
  partition->add_option("-o,--output", o.output, "Folder for rank_<r>.fdp (default: <output.folder>/partition_<N>)");
}

void define_contact_reach(CLI::App* sub, CliOptions& o) {
  sub->add_option("--contact-reach", o.contact_reach,
                  "m: each rank also holds the tets within this distance of its own, for contact across ranks "
                  "(reference positions, gathered again with the current ones whenever a node has moved a "
                  "quarter of it; it must exceed twice a node's motion in one step). Default with contact: two "
                  "mean edge lengths, or 2.5 times the platen travel to the end condition if larger")
      ->check([](const std::string& v) -> std::string {
        // CLI::PositiveNumber lets nan through (nan <= 0 is false), and nan meant "the default".
        return fdem::decimal(v) > 0 ? "" : "Value " + v + " is not a finite length > 0 (m)";
      });
}

void define_series_commands(const Commands& c, CliOptions& o) {
  c.triaxial->add_option("scene", o.scene_path, "Scene file (YAML)")->required();
  c.triaxial->add_option("--sigma3", o.sigma3, "Confining pressures in Pa, comma-separated, e.g. 0,2.5e6,5e6,10e6")
      ->required();
  const char* vary_help =
      "key=v1,v2,... (repeatable; every combination runs, at most 10000; a value given twice, also as 1e6 and "
      "1000000, is an error), SI units; keys: sigma3 (Pa), platen_velocity (m/s), "
      "diameter (m, height scaled with it), element_size (m), mass_scaling, activation, time_step_safety";
  c.series->add_option("scene", o.scene_path, "Scene file (YAML)")->required();
  c.series->add_option("--vary", o.vary, vary_help)->required();
  c.study->add_option("scene", o.scene_path, "Scene file (YAML)")->required();
  c.study->add_option("--vary", o.vary, vary_help)->required();
  c.study->add_option("--reference", o.reference,
                      "The reference variant, key=value[,key=value] (default: the most exact value of each axis: "
                      "activation full, the smallest mass_scaling, platen_velocity, element_size, time_step_safety)");
  c.study->add_option("--budget", o.budget,
                      "Error budget, metric=limit[,...]: peak, strain_at_peak, curve_pre, curve_post, broken (at "
                      "most, e.g. 2% or 0.02; a fraction above 1 needs %), jaccard (at least, e.g. 0.8)");
  for (auto* sub : {c.triaxial, c.series, c.study}) {
    sub->add_option("-o,--output", o.output,
                    sub == c.study ? "Study folder (default: <output.folder>/study of the scene)"
                                   : "Series folder (default: the scene's output.folder)");
    sub->add_option("-t,--threads", o.threads, "OpenMP threads per run")
        ->check(CLI::Range(0, fdem::SolverSettings::kMaxThreads));
    sub->add_flag("-q,--quiet", o.quiet, "No progress lines");
  }
}

Commands define_commands(CLI::App& app, CliOptions& o) {
  Commands c;
  c.run = app.add_subcommand("run", "Run a scene: writes monitors.csv, stress_strain.png and fields.xdmf/.h5");
  c.check = app.add_subcommand(
      "check", "Validate a scene, build its model and report the mesh's groups, counts and the time step");
  c.partition = app.add_subcommand(
      "partition",
      "Partition a scene's model for N MPI ranks (METIS) and write one rank file per rank, for fdem run "
      "--partitioned on machines without METIS or to skip the build at start");
  c.triaxial = app.add_subcommand(
      "triaxial",
      "Run a scene at several confining pressures (along the scene's confinement.path, hydrostatic by default), one "
      "after another, skipping finished "
      "ones; writes series.csv, series_curves.png, mohr_coulomb.csv and mohr_circles.png");
  c.series = app.add_subcommand(
      "series",
      "Run a scene for every combination of the varied parameters, skipping finished runs; writes series.csv and "
      "series_curves.png (loading-rate and specimen-size studies)");
  c.study = app.add_subcommand(
      "study",
      "Speed against error: run variants of a scene, compare each with a reference variant (peak, strain at peak, "
      "curve before/after the peak, broken CE6, fracture overlap) and recommend the fastest within a budget; writes "
      "study.csv, study.md, study.png");
  define_run(c.run, o);
  define_check_and_partition(c.check, c.partition, o);
  for (auto* sub : {c.run, c.partition}) define_contact_reach(sub, o);
  define_series_commands(c, o);
  return c;
}

int partition_command(CliOptions o) {
  fdem::Scene scene = fdem::load_scene(o.scene_path);
  const fdem::Model model = fdem::build_scene_model(scene, "", std::cout);
  const fdem::PartitionPlan plan = fdem::plan_scene(scene, model, o.parts, o.contact_reach);
  if (o.output.empty()) o.output = scene.output.folder + "/partition_" + std::to_string(o.parts);
  std::error_code ec;
  std::filesystem::create_directories(o.output, ec);
  if (ec)
    throw fdem::OutputError(
        "cannot create the folder '" + o.output + "' for the rank files: " + ec.message() +
        (ec == std::errc::not_a_directory || ec == std::errc::file_exists
             ? ". Fix: give -o a folder (new or existing), not a file"
             : ". Fix: give -o a folder where you may write (check its permissions and free space)"));
  std::cout << "partition of " << model.tet_nodes.size() << " tets, " << model.ce6_nodes.size() << " CE6, "
            << model.X.size() << " nodes for " << o.parts << " ranks, contact reach " << plan.reach << " m:\n";
  for (int r = 0; r < o.parts; ++r) {
    const fdem::RankModel rm = fdem::extract_rank(model, plan, r);
    const std::string path = fdem::rank_file_path(o.output, r);
    fdem::write_rank_file(path, rm, fdem::model_key(scene));
    long own = 0, ghost_nodes = 0;
    for (auto t : rm.dd.tet_owned) own += t;
    for (const auto& nb : rm.dd.neighbours) ghost_nodes += long(nb.recv_nodes.size());
    std::cout << "  rank " << r << ": " << own << " tets own, " << rm.model.tet_nodes.size() - own << " ghost, "
              << rm.dd.neighbours.size() << " neighbour(s), " << ghost_nodes << " ghost nodes -> " << path << "\n";
  }
  std::cout << "run with: mpiexec -n " << o.parts << " fdem run " << o.scene_path << " --partitioned " << o.output
            << "\n";
  return 0;
}

int study_command(CliOptions o) {
  std::vector<fdem::SeriesAxis> axes;
  for (const std::string& a : o.vary) axes.push_back(fdem::parse_series_axis(a));
  const fdem::SeriesValues ref = fdem::parse_reference(o.reference);
  const auto limits = fdem::parse_budget(o.budget);
  if (o.output.empty()) o.output = fdem::load_scene(o.scene_path).output.folder + "/study";
  std::unique_ptr<fdem::RunLock> lock;  // the folder's, held to the end of the command
  const fdem::StudyResult r =
      fdem::run_study(o.scene_path, axes, ref, limits, o.output, o.threads, o.quiet, std::cout, &lock);
  const bool plotted = fdem::write_study(o.output, r);
  std::ifstream md(o.output + "/study.md");
  std::cout << md.rdbuf() << "\nstudy: " << o.output << "/study.csv, study.md"
            << (plotted ? ", study.png" : " (no plot: needs python3-matplotlib)") << "\n";
  return 0;
}

/// The command that continues a run stopped by a signal: every option that changes the run, so
/// that the checkpoint matches (and, with -t, bit for bit).
std::string continue_command(const CliOptions& o, int size, const std::string& folder) {
  auto q = [](const std::string& a) { return "'" + a + "'"; };
  std::string cmd =
      (size > 1 ? "mpiexec -n " + std::to_string(size) + " " : std::string()) + "fdem run " + q(o.scene_path);
  if (!o.output.empty()) cmd += " -o " + q(o.output);
  if (!o.partitioned.empty()) cmd += " --partitioned " + q(o.partitioned);
  if (o.contact_reach > 0) cmd += " --contact-reach " + fdem::fmt(o.contact_reach, 10);
  if (o.threads > 0) cmd += " -t " + std::to_string(o.threads);
  if (!o.activation.empty()) cmd += " --contact " + o.activation;
  if (!o.backend.empty()) cmd += " --backend " + o.backend;
  if (!o.distribute.empty()) cmd += " --distribute " + o.distribute;
  return cmd + " --restart " + q(folder);
}

/// The end of a run: its end, peak, breaks, fracture plane, contact and outputs.
void report_run(const fdem::RunSummary& s, const fdem::Solver& solver) {
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
  std::cout << "  contact " << fdem::name_of(solver.scene().contact.activation);
  if (solver.contacts.enabled()) {
    const fdem::ContactTimes& ct = solver.contacts.times;
    const long tets = solver.distributed() ? solver.decomposition().global_tets : long(solver.model().tet_nodes.size());
    std::cout << ": " << s.last.active_tets << " of " << tets << " tets active, " << s.last.contact_pairs
              << " candidate pairs, " << ct.rebuilds << " broad-phase builds; wall time broad " << ct.broad
              << " s, narrow " << ct.narrow << " s with friction" << (solver.distributed() ? " (rank 0)" : "");
  }
  std::cout << "\n  outputs in " << s.folder
            << ": monitors.csv, summary.csv, stress_strain.png, fields.xdmf (open in ParaView; frames labelled "
               "pre-peak, peak, post-peak)\n";
}

/// fdem run and fdem check (check_only: the model and its report, no run).
int run_command(const CliOptions& o, bool check_only) {
  const int size = world_size(), rank = world_rank();
  fdem::Scene scene = fdem::load_scene(o.scene_path);
  if (!o.output.empty()) scene.output.folder = o.output;
  if (o.threads > 0) scene.solver.threads = o.threads;
  if (o.quiet) scene.output.progress_interval = 0;
  if (!o.activation.empty()) fdem::choice_named(o.activation, scene.contact.activation);
  if (!o.backend.empty()) scene.solver.backend = fdem::parse_backend(o.backend, "--backend");
  NullBuffer null_buffer;
  std::ostream null_stream(&null_buffer);
  std::ostream& log = rank == 0 ? std::cout : null_stream;
  const std::unique_ptr<fdem::Solver> solver =
      fdem::make_solver(scene, {o.partitioned, fdem::distribution_named(o.distribute), o.contact_reach, o.write_mesh},
                        MPI_COMM_WORLD, log);
  fdem::report_model(*solver, log);
  if (check_only) return 0;
  fdem::RunSummary s;
  try {
    s = fdem::run_scene(*solver, log, o.run_options);
  } catch (const fdem::Interrupted& e) {
    throw fdem::Interrupted(std::string(e.what()) +
                            "; continue with: " + continue_command(o, size, scene.output.folder));
  }
  if (rank == 0) report_run(s, *solver);
  return 0;
}

int run_main(int argc, char** argv) {
  CLI::App app{"fdem " FDEM_VERSION
               ": 3D combined finite-discrete element modelling of rock fracture (TET4 + CE6 cohesive elements). "
               "All quantities in SI units."};
  app.set_version_flag("--version", "fdem " FDEM_VERSION);
  app.require_subcommand(1);
  CliOptions o;
  const Commands c = define_commands(app, o);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  // OpenMP's own limit is far above what it survives: libgomp crashed at 100000 threads before
  // the first line of output.
  if (omp_get_max_threads() > fdem::SolverSettings::kMaxThreads)
    throw fdem::InputError(
        "OMP_NUM_THREADS=" + std::string(std::getenv("OMP_NUM_THREADS") ? std::getenv("OMP_NUM_THREADS") : "?") +
        ": more than " + std::to_string(fdem::SolverSettings::kMaxThreads) +
        " OpenMP threads. Fix: set OMP_NUM_THREADS to the cores of one rank, or unset it");
  const int size = world_size();
  if (size > 1 && !c.run->parsed())
    throw fdem::InputError("fdem " + app.get_subcommands().front()->get_name() + " runs on one MPI rank (got " +
                           std::to_string(size) + "); only fdem run uses several. Fix: run it without mpiexec");
  if (c.partition->parsed()) return partition_command(o);
  if (c.study->parsed()) return study_command(o);
  std::vector<fdem::SeriesAxis> axes;
  if (c.triaxial->parsed()) axes.push_back(fdem::parse_series_axis("sigma3=" + o.sigma3));
  for (const std::string& a : o.vary) axes.push_back(fdem::parse_series_axis(a));
  if (c.triaxial->parsed() || c.series->parsed())
    return run_series_command(o.scene_path, axes, o.output, o.threads, o.quiet, c.triaxial->parsed());
  return run_command(o, c.check->parsed());
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  const int size = world_size();
  // Several ranks: a message names its rank, and a rank that fails ends the whole job at once
  // (MPI_Abort), since the others would wait for it in the next exchange.
  const std::string who = size > 1 ? "rank " + std::to_string(world_rank()) + ": " : "";
  int code = 0;
  std::string message;
  try {
    code = run_main(argc, argv);
  } catch (const fdem::InputError& e) {
    message = "error: " + std::string(e.what()), code = 2;
  } catch (const fdem::OutputError& e) {
    message = "output failed: " + std::string(e.what()), code = 4;
  } catch (const fdem::RunError& e) {
    message = "run stopped: " + std::string(e.what()), code = 3;
  } catch (const fdem::Interrupted& e) {
    message = "interrupted: " + std::string(e.what()), code = 5;
  } catch (const std::exception& e) {
    message = "error: " + std::string(e.what()), code = 1;
  }
  if (code == 5 && size > 1) {
    // A signal stops every rank at the same step after each wrote its checkpoint: a clean end.
    if (world_rank() == 0) std::cerr << message << std::endl;
  } else if (!message.empty()) {
    std::cerr << who << message << std::endl;
    if (size > 1) MPI_Abort(MPI_COMM_WORLD, code);
  }
  if (code != 0 && fdem::open_hdf5_files() > 0) {
    // A field file whose close failed: HDF5's shutdown in MPI_Finalize would crash on it
    // (exit 139 instead of the code above). Everything of ours is written or reported.
    std::cout.flush();
    std::cerr.flush();
    std::_Exit(code);
  }
  fdem::plex_finalize();
  MPI_Finalize();
  return code;
}
