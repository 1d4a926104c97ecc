// bench_gather (MPI, 2 ranks): the time of the gatherings of contact ghosts that add tets.
// Two blocks of n x n x n cells (6 n^3 tets each, 0.01 m, CE6s inside): the lower one on rank
// 0, the upper one on rank 1, starting 0.5 mm apart and closing at 20 m/s (--speed), with a
// contact reach of 0.3 mm. At the start neither rank holds a tet of the other block; as they
// close, each gathering brings the other block's tets that came within the reach.
//
//   mpiexec -n 2 build/bench/bench_gather [--cells 12] [--steps 1600] [--threads 1] [--speed 20]
//
// Per gathering: the step, the tets it added (both ranks), and its wall time (the slowest
// rank's, from the Solver's own count), beside the mean step time of the run.
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "model/model.hpp"
#include "model/structured.hpp"
#include "partition/partition.hpp"
#include "solver/solver.hpp"

using namespace fdem;

namespace {

constexpr real kGap = 5e-4, kReach = 3e-4;  // m, m

Mesh two_blocks(int cells) {
  Mesh a = structured_box_mesh({0.01, 0.01, 0.01}, cells, cells, cells);
  const Mesh b = structured_box_mesh({0.01, 0.01, 0.01}, cells, cells, cells);
  const int off = int(a.vertices.size());
  for (Vec3 p : b.vertices) a.vertices.push_back(p + Vec3{0.001, 0.0005, 0.01 + kGap});
  for (auto q : b.tets) a.tets.push_back({q[0] + off, q[1] + off, q[2] + off, q[3] + off});
  a.source = "two blocks";
  return a;
}

bool upper(const Model& m, int t) {
  real z = 0;
  for (int n : m.tet_nodes[t]) z += 0.25 * m.X[n].z;
  return z > 0.01;
}

double max_over_ranks(double v) {
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int cells = 12, threads = 1;
  real speed = 20;  // m/s: faster for a large block, which takes many steps to close the gap
  long steps = 1600;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--cells") cells = std::atoi(argv[i + 1]);
    if (a == "--steps") steps = std::atol(argv[i + 1]);
    if (a == "--threads") threads = std::atoi(argv[i + 1]);
    if (a == "--speed") speed = std::atof(argv[i + 1]);
  }
  if (size != 2) {
    if (rank == 0) std::fprintf(stderr, "bench_gather: run it on 2 ranks (mpiexec -n 2)\n");
    MPI_Finalize();
    return 2;
  }
  Scene scene;
  scene.name = "bench_gather";
  scene.platens.enabled = false;
  scene.contact.activation = Activation::full;
  scene.solver.mass_scaling = 10;
  scene.solver.threads = threads;
  const Model global = build_model(two_blocks(cells), scene);
  std::vector<int> part(global.tet_nodes.size());
  for (std::size_t t = 0; t < part.size(); ++t) part[t] = upper(global, int(t)) ? 1 : 0;
  RankModel rm = extract_rank(global, part, rank, kReach);
  Solver s(scene, std::move(rm.model), std::move(rm.dd), MPI_COMM_WORLD);
  s.sync_host();
  for (std::size_t t = 0; t < s.model().tet_nodes.size(); ++t)
    if (upper(s.model(), int(t)))
      for (int n : s.model().tet_nodes[t]) s.state.v[n] = {0, 0, -speed};
  s.host_changed();
  if (rank == 0)
    std::printf("two blocks of %d^3 cells, %zu tets, closing at %g m/s; reach %g m, dt %.3g s\n\n", cells,
                global.tet_nodes.size(), speed, kReach, s.dt());
  if (rank == 0) std::printf("| step | tets added | gathering, s | steps' worth |\n|---|---|---|---|\n");
  GhostGrowths seen = s.ghost_growths();
  double stepping = 0;
  long stepped = 0;
  for (long k = 0; k < steps; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    s.step();
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const GhostGrowths& g = s.ghost_growths();
    if (g.count == seen.count) {
      stepping += dt, ++stepped;
      continue;
    }
    long added = g.tets - seen.tets;
    MPI_Allreduce(MPI_IN_PLACE, &added, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    const double took = max_over_ranks(g.seconds - seen.seconds);
    if (rank == 0 && added > 0)
      std::printf("| %ld | %ld | %.4f | %.1f |\n", g.step, added, took, took / (stepping / std::max(1L, stepped)));
    seen = g;
  }
  const double step_time = max_over_ranks(stepping / std::max(1L, stepped));
  if (rank == 0)
    std::printf("\nmean step %.3g s over %ld steps; %ld gatherings, %ld of them adding no tet\n", step_time, stepped,
                seen.count, seen.unchanged);
  MPI_Finalize();
  return 0;
}
