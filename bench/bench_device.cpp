// bench_device: the device time loop (solver/device_loop_impl.hpp) per pass and per step, against
// the memory-bandwidth floor, on structured boxes of the paper's cylinder proportions
// (57 x 57 x 129 mm, 6 tets per cell, CE6 on every internal face, Table 2 limestone, platens at
// 0.02 m/s, adaptive contact, mass scaling --mass-scaling, default 1).
//
// For each size: build, warm up, then
//  - step: wall time of --steps steps with nothing else in the loop (passes queued as a run
//    queues them; the per-step sums the host reads are included);
//  - per pass: --steps more steps with the device waited for after every pass;
//  - floor: the bytes of one step (DeviceLoop::bytes_per_step, a traffic model that counts node
//    data once per element corner) over the measured copy bandwidth of the backend's memory;
//  - monitor row: Solver::measure() (its sums on the device);
//  - state to host: Solver::sync_host() after a step (what output, checkpoints and peak frames cost);
//  - host peak: the process's peak resident memory over what was resident before the size, per
//    tet; set-up: the structured mesh, the model and the Solver built on the host.
// Then the projected wall time of the paper's UCS run (scenes/ucs_paper.yaml: 670,005 tets,
// 0.02 m/s, to the post-peak stage: 0.0192 s of loading, 3.31 million steps of 5.79 ns at m = 5,
// docs/validation.md, times sqrt(5 / m)) from the step time
// per tet of the largest size, with its pre-peak contact (fracture adds pairs).
//
// Then the largest model that fits: the memory free at the start (device and host) over the
// bytes per tet the largest size took (device arrays; the host's peak resident memory, model
// and host copies included), with a tenth kept free. `max` in --tets runs that size (after at
// least one smaller size, which gives the bytes per tet; the host builds the model single
// threaded: the set-up column; 6.4 us per tet on the dev VM, so 10 million tets take a minute).
//
// Usage: bench_device [--backend cuda|debug] [--tets 10000,100000,700000[,max]] [--steps N]
//                     [--mass-scaling m] [--contact adaptive|full|none] [--schedule auto,fused,colour]
//                     [--blocks-per-sm 1,2]
// --schedule: the element passes, each a row per size (FDEM_DEVICE_SCHEDULE): auto (TET4 and CE6
// fused in one pass where the mesh allows, the integration in it where the run allows: the
// default), fused (that pass without the integration) and/or colour (colour by colour).
// --blocks-per-sm: the resident blocks per multiprocessor the fused pass's kernels are compiled
// for (FDEM_CUDA_BLOCKS_PER_SM; default 1), each a row per fused schedule and size: 2 halves the
// registers per thread (spilling the rest) for twice the threads in flight (the CUDA backend only).
// Default backend: cuda where a GPU is visible, else debug (the same loop on the host).
// Prints Markdown on stdout. A benchmark, not a test: it checks nothing.
#include <malloc.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/device_memory.hpp"
#include "core/error.hpp"
#include "core/forall.hpp"
#include "model/structured.hpp"
#include "solver/device_loop.hpp"
#include "solver/solver.hpp"

namespace {

using namespace fdem;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

constexpr long kLargest = -1;  // "max" in --tets

std::vector<long> parse_list(const std::string& s) {
  std::vector<long> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item == "max" ? kLargest : std::atol(item.c_str()));
  return out;
}

std::vector<std::string> parse_names(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

struct Row {
  long tets = 0, ce6 = 0, nodes = 0, pairs = 0;
  double step_us = 0, floor_us = 0, bytes = 0, monitor_ms = 0, sync_ms = 0, mem_mb = 0, dt = 0;
  double copies_to_host = 0, bytes_to_host = 0;  // per step, between monitor rows (device::traffic)
  double launches = 0;                           // device passes per step (kernels; device::traffic)
  double launches_ahead = 0;                     // of them, queued behind a copy before the host waits
  double host_bytes = 0;                         // peak resident memory over the size's start
  double setup_s = 0;                            // mesh, model and Solver built on the host
  std::string schedule;                          // the element passes: fused+step, fused or colour
  DeviceTimes pass;
};

/// Bytes per tet of the largest size run so far, and the largest model the memory free at the
/// start holds with a tenth kept free.
struct Fit {
  double device_per_tet = 0, host_per_tet = 0, device_free = 0, host_free = 0;
  long tets = 0;
};
Fit largest_fit(Backend b, const std::vector<Row>& rows, double device_free, double host_free) {
  Fit f;
  f.device_free = device_free, f.host_free = host_free;
  const Row* big = nullptr;  // the largest size; of its schedules, the one that took the most
  for (const Row& r : rows)
    if (!big || r.tets > big->tets || (r.tets == big->tets && r.mem_mb > big->mem_mb)) big = &r;
  if (!big) return f;
  f.device_per_tet = big->mem_mb * 1e6 / double(big->tets);
  f.host_per_tet = big->host_bytes / double(big->tets);
  // The debug backend's device arrays are host memory, already in the resident peak.
  double n = f.host_per_tet > 0 ? 0.9 * host_free / f.host_per_tet : 1e300;
  if (b == Backend::cuda && f.device_per_tet > 0) n = std::min(n, 0.9 * device_free / f.device_per_tet);
  f.tets = n < 1e300 ? long(n) : 0;
  return f;
}

/// The command line, with its defaults.
struct Options {
  std::string backend = cuda_device_count() > 0 ? "cuda" : "debug", contact = "adaptive";
  std::vector<long> sizes{10000, 100000, 700000};
  std::vector<std::string> schedules{"auto"}, blocks_per_sm{"1"};
  int steps = 200;
  double mass_scaling = 1;
};

/// Options from argv; false (after a message) on an unknown one.
bool parse_options(int argc, char** argv, Options& o) {
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--backend")
      o.backend = v;
    else if (a == "--tets")
      o.sizes = parse_list(v);
    else if (a == "--steps")
      o.steps = std::atoi(v.c_str());
    else if (a == "--mass-scaling")
      o.mass_scaling = std::atof(v.c_str());
    else if (a == "--contact")
      o.contact = v;
    else if (a == "--schedule")
      o.schedules = parse_names(v);
    else if (a == "--blocks-per-sm")
      o.blocks_per_sm = parse_names(v);
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return false;
    }
  }
  return true;
}

/// The rows' (schedule, blocks per SM); the colour passes and the debug backend's host code are
/// the same whatever the blocks, so they get one row. False (after a message) where a value is
/// not allowed: every value is checked before a model is built.
bool row_variants(Backend b, const Options& o, std::vector<std::pair<std::string, std::string>>& variants) {
  for (const std::string& schedule : o.schedules)
    for (const std::string& blocks : o.blocks_per_sm)
      if ((schedule != "colour" && b == Backend::cuda) || blocks == o.blocks_per_sm.front())
        variants.emplace_back(schedule, blocks);
  if (b != Backend::cuda && o.blocks_per_sm.size() > 1)
    std::fprintf(stderr, "bench_device: --blocks-per-sm changes the CUDA kernels only: one row per schedule here\n");
  try {
    for (const std::string& schedule : o.schedules)
      setenv("FDEM_DEVICE_SCHEDULE", schedule.c_str(), 1), device_schedule(b);
    for (const std::string& blocks : o.blocks_per_sm)
      setenv("FDEM_CUDA_BLOCKS_PER_SM", blocks.c_str(), 1), device_blocks_per_sm();
  } catch (const InputError& e) {
    std::fprintf(stderr, "bench_device: --schedule or --blocks-per-sm: %s\n", e.what());
    return false;
  }
  return true;
}

/// The benchmark's scene on backend b.
Scene bench_scene(Backend b, Activation activation, double mass_scaling) {
  Scene s;
  s.name = "bench_device";
  s.file = "(bench_device)";
  s.platens.velocity = 0.02;
  s.contact.activation = activation;
  s.solver.mass_scaling = mass_scaling;
  s.solver.backend = b;
  s.solver.max_energy_error = 0;
  s.output.progress_interval = 0;
  return s;
}

/// The step's time, its copies and launches, then each pass's time, over `steps` steps each.
void time_steps(Solver& solver, Backend b, int steps, Row& r) {
  DeviceLoop* dev = solver.device_loop();
  device::reset_traffic();
  const auto t0 = Clock::now();
  for (int i = 0; i < steps; ++i) solver.step();
  device::synchronize(b);
  r.step_us = 1e6 * since(t0) / steps;
  r.copies_to_host = double(device::traffic().to_host) / steps;
  r.bytes_to_host = double(device::traffic().host_bytes) / steps;
  r.launches = double(device::traffic().launches) / steps;
  r.launches_ahead = double(device::traffic().launches_ahead) / steps;
  const DeviceTimes before = dev->times();
  dev->set_timing(true);
  for (int i = 0; i < steps; ++i) solver.step();
  dev->set_timing(false);
  const DeviceTimes after = dev->times();
  auto per = [&](double DeviceTimes::*m) { return 1e6 * (after.*m - before.*m) / steps; };
  r.pass.tet4 = per(&DeviceTimes::tet4), r.pass.ce6 = per(&DeviceTimes::ce6);
  r.pass.activation = per(&DeviceTimes::activation), r.pass.broad = per(&DeviceTimes::broad);
  r.pass.narrow = per(&DeviceTimes::narrow);
  r.pass.contact_sum = per(&DeviceTimes::contact_sum), r.pass.platens = per(&DeviceTimes::platens);
  r.pass.pressure = per(&DeviceTimes::pressure), r.pass.integrate = per(&DeviceTimes::integrate);
  r.pass.energy = per(&DeviceTimes::energy), r.pass.copies = per(&DeviceTimes::copies);
}

/// One row: a box of n x n x nz cells under scene s with the schedule and blocks per SM. False
/// where the CUDA backend has no fused pass for those blocks on this mesh (no row).
bool measure_row(const Scene& s, int n, int nz, const std::string& schedule, const std::string& blocks, int steps,
                 double bw, Row& r) {
  const Backend b = s.solver.backend;
  // The host's peak resident memory over what is resident before this row's model (the last
  // row's freed heap given back first, so that reusing it does not hide this one's growth);
  // the device's peak from what is in use now. Each row builds its own model.
  malloc_trim(0);
  const bool peak_reset = device::reset_host_peak();
  if (!peak_reset)
    std::fprintf(stderr, "bench_device: /proc/self/clear_refs refused: host bytes per tet include earlier sizes\n");
  const double resident0 = double(device::host_resident());
  device::reset_peak_bytes();
  setenv("FDEM_DEVICE_SCHEDULE", schedule.c_str(), 1);  // read when the Solver makes its device loop
  setenv("FDEM_CUDA_BLOCKS_PER_SM", blocks.c_str(), 1);
  const auto t_setup = Clock::now();
  Solver solver(s, build_model(structured_box_mesh({0.057, 0.057, 0.129}, n, n, nz), s));
  r.setup_s = since(t_setup);
  DeviceLoop* dev = solver.device_loop();
  if (b == Backend::cuda && dev->blocks_per_sm() != std::atoi(blocks.c_str())) {
    std::fprintf(stderr, "bench_device: %s with %s blocks per SM: no fused pass on this mesh, row left out\n",
                 schedule.c_str(), blocks.c_str());
    return false;
  }
  for (int i = 0; i < 20; ++i) solver.step();
  solver.sync_host();
  device::synchronize(b);
  r.schedule = dev->integrates() ? "fused+step" : dev->fused() ? "fused" : "colour";
  if (b == Backend::cuda && dev->blocks_per_sm() > 1)
    r.schedule += ", " + std::to_string(dev->blocks_per_sm()) + " blocks/SM";
  r.tets = long(solver.model().tet_nodes.size());
  r.ce6 = long(solver.model().ce6_nodes.size());
  r.nodes = long(solver.model().X.size());
  r.dt = solver.dt();
  time_steps(solver, b, steps, r);
  r.bytes = dev->bytes_per_step();
  r.floor_us = 1e6 * r.bytes / (bw * 1e9);
  auto t0 = Clock::now();
  const Monitors m = solver.measure();
  r.monitor_ms = 1e3 * since(t0);
  r.pairs = m.contact_pairs;
  solver.step();
  device::synchronize(b);
  t0 = Clock::now();
  solver.sync_host();  // the whole evolving state to the host (output, checkpoints, peak frames)
  r.sync_ms = 1e3 * since(t0);
  r.mem_mb = double(device::peak_bytes()) / 1e6;
  r.host_bytes = double(device::host_peak_resident()) - (peak_reset ? resident0 : 0.0);
  // Progress on stderr, so that a run stopped at a time limit still shows its finished rows.
  std::fprintf(stderr, "bench_device: %ld tets, %s: %.1f us per step, floor %.1f us, %.0f MB device memory\n", r.tets,
               r.schedule.c_str(), r.step_us, r.floor_us, r.mem_mb);
  return true;
}

/// The two tables: each row's step against the floor, and its passes.
void print_tables(const std::vector<Row>& rows, double bw) {
  std::printf(
      "| tets | CE6 | nodes | pairs | schedule | step, us | floor, us | step / floor | GB/s | of measured | monitor "
      "row, ms | state to host, ms | device memory peak, MB | copies to host per step | bytes to host per step "
      "| launches per step (queued before the host waits) | host peak, bytes per tet | set-up, s "
      "|\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    std::printf(
        "| %ld | %ld | %ld | %ld | %s | %.1f | %.1f | %.2f | %.0f | %.0f %% | %.2f | %.2f | %.0f | %.1f | %.0f | %.1f "
        "(%.1f) | %.0f | %.1f |\n",
        r.tets, r.ce6, r.nodes, r.pairs, r.schedule.c_str(), r.step_us, r.floor_us, r.step_us / r.floor_us,
        r.bytes / (r.step_us * 1e3), 100 * r.bytes / (r.step_us * 1e3) / bw, r.monitor_ms, r.sync_ms, r.mem_mb,
        r.copies_to_host, r.bytes_to_host, r.launches, r.launches_ahead, r.host_bytes / double(r.tets), r.setup_s);
  std::printf(
      "\nPer pass, us per step (device waited for after each pass; fused: TET4 and CE6 in one pass, its time "
      "under CE6):\n\n| tets | schedule | TET4 | CE6 | activation | broad "
      "| narrow and friction | contact sum | platens | pressure | integrate | energy sums | copies | "
      "sum |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    std::printf("| %ld | %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n",
                r.tets, r.schedule.c_str(), r.pass.tet4, r.pass.ce6, r.pass.activation, r.pass.broad, r.pass.narrow,
                r.pass.contact_sum, r.pass.platens, r.pass.pressure, r.pass.integrate, r.pass.energy, r.pass.copies,
                r.pass.total());
}

/// The largest model that fits, and the paper's UCS run at the largest size's step per tet.
void print_projections(Backend b, const std::vector<Row>& rows, double device_free, double host_free,
                       double mass_scaling) {
  const Fit fit = largest_fit(b, rows, device_free, host_free);
  std::printf(
      "\nLargest model that fits: about %.3g tets (%s: %.1f GB free at the start, %.0f bytes per tet on the "
      "device; host: %.1f GB available, %.0f bytes per tet of peak resident memory; a tenth kept free; from the "
      "largest size above)\n",
      double(fit.tets), b == Backend::cuda ? "GPU" : "host memory", fit.device_free / 1e9, fit.device_per_tet,
      fit.host_free / 1e9, fit.host_per_tet);
  const double paper_tets = 670005, paper_steps = 0.0192 / 5.79e-9 * std::sqrt(5.0 / mass_scaling);
  for (const Row& big : rows) {  // the largest size, each schedule
    if (big.tets != rows.back().tets) continue;
    const double us_per_step = big.step_us * paper_tets / double(big.tets);
    std::printf(
        "\nPaper UCS (670,005 tets, 0.02 m/s, m = %g), %s: %.3g steps to the post-peak stage; at %.1f us per step "
        "(the largest size scaled by tets) %.0f s = %.1f min of steps (pre-peak contact; the floor alone "
        "gives %.1f min)\n",
        mass_scaling, big.schedule.c_str(), paper_steps, us_per_step, us_per_step * 1e-6 * paper_steps,
        us_per_step * 1e-6 * paper_steps / 60, big.floor_us * paper_tets / double(big.tets) * 1e-6 * paper_steps / 60);
  }
}

/// The header lines: the backend, its measured copy bandwidth (returned, GB/s), the settings.
double print_header(Backend b, const Options& o) {
  const double bw = device::copy_bandwidth(b, std::size_t(1) << (b == Backend::cuda ? 30 : 27));
  std::printf("# bench_device: backend %s%s, measured copy bandwidth %.0f GB/s\n\n", o.backend.c_str(),
              b == Backend::cuda ? (" (" + cuda_device_description() + ")").c_str() : " (host memory)", bw);
  std::printf("%d steps per measurement, mass scaling %g, contact %s\n\n", o.steps, o.mass_scaling, o.contact.c_str());
#ifdef FDEM_CUDA_FMAD
  const char* fmad = "on (FDEM_CUDA_FMAD=ON: not the CPU backend's bits)";
#else
  const char* fmad = "off (the CPU backend's bits)";
#endif
  if (b == Backend::cuda) std::printf("nvcc fused multiply-adds: %s\n\n", fmad);
  return bw;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse_options(argc, argv, o)) return 2;
  MPI_Init(&argc, &argv);
  const Backend b = parse_backend(o.backend, "--backend");
  Activation activation = Activation::adaptive;
  if (!choice_named(o.contact, activation)) {
    std::fprintf(stderr, "--contact %s: allowed: %s\n", o.contact.c_str(), choice_list<Activation>(", ").c_str());
    return 2;
  }
  const double device_free = double(device::memory_available(b)),
               host_free = double(device::memory_available(Backend::cpu));
  // The debug backend scrambles the order of each pass's iterations to expose races
  // (core/forall.hpp), at a cost in cache misses; timings run them in index order.
  set_host_order(HostOrder::forward);
  const double bw = print_header(b, o);
  std::vector<std::pair<std::string, std::string>> variants;
  if (!row_variants(b, o, variants)) {
    MPI_Finalize();
    return 2;
  }
  const Scene s = bench_scene(b, activation, o.mass_scaling);
  std::vector<Row> rows;
  for (long target : o.sizes) {
    if (target == kLargest) {
      target = largest_fit(b, rows, device_free, host_free).tets;
      if (target <= 0) {
        std::fprintf(stderr,
                     "bench_device: --tets max needs a smaller size before it (it scales the bytes per tet of "
                     "the largest size run before it). Fix: e.g. --tets 100000,max\n");
        MPI_Finalize();
        return 2;
      }
      std::printf("--tets max: %ld tets\n\n", target);
      std::fflush(stdout);
    }
    // Cells n x n x round(2.26 n), 6 tets each.
    const int n = std::max(2, int(std::lround(std::cbrt(double(target) / (6 * 2.263)))));
    const int nz = std::max(2, int(std::lround(2.263 * n)));
    for (const auto& [schedule, blocks] : variants) {
      Row r;
      if (measure_row(s, n, nz, schedule, blocks, o.steps, bw, r)) rows.push_back(r);
    }
    unsetenv("FDEM_DEVICE_SCHEDULE");
    unsetenv("FDEM_CUDA_BLOCKS_PER_SM");
  }
  print_tables(rows, bw);
  print_projections(b, rows, device_free, host_free, o.mass_scaling);
  MPI_Finalize();
  return 0;
}
