// bench_contact: adaptive against full contact activation on a fracturing UCS run.
//
// For each element size: generate a 0.02 m x 0.04 m cylinder, build the default model
// (Table 2 limestone, CE6 on every internal face), load it with the platens at --velocity
// (default 0.2 m/s, mass scaling 5) until the axial stress falls below --post-peak (default
// 0.5) of its peak, once with contact.activation = adaptive and once with full. Prints, as
// Markdown: wall time, steps, time per step, the share of each contact phase (broad, narrow,
// friction) in the wall time, the peak stress and broken-CE6 count of each run and their
// differences, the speed-up; and the active tets and candidate pairs over the run.
//
// Usage: bench_contact [--sizes 0.008,0.006] [--velocity 0.2] [--mass-scaling 5]
//                      [--post-peak 0.5] [--threads T] [--only adaptive|full]
//                      [--backend cpu|debug|cuda] [--max-steps N]
//                      [--meshes DIR] [--write-meshes DIR]
// --backend runs the same model on the device loop (cuda: on the GPU; the contact phases' shares
// are then not measured, only the wall time). --max-steps stops a run after N steps, peak or not:
// a short run that checks the program, not a measurement. --write-meshes writes each size's
// cylinder to DIR/cylinder_<size>.msh and stops; --meshes reads them from there instead of
// meshing (for a machine without gmsh, such as the GPU machine).
// This is a benchmark, not a test: it checks nothing.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/device_memory.hpp"
#include "io/mesh_io.hpp"
#include "model/model.hpp"
#include "solver/solver.hpp"

namespace {

using fdem::real;
using Clock = std::chrono::steady_clock;

struct Sample {
  real strain, stress;
  long active, pairs, contacts, broken;
};

struct Result {
  std::string activation;
  long tets = 0, steps = 0;
  double wall = 0;
  fdem::ContactTimes times;
  real peak = 0, strain_at_peak = 0;
  long broken = 0;
  std::vector<Sample> samples;
};

struct Options {
  std::vector<real> sizes{0.008, 0.006};
  real velocity = 0.2, mass_scaling = 5, post_peak = 0.5;
  int threads = 0;
  std::string only;
  fdem::Backend backend = fdem::Backend::cpu;
  long max_steps = 0;  // 0: no limit
  std::string meshes, write_meshes;
};

std::string mesh_path(const std::string& dir, real h) {
  char name[64];
  std::snprintf(name, sizeof name, "/cylinder_%g.msh", h);
  return dir + name;
}

/// The 0.02 m x 0.04 m cylinder of element size h: generated, or read from opt.meshes.
fdem::Mesh cylinder(real h, const Options& opt) {
  if (!opt.meshes.empty()) return fdem::read_msh(mesh_path(opt.meshes, h));
  fdem::MeshSpec spec;
  spec.shape = fdem::MeshShape::cylinder;
  spec.diameter = 0.02;
  spec.height = 0.04;
  spec.element_size = h;
  return fdem::generate_mesh(spec);
}

Result run(real h, const std::string& activation, const Options& opt) {
  fdem::Scene scene;
  scene.name = "bench_contact";
  scene.file = "(bench)";
  scene.output.progress_interval = 0;
  scene.output.plot = false;
  scene.platens.velocity = opt.velocity;
  scene.solver.mass_scaling = opt.mass_scaling;
  scene.solver.threads = opt.threads;
  scene.solver.backend = opt.backend;
  if (!choice_named(activation, scene.contact.activation)) throw std::invalid_argument(activation);
  fdem::Solver s(scene, fdem::build_model(cylinder(h, opt), scene));
  Result r;
  r.activation = activation;
  r.tets = long(s.model().tet_nodes.size());
  const auto t0 = Clock::now();
  fdem::Monitors row = s.measure();
  const real strain_cap = 0.01;
  for (;;) {
    s.step();
    if (s.step_count() % 100) continue;
    row = s.measure();
    r.samples.push_back(
        {row.axial_strain, row.axial_stress, row.active_tets, row.contact_pairs, row.contacts, row.broken});
    if (row.axial_stress > r.peak) r.peak = row.axial_stress, r.strain_at_peak = row.axial_strain;
    if (row.axial_stress < opt.post_peak * r.peak || row.axial_strain > strain_cap) break;
    if (opt.max_steps > 0 && s.step_count() >= opt.max_steps) break;
  }
  r.wall = std::chrono::duration<double>(Clock::now() - t0).count();
  r.steps = s.step_count();
  r.times = s.contacts.times;
  r.broken = row.broken;
  return r;
}

std::vector<real> parse_list(const char* s) {
  std::vector<real> v;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ',')) v.push_back(std::atof(item.c_str()));
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--sizes")
      opt.sizes = parse_list(argv[i + 1]);
    else if (k == "--velocity")
      opt.velocity = std::atof(argv[i + 1]);
    else if (k == "--mass-scaling")
      opt.mass_scaling = std::atof(argv[i + 1]);
    else if (k == "--post-peak")
      opt.post_peak = std::atof(argv[i + 1]);
    else if (k == "--threads")
      opt.threads = std::atoi(argv[i + 1]);
    else if (k == "--only")
      opt.only = argv[i + 1];
    else if (k == "--backend")
      opt.backend = fdem::parse_backend(argv[i + 1], "--backend");
    else if (k == "--max-steps")
      opt.max_steps = std::atol(argv[i + 1]);
    else if (k == "--meshes")
      opt.meshes = argv[i + 1];
    else if (k == "--write-meshes")
      opt.write_meshes = argv[i + 1];
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  if (opt.threads > 0) omp_set_num_threads(opt.threads);
  if (!opt.write_meshes.empty()) {
    for (real h : opt.sizes) fdem::write_msh(cylinder(h, opt), mesh_path(opt.write_meshes, h));
    return 0;
  }
  std::printf("backend %s, threads %d, platen velocity %g m/s, mass scaling %g, run to %g of the peak",
              fdem::backend_name(opt.backend), omp_get_max_threads(), opt.velocity, opt.mass_scaling, opt.post_peak);
  if (opt.max_steps > 0) std::printf(" or %ld steps", opt.max_steps);
  std::printf("\n\n");
  std::printf(
      "| element m | activation | tets | steps | wall s | ms/step | broad %% | narrow %% (friction in it) | builds | "
      "peak MPa | strain at peak | broken CE6 |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::vector<std::vector<Result>> all;
  for (real h : opt.sizes) {
    std::vector<Result> rs;
    for (const char* a : {"adaptive", "full"}) {
      if (!opt.only.empty() && opt.only != a) continue;
      Result r = run(h, a, opt);
      const double w = r.wall / 100;
      std::printf("| %g | %s | %ld | %ld | %.1f | %.3f | %.1f | %.1f | %ld | %.3f | %.5f | %ld |\n", h, a, r.tets,
                  r.steps, r.wall, 1e3 * r.wall / r.steps, r.times.broad / w, r.times.narrow / w, r.times.rebuilds,
                  r.peak / 1e6, r.strain_at_peak, r.broken);
      std::fflush(stdout);
      rs.push_back(std::move(r));
    }
    all.push_back(std::move(rs));
  }
  std::printf(
      "\n| element m | speed-up (full wall / adaptive wall) | peak difference | broken difference |\n"
      "|---|---|---|---|\n");
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (all[i].size() < 2) continue;
    const Result &a = all[i][0], &f = all[i][1];
    std::printf("| %g | %.1f | %+.2f %% | %+.1f %% |\n", opt.sizes[i], f.wall / a.wall, 100 * (a.peak / f.peak - 1),
                f.broken > 0 ? 100.0 * double(a.broken - f.broken) / double(f.broken) : 0.0);
  }
  // Candidate pairs over the run (about ten rows per size).
  for (std::size_t i = 0; i < all.size(); ++i) {
    std::printf("\nelement %g m: active tets and candidate pairs over the run\n\n", opt.sizes[i]);
    std::printf("| axial strain | stress MPa (adaptive) |");
    for (const Result& r : all[i])
      std::printf(" %s active | %s pairs | %s touching |", r.activation.c_str(), r.activation.c_str(),
                  r.activation.c_str());
    std::printf("\n|---|---|");
    for (std::size_t k = 0; k < all[i].size(); ++k) std::printf("---|---|---|");
    std::printf("\n");
    const std::size_t n = all[i][0].samples.size();
    const std::size_t every = std::max<std::size_t>(1, n / 10);
    for (std::size_t j = 0; j < n; j += every) {
      const Sample& s0 = all[i][0].samples[j];
      std::printf("| %.5f | %.2f |", s0.strain, s0.stress / 1e6);
      for (const Result& r : all[i]) {
        const Sample& s = r.samples[std::min(j, r.samples.size() - 1)];
        std::printf(" %ld | %ld | %ld |", s.active, s.pairs, s.contacts);
      }
      std::printf("\n");
    }
  }
  return 0;
}
