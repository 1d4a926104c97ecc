// CPU benchmark of the time step: for UCS cylinders of three element sizes, time per
// step, element updates per second per core, bytes moved per step, memory per tet.
// Usage: bench_step [--sizes 0.004,0.0025,0.0016] [--steps N] [--threads T]
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/mesh_io.hpp"
#include "solver/solver.hpp"

using namespace fdem;

namespace {

template <class T>
double bytes_of(const std::vector<T>& v) {
  return double(v.size() * sizeof(T));
}

/// Bytes one step reads and writes, counted array by array (each element of each array
/// touched once per step; gathers through node ids counted once per element reference,
/// since a colour-ordered sweep does not keep a node in cache between elements).
double bytes_per_step(const Solver& s) {
  const Model& m = s.model();
  const double nn = double(m.X.size()), nt = double(m.tet_nodes.size()), nc = double(m.ce6_nodes.size()),
               np = double(m.platen_nodes.size());
  const double v3 = sizeof(Vec3), r = sizeof(real), i = sizeof(int);
  double b = 0;
  b += nn * v3;                                                 // zero f
  b += nt * (4 * i + sizeof(Mat3) + 2 * r + 4 * (3 * v3));      // tets: ids, Xinv, V0, eta; x, v read, f read+write
  b += nc * (6 * i + r + 2 * sizeof(Ce6State) + 6 * (3 * v3));  // CE6: ids, h, state r+w; x, v, f r+w
  b += np * (i + r + 2 * v3 + 3 * v3);                          // platen: id, k, anchor r+w; x, f r+w
  b += nn * (5 * v3 + r);                                       // integrate: x, v r+w, f, 1/m
  return b;
}

double state_bytes(const Solver& s) {
  const Model& m = s.model();
  return bytes_of(m.X) + bytes_of(m.mass) + bytes_of(m.node_vertex) + bytes_of(m.tet_nodes) + bytes_of(m.tet_input) +
         bytes_of(m.tet_Xinv) + bytes_of(m.tet_V0) + bytes_of(m.tet_eta) + bytes_of(m.tet_colours.order) +
         bytes_of(m.ce6_nodes) + bytes_of(m.ce6_tets) + bytes_of(m.ce6_h) + bytes_of(m.ce6_colours.order) +
         bytes_of(m.surface_faces) + bytes_of(m.surface_tet) + bytes_of(m.platen_nodes) + bytes_of(m.platen_node_area) +
         bytes_of(m.platen_node_h) + bytes_of(m.top_nodes) + bytes_of(m.bottom_nodes) + bytes_of(m.lateral_nodes) +
         bytes_of(s.x) + bytes_of(s.v) + bytes_of(s.f) + bytes_of(s.ce6) + bytes_of(s.platen_anchor) +
         double(m.X.size() * sizeof(real)) /* 1/m */ + double(m.platen_nodes.size() * sizeof(real)) /* platen k */;
}

std::vector<double> parse_list(const char* s) {
  std::vector<double> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(std::stod(item));
  return out;
}

std::string cpu_name() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> sizes = {0.004, 0.0025, 0.0016};
  int steps = 300, max_threads = omp_get_num_procs();
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--sizes") && a + 1 < argc)
      sizes = parse_list(argv[++a]);
    else if (!std::strcmp(argv[a], "--steps") && a + 1 < argc)
      steps = std::stoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--threads") && a + 1 < argc)
      max_threads = std::stoi(argv[++a]);
    else {
      std::fprintf(stderr, "usage: %s [--sizes a,b,c] [--steps N] [--threads T]\n", argv[0]);
      return 2;
    }
  }
  std::printf("# fdem CPU step benchmark\n\nmachine: %s, %d cores; command:", cpu_name().c_str(), omp_get_num_procs());
  for (int a = 0; a < argc; ++a) std::printf(" %s", argv[a]);
  std::printf("\nUCS cylinder 0.02 m x 0.04 m, Table 2 limestone, CE6 everywhere, m = 5, platens at 0.1 m/s\n\n");
  std::printf(
      "| element size (m) | tets | CE6 | nodes | threads | us/step | M element updates/s/core | MB/step | GB/s | "
      "bytes/tet | monitor row (ms) |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (double h : sizes) {
    MeshSpec spec;
    spec.shape = "cylinder";
    spec.diameter = 0.02;
    spec.height = 0.04;
    spec.element_size = h;
    const Mesh mesh = generate_mesh(spec);
    Scene scene;
    scene.solver.mass_scaling = 5;
    scene.platens.velocity = 0.1;
    for (int threads = 1; threads <= max_threads; threads *= 2) {
      scene.solver.threads = threads;
      Solver s(scene, build_model(mesh, scene));
      for (int i = 0; i < steps / 5; ++i) s.step();  // warm-up
      const auto t0 = std::chrono::steady_clock::now();
      for (int i = 0; i < steps; ++i) s.step();
      const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const auto t1 = std::chrono::steady_clock::now();
      s.measure();
      const double mon = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
      const Model& m = s.model();
      const double elems = double(m.tet_nodes.size() + m.ce6_nodes.size());
      const double per_step = sec / steps, bytes = bytes_per_step(s);
      std::printf("| %.4g | %zu | %zu | %zu | %d | %.0f | %.2f | %.2f | %.2f | %.0f | %.2f |\n", h, m.tet_nodes.size(),
                  m.ce6_nodes.size(), m.X.size(), threads, per_step * 1e6, elems / per_step / threads / 1e6,
                  bytes / 1e6, bytes / per_step / 1e9, state_bytes(s) / m.tet_nodes.size(), mon * 1e3);
      std::fflush(stdout);
    }
  }
  return 0;
}
