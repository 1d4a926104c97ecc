// bench_cpu: speed of the cpu backend's time step (Solver::step) on UCS cylinders of several mesh sizes.
//
// For each element size: generate a 0.02 m x 0.04 m cylinder with gmsh, build the model with
// the default scene (Table 2 limestone, CE6 on every internal face, mass scaling 5, platens
// approaching at 0.1 m/s, no output), warm up, then time N calls of Solver::step() with
// nothing else in the loop. Solver::measure() (one monitor row) is timed on its own.
// Each size runs with 1 thread and with T threads (T = --threads, default all cores).
// The N timed steps run in 5 chunks: "best" is the fastest chunk (the step's own cost on a
// shared machine), "median" the middle one; "others' load" is the CPU time other processes
// used meanwhile (/proc/stat minus this process), in cores: a row with others' load near a
// whole core is disturbed, above all with T threads on a machine of T cores.
// A second table times variants of the largest model on 1 thread (platens off, no CE6)
// to show where a step's time goes.
//
// Usage: bench_cpu [--sizes 0.004,0.0025,0.0013] [--steps N] [--threads T] [--no-variants] [--ftz]
// (--ftz: diagnostic, flush subnormals to zero on every thread.)
// Prints Markdown on stdout. This is a benchmark, not a test: it checks nothing.
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

#include "io/mesh_io.hpp"
#include "model/model.hpp"
#include "solver/solver.hpp"

namespace {

using fdem::Ce6State;
using fdem::Mat3;
using fdem::Model;
using fdem::real;
using fdem::Scene;
using fdem::Solver;
using fdem::Vec3;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Bytes held by a vector's elements (size, not capacity).
template <class T>
double held(const std::vector<T>& a) {
  return double(a.size()) * double(sizeof(T));
}

/// Traffic model of one Solver::step() on the cpu backend's default schedule, the colour passes
/// (solver/device_loop_impl.hpp), in the state the solver is in now, in bytes; contact is not
/// counted. Two counts:
///  per_reference: every array element that the step's loops touch, counted each time a
///    loop touches it. Node data gathered through element node ids is counted once per
///    element corner (a tet's 4 corners, a CE6's 6), since with split nodes and
///    colour-ordered sweeps a node is rarely still in cache. This is the traffic if nothing
///    is reused from cache.
///  once: each array that the step touches counted once (read, plus write where written):
///    the compulsory traffic, a lower bound.
/// What one step does and what is counted, with nn nodes, nt tets, nc CE6, np platen nodes:
///  integrate (per node): read x, v, f (3 x 24 B) and m (8 B), write x, v (2 x 24 B);
///  forces start: with gravity f written from m (32 B per node); without, the first TET4 to
///    reach a node assigns its force and only the nodes no TET4 reaches are zeroed (28 B);
///  TET4 sweep (per tet): colour order entry (4 B), tet node ids (16 B), Xinv (72 B),
///    V0 (8 B), eta (8 B), the assign mask (1 B); per corner: read x, v (48 B), write f
///    (24 B), and read f (24 B) where the corner does not assign;
///  CE6 sweep (per CE6): colour order entry (4 B), damage and mode read (32 B); where it
///    carries force: node ids (24 B), h (8 B), per node read x, v and read+write f (96 B);
///    where damaged: the damage written (an upper bound: only when it rises) and the friction
///    anchors read and written (2 x 72 B);
///  platens (per platen node): node id (4 B), stiffness k (8 B), friction anchor read+write
///    (48 B), read x (24 B), read+write f (48 B).
/// Not counted: the colour offsets, scalar reductions, the fixed-node list (empty here).
struct Traffic {
  double per_reference = 0, once = 0;
};

Traffic step_traffic(const Solver& s) {
  s.sync_host();  // (the CE6 states below)
  const Model& m = s.model();
  const double nn = double(m.X.size()), nt = double(m.tet_nodes.size()), nc = double(m.ce6_nodes.size());
  const double np = s.scene().platens.enabled ? double(m.platen_nodes.size()) : 0;
  const double V = sizeof(Vec3), R = sizeof(real), I = sizeof(int);
  const bool gravity = s.scene().has_gravity();
  std::vector<char> reached(m.X.size(), 0);
  for (const auto& q : m.tet_nodes)
    for (int n : q) reached[n] = 1;
  double reached_nodes = 0;
  for (char r : reached) reached_nodes += r;
  double carrying = 0, damaged = 0;
  const fdem::Ce6Params p = s.laws().ce6[0];
  for (const fdem::Ce6Damage& c : s.state.ce6.damage) {
    const bool carries = fdem::ce6_carries_force(p, c);
    carrying += carries;
    damaged += carries && fdem::ce6_max_damage(c) > 0;
  }
  const double integrate = nn * (3 * V + R + 2 * V);
  const double start = gravity ? nn * (V + R) : (nn - reached_nodes) * (V + I);
  const double read_f = gravity ? 4 * nt : 4 * nt - reached_nodes;  // corners that add
  const double tet_own = nt * (I + 4 * I + sizeof(Mat3) + 2 * R + 1);
  const double ce6_own = nc * (I + sizeof(fdem::Ce6Damage)) + carrying * (6 * I + R) +
                         damaged * (sizeof(fdem::Ce6Damage) + 2 * sizeof(fdem::Ce6Anchors));
  const double platen_own = np * (I + R + 2 * V);
  Traffic t;
  t.per_reference = integrate + start + tet_own + nt * 4 * (2 * V + V) + read_f * V + ce6_own +
                    carrying * 6 * (2 * V + 2 * V) + platen_own + np * (V + 2 * V);
  // Once: x, v read + written, f written by the sweeps and read by the integration (read by the
  // sweeps too where a corner adds, from cache once written); 1/m read; the element arrays.
  t.once = nn * (2 * V + 2 * V + 2 * V + R) + (gravity ? nn * R : 0) + tet_own + ce6_own + platen_own;
  return t;
}

/// All state the model and the solver hold for the run, in bytes: every array of Model and
/// every array of Solver (the private ones by their known sizes: platen stiffness per platen
/// node; the prescribed-node lists are empty in this scene), and the arrays the time loop
/// allocates for itself (device::bytes_in_use; those it borrows from the two are not counted
/// again).
double state_bytes(const Solver& s) {
  const Model& m = s.model();
  double b = held(m.X) + held(m.mass) + held(m.node_vertex);
  b += held(m.tet_nodes) + held(m.tet_input) + held(m.tet_Xinv) + held(m.tet_V0) + held(m.tet_eta);
  b += held(m.tet_colours.order) + held(m.tet_colours.offsets);
  b += held(m.ce6_nodes) + held(m.ce6_tets) + held(m.ce6_h);
  b += held(m.ce6_colours.order) + held(m.ce6_colours.offsets);
  b += held(m.surface_faces) + held(m.surface_tet) + held(m.platen_nodes) + held(m.platen_node_area) +
       held(m.platen_node_h) + held(m.top_nodes) + held(m.bottom_nodes) + held(m.lateral_nodes);
  b += held(s.state.x) + held(s.state.v) + held(s.state.f) + held(s.state.ce6.damage) + held(s.state.ce6.anchors) +
       held(s.loads().platens.anchor);
  b += double(m.platen_nodes.size()) * sizeof(real);  // Solver::platen_k_
  b += double(fdem::device::bytes_in_use());
  return b;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.compare(0, 10, "model name") == 0) {
      const auto colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  return "(unknown CPU)";
}

/// CPU ticks (1/sysconf(_SC_CLK_TCK) s) spent busy by the whole machine (/proc/stat) and by
/// this process (/proc/self/stat), to report how much of the machine others used meanwhile.
struct Ticks {
  double machine = 0, self = 0;
};

Ticks read_ticks() {
  Ticks t;
  std::ifstream stat("/proc/stat");
  std::string cpu;
  double user = 0, nice = 0, sys = 0, idle = 0, iowait = 0, irq = 0, softirq = 0, steal = 0;
  if (stat >> cpu >> user >> nice >> sys >> idle >> iowait >> irq >> softirq >> steal)
    t.machine = user + nice + sys + irq + softirq + steal;
  std::ifstream self("/proc/self/stat");
  std::string line;
  std::getline(self, line);
  const auto close = line.rfind(')');  // fields after the command name; utime, stime are 14, 15
  if (close != std::string::npos) {
    std::istringstream rest(line.substr(close + 2));
    std::string field;
    for (int i = 3; i <= 15 && rest >> field; ++i)
      if (i == 14 || i == 15) t.self += std::atof(field.c_str());
  }
  return t;
}

bool parse_sizes(const std::string& text, std::vector<double>& out) {
  out.clear();
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    char* end = nullptr;
    const double h = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !(h > 0)) return false;
    out.push_back(h);
    start = comma + 1;
  }
  return !out.empty();
}

Scene bench_scene(int threads) {
  Scene s;  // defaults: Table 2 limestone, CE6 everywhere, platens enabled
  s.name = "bench_cpu";
  s.file = "(bench_cpu)";
  s.solver.mass_scaling = 5;
  s.solver.threads = threads;
  s.platens.velocity = 0.1;
  s.output.progress_interval = 0;
  s.output.plot = false;
  s.output.monitor_interval = 0;
  s.output.field_interval = 0;
  return s;
}

struct Timing {
  std::size_t tets = 0, ce6 = 0, nodes = 0;
  double step_s = 0;     // seconds per step, best of the chunks
  double median_s = 0;   // seconds per step, median of the chunks
  double others = 0;     // cores' worth of CPU used by other processes during the timed steps
  double monitor_s = 0;  // seconds per measure()
  Traffic traffic;
  double state = 0;  // bytes
};

Timing time_steps(const fdem::Mesh& mesh, const Scene& scene, int steps, bool with_monitor) {
  omp_set_num_threads(std::max(1, scene.solver.threads));  // gmsh may have changed it
  Solver solver(scene, fdem::build_model(mesh, scene));
  const int warmup = std::max(20, steps / 10);
  for (int i = 0; i < warmup; ++i) solver.step();
  // The timed steps run in chunks; the machine is shared, so the best chunk is the
  // step's own cost and the median shows how much others disturbed it.
  const int chunks = std::min(steps, 5);
  std::vector<double> per_step;
  const Ticks k0 = read_ticks();
  const auto t0 = Clock::now();
  for (int c = 0; c < chunks; ++c) {
    const int n = steps / chunks + (c < steps % chunks ? 1 : 0);
    const auto tc = Clock::now();
    for (int i = 0; i < n; ++i) solver.step();
    per_step.push_back(seconds_since(tc) / n);
  }
  const double wall = seconds_since(t0);
  const Ticks k1 = read_ticks();
  Timing r;
  std::sort(per_step.begin(), per_step.end());
  r.step_s = per_step.front();
  r.median_s = per_step[per_step.size() / 2];
  r.others = std::max(0.0, (k1.machine - k0.machine) - (k1.self - k0.self)) / double(sysconf(_SC_CLK_TCK)) / wall;
  if (with_monitor) {
    const int rows = 5;
    const auto t1 = Clock::now();
    for (int i = 0; i < rows; ++i) solver.measure();
    r.monitor_s = seconds_since(t1) / rows;
  }
  const Model& m = solver.model();
  r.tets = m.tet_nodes.size();
  r.ce6 = m.ce6_nodes.size();
  r.nodes = m.X.size();
  r.traffic = step_traffic(solver);
  r.state = state_bytes(solver);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> sizes{0.004, 0.0025, 0.0013};
  int steps = 300;
  int threads = int(std::max(1u, std::thread::hardware_concurrency()));
  bool variants = true, ftz = false;
  for (int a = 1; a < argc; ++a) {
    const std::string opt = argv[a];
    const bool has_value = a + 1 < argc;
    if (opt == "--sizes" && has_value && parse_sizes(argv[a + 1], sizes)) {
      ++a;
    } else if (opt == "--steps" && has_value && (steps = std::atoi(argv[a + 1])) > 0) {
      ++a;
    } else if (opt == "--threads" && has_value && (threads = std::atoi(argv[a + 1])) > 0) {
      ++a;
    } else if (opt == "--no-variants") {
      variants = false;
    } else if (opt == "--ftz") {
      ftz = true;
    } else {
      std::fprintf(stderr, "usage: %s [--sizes a,b,c (m, > 0)] [--steps N (> 0)] [--threads T (> 0)] [--no-variants]\n",
                   argv[0]);
      return 2;
    }
  }

  if (ftz) {
#if defined(__SSE2__)
    // Diagnostic only: flush subnormal results and inputs to zero on every OpenMP thread
    // (MXCSR FTZ | DAZ), to see whether subnormal arithmetic slows the step down.
#pragma omp parallel num_threads(threads)
    _mm_setcsr(_mm_getcsr() | 0x8040);
    _mm_setcsr(_mm_getcsr() | 0x8040);
#else
    std::fprintf(stderr, "--ftz needs SSE2; ignored\n");
#endif
  }
  std::printf("# bench_cpu\n\n");
  std::printf("- machine: %s, %u logical CPUs (nproc)\n", cpu_model().c_str(), std::thread::hardware_concurrency());
  std::printf("- command:");
  for (int a = 0; a < argc; ++a) std::printf(" %s", argv[a]);
  std::printf(
      "\n- scene: UCS cylinder d = 0.02 m, h = 0.04 m (gmsh), Table 2 limestone, CE6 on every internal face, "
      "mass scaling 5, platens at 0.1 m/s; %d timed steps after %d warm-up steps\n\n",
      steps, std::max(20, steps / 10));
  std::printf(
      "| element size (m) | tets | CE6 | nodes | threads | µs/step (best) | µs/step (median) | "
      "M element updates/s/core | MB/step (per reference) | MB/step (each array once) | "
      "GB/s (per reference) | bytes of state/tet | monitor row (ms) | others' load (cores) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::fflush(stdout);

  std::vector<int> thread_counts{1};
  if (threads > 1) thread_counts.push_back(threads);
  const fdem::Mesh* largest = nullptr;
  std::vector<fdem::Mesh> meshes;
  meshes.reserve(sizes.size());
  for (double h : sizes) {
    fdem::MeshSpec spec;
    spec.shape = fdem::MeshShape::cylinder;
    spec.diameter = 0.02;
    spec.height = 0.04;
    spec.element_size = h;
    meshes.push_back(fdem::generate_mesh(spec));
    const fdem::Mesh& mesh = meshes.back();
    if (!largest || mesh.tets.size() > largest->tets.size()) largest = &mesh;
    for (int t : thread_counts) {
      const Timing r = time_steps(mesh, bench_scene(t), steps, true);
      const double updates = double(r.tets + r.ce6) / r.step_s / t;
      std::printf("| %g | %zu | %zu | %zu | %d | %.0f | %.0f | %.2f | %.2f | %.2f | %.2f | %.0f | %.2f | %.2f |\n", h,
                  r.tets, r.ce6, r.nodes, t, r.step_s * 1e6, r.median_s * 1e6, updates / 1e6,
                  r.traffic.per_reference / 1e6, r.traffic.once / 1e6, r.traffic.per_reference / r.step_s / 1e9,
                  r.state / double(r.tets), r.monitor_s * 1e3, r.others);
      std::fflush(stdout);
    }
  }

  if (variants && largest) {
    std::printf("\nWhere the time goes (largest mesh, %zu tets, 1 thread):\n\n", largest->tets.size());
    std::printf(
        "| variant | tets | CE6 | nodes | µs/step (best) | µs/step (median) | others' load (cores) |\n"
        "|---|---|---|---|---|---|---|\n");
    struct Variant {
      const char* name;
      bool platens, ce6;
    };
    const Variant list[] = {{"full step", true, true},
                            {"platens disabled", false, true},
                            {"no CE6 (fracture regions none: continuous mesh)", true, false},
                            {"no CE6, platens disabled", false, false}};
    for (const Variant& v : list) {
      Scene s = bench_scene(1);
      s.platens.enabled = v.platens;
      if (!v.ce6) {
        s.fracture.everywhere = false;
        s.fracture.boxes.clear();
      }
      const Timing r = time_steps(*largest, s, steps, false);
      std::printf("| %s | %zu | %zu | %zu | %.0f | %.0f | %.2f |\n", v.name, r.tets, r.ce6, r.nodes, r.step_s * 1e6,
                  r.median_s * 1e6, r.others);
      std::fflush(stdout);
    }
  }
  return 0;
}
