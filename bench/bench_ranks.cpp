// bench_ranks: what several MPI ranks cost and gain on the CPU backend, and a model of weak
// scaling from measured halo sizes.
//
// Part 1 (run it under mpiexec with 1 and with 2 ranks): for each structured box (Kuhn tets,
// 2:1 height, CE6 everywhere, Table 2 rock, platens at 0.1 m/s, mass scaling 5, no contact
// unless --contact), partition with METIS over the ranks and time N steps: wall time per
// step (slowest rank; the fastest of 5 chunks), the part of it spent in the node halo exchange
// (slowest rank; it includes waiting for the other ranks, i.e. load imbalance), halo
// bytes sent per step (largest rank and all ranks), ghost tets against own tets, neighbours.
//
// Part 2 (--weak N, one process): weak scaling without running the ranks. A box of about N
// tets per rank times P is partitioned for each P of --ranks (default 1,2,8,64); for a sample
// of ranks the halo is built exactly as a run would build it, giving the largest ghost-node
// count, neighbour count and ghost-tet fraction. The time per step is then modelled as
//   t(P) = t_tet * own * (1 + elements computed twice / own elements)
//          + t_contact * own * (1 + own tets on the rank border / own)
//          + neighbours * latency + bytes / bandwidth + ceil(log2 P) * latency
// with t_tet measured per own tet-step (part 1 or --tet-us) and the latency and bandwidth
// given (--latency-us, --gbps; defaults 2 us and 12.5 GB/s, an HDR100 InfiniBand link; these
// are assumptions, not measurements). The last term is the step's one reduction over the
// ranks (recursive doubling). --contact-us C (us per own tet-step of the contact passes,
// every tet a candidate) adds contact: the ranks then also hold the contact ghosts within two
// mean edges, and the positions and velocities of every ghost tet's nodes cross the halo each
// step with a flag per ghost tet (every tet a candidate: the halo at its largest, counted on the
// receiving side). A pair across ranks is evaluated on both, so the own tets with a corner
// where a ghost has one count twice.
//
// --fracture-below F: CE6s only in the lower fraction F of the box (0 < F < 1; default: CE6
// everywhere), where a tet costs about 4 times one outside; --uniform: METIS balances tet counts
// instead of the tets' step cost (partition/partition.hpp, tet_cost_weights).
//
// Usage: mpiexec -n 2 bench_ranks [--cells 6,10,14] [--steps N] [--contact] [--fracture-below F] [--uniform]
//        bench_ranks --weak 20000 [--ranks 1,2,8,64] [--tet-us 0.5] [--contact-us C] [--latency-us 2]
//                    [--gbps 12.5] [--sample 6]
// Prints Markdown. A benchmark, not a test: it checks nothing.
#include <mpi.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "model/structured.hpp"
#include "partition/halo.hpp"
#include "partition/partition.hpp"
#include "solver/solver.hpp"

namespace {

using namespace fdem;

Scene bench_scene(bool contact) {
  Scene s;
  s.name = "bench_ranks";
  s.output.progress_interval = 0;
  s.output.plot = false;
  s.solver.mass_scaling = 5;
  s.platens.velocity = 0.1;
  if (!contact) s.contact.activation = Activation::none;
  return s;
}

/// Box of nx x nx x 2nx cells (6 tets each), 0.01 m cells.
Model box_model(int nx, const Scene& s) {
  return build_model(structured_box_mesh({0.01 * nx, 0.01 * nx, 0.02 * nx}, nx, nx, 2 * nx), s);
}

std::vector<int> parse_ints(const std::string& a) {
  std::vector<int> v;
  std::stringstream in(a);
  for (std::string x; std::getline(in, x, ',');) v.push_back(std::atoi(x.c_str()));
  return v;
}

double max_over(double v) {
  return max_over_ranks(MPI_COMM_WORLD, v);
}
double sum_over(double v) {
  return sum_over_ranks(MPI_COMM_WORLD, v);
}

void measured(const std::vector<int>& cells, int steps, bool contact, double fracture_below, bool uniform) {
  const int rank = rank_in(MPI_COMM_WORLD), size = size_of(MPI_COMM_WORLD);
  Scene scene = bench_scene(contact);
  if (rank == 0) {
    std::printf("\n### %d rank(s), %d OpenMP thread(s) each, %d steps, contact %s, CE6 %s, partition by %s\n\n", size,
                omp_get_max_threads(), steps, contact ? "adaptive" : "none",
                fracture_below > 0 ? ("in the lower " + std::to_string(fracture_below) + " of the height").c_str()
                                   : "everywhere",
                uniform ? "tet count" : "tet cost");
    std::printf(
        "| tets | CE6 | own tets (largest rank) | ghost tets / own | neighbours | us/step | halo us/step | halo share "
        "| "
        "halo kB/step (largest rank) | halo kB/step (all) | us per own tet-step |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n");
  }
  for (int nx : cells) {
    if (fracture_below > 0) {  // the box is 0.02 nx m high
      scene.fracture.everywhere = false;
      scene.fracture.boxes = {{{-1e3, -1e3, -1e3}, {1e3, 1e3, fracture_below * 0.02 * nx}}};
    }
    const Model global = box_model(nx, scene);
    const std::vector<int> part =
        partition_tets(global, size, uniform ? PartitionWeights::uniform : PartitionWeights::cost);
    RankModel rm = extract_rank(global, part, rank, default_reach(global, scene));
    double own = 0, ghost = 0;
    for (auto o : rm.dd.tet_owned) own += o, ghost += !o;
    const double neighbours = double(rm.dd.neighbours.size());
    Solver s(scene, std::move(rm.model), std::move(rm.dd), MPI_COMM_WORLD);
    for (int i = 0; i < std::max(20, steps / 10); ++i) s.step();  // warm up
    // Five chunks; the fastest (slowest rank within it) is the step's own cost on a shared machine.
    double wall = 1e300, halo = 0;
    for (int chunk = 0; chunk < 5; ++chunk) {
      const double halo0 = s.halo_seconds();
      MPI_Barrier(MPI_COMM_WORLD);
      const double t0 = MPI_Wtime();
      for (int i = 0; i < steps / 5; ++i) s.step();
      const double w = max_over(MPI_Wtime() - t0) / (steps / 5);
      const double h = max_over(s.halo_seconds() - halo0) / (steps / 5);
      if (w < wall) wall = w, halo = h;
    }
    const double bytes = double(s.halo_bytes_per_step());
    const double own_max = max_over(own);
    const double ghost_ratio = max_over(own > 0 ? ghost / own : 0);
    const double bytes_max = max_over(bytes), bytes_all = sum_over(bytes), nb = max_over(neighbours);
    if (rank == 0)
      std::printf("| %zu | %zu | %.0f | %.3f | %.0f | %.1f | %.1f | %.1f %% | %.1f | %.1f | %.3f |\n",
                  global.tet_nodes.size(), global.ce6_nodes.size(), own_max, ghost_ratio, nb, 1e6 * wall, 1e6 * halo,
                  100 * halo / wall, bytes_max / 1e3, bytes_all / 1e3, 1e6 * wall / own_max);
  }
}

/// The halo of a sample of ranks of a partition: the largest of each figure over the sample.
struct HaloSample {
  double own = 0, ghost_ratio = 0, border = 0, neighbours = 0, bytes = 0, twice = 0;
};

/// The share of a rank's own tets with a corner where a ghost tet has one: the tets whose
/// contact pairs can reach across ranks, evaluated on both.
double border_share(const RankModel& rm) {
  std::vector<std::tuple<real, real, real>> ghost_corners;
  const Model& m = rm.model;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t)
    if (!rm.dd.tet_owned[t])
      for (int n : m.tet_nodes[t]) ghost_corners.emplace_back(m.X[n].x, m.X[n].y, m.X[n].z);
  std::sort(ghost_corners.begin(), ghost_corners.end());
  double own = 0, border = 0;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    if (!rm.dd.tet_owned[t]) continue;
    bool on = false;
    for (int n : m.tet_nodes[t])
      on = on || std::binary_search(ghost_corners.begin(), ghost_corners.end(),
                                    std::make_tuple(m.X[n].x, m.X[n].y, m.X[n].z));
    own += 1, border += on;
  }
  return own > 0 ? border / own : 0;
}

HaloSample sample_halo(const Model& global, const PartitionPlan& plan, int P, int sample) {
  HaloSample h;
  for (int k = 0; k < std::min(P, sample); ++k) {
    const int r = int((long(k) * P) / std::min(P, sample));  // spread over the rank numbers
    const RankModel rm = extract_rank(global, plan, r);
    double own = 0, ghost = 0, sent = 0, own_elems = 0, twice = 0;
    for (auto o : rm.dd.tet_owned) own += o, ghost += !o;
    // Elements computed on two ranks: CE6s of the boundary (ghost TET4s and the other CE6s
    // are skipped: they act on no owned node).
    for (std::size_t c = 0; c < rm.model.ce6_nodes.size(); ++c) {
      bool touches = false;
      for (int n : rm.model.ce6_nodes[c]) touches = touches || rm.dd.node_owned[n];
      twice += !rm.dd.ce6_owned[c] && touches;
      own_elems += rm.dd.ce6_owned[c];
    }
    own_elems += own;
    h.twice = std::max(h.twice, twice / own_elems);
    for (const Neighbour& n : rm.dd.neighbours) sent += 2.0 * sizeof(Vec3) * double(n.send_nodes.size());
    if (plan.reach > 0) {  // every tet a candidate: the nodes of every ghost tet, and a flag per ghost tet
      std::vector<char> ghost_node(rm.model.X.size(), 0);
      for (std::size_t t = 0; t < rm.model.tet_nodes.size(); ++t)
        if (!rm.dd.tet_owned[t])
          for (int n : rm.model.tet_nodes[t]) ghost_node[n] = !rm.dd.node_owned[n];
      double nodes = 0;
      for (char g : ghost_node) nodes += g;
      sent = std::max(sent, 2.0 * sizeof(Vec3) * nodes + ghost);
    }
    h.own = std::max(h.own, own);
    if (plan.reach > 0) h.border = std::max(h.border, border_share(rm));
    h.ghost_ratio = std::max(h.ghost_ratio, own > 0 ? ghost / own : 0);
    h.neighbours = std::max(h.neighbours, double(rm.dd.neighbours.size()));
    h.bytes = std::max(h.bytes, sent);
  }
  return h;
}

struct WeakCosts {
  double tet_us, contact_us, latency_us, gbps;
};

void weak(long per_rank, const std::vector<int>& ranks, const WeakCosts& c, int sample) {
  const bool contact = c.contact_us > 0;
  const Scene scene = bench_scene(contact);
  std::printf(
      "\n### Weak scaling model: about %ld tets per rank%s\n\n"
      "Measured: partition, ghosts and halo of a sample of %d ranks (the largest shown). Modelled: compute %.3f us "
      "per own tet-step (x (1 + elements computed twice / own elements)), contact %.3f us per own tet-step (x (1 + "
      "own tets on the border / own)), latency "
      "%.1f us per neighbour and per reduction stage, %.1f GB/s per rank.\n\n"
      "| ranks | tets | own tets (largest) | ghost tets / own | computed twice / own elements | border / own | "
      "neighbours | "
      "halo kB/step | compute us | contact us | halo us | reduction us | step us | efficiency vs 1 rank | "
      "largest loss |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
      per_rank, contact ? ", contact" : "", sample, c.tet_us, c.contact_us, c.latency_us, c.gbps);
  double t1 = 0;
  for (int P : ranks) {
    const int nx = std::max(2, int(std::lround(std::cbrt(double(per_rank) * P / 12.0))));
    const Model global = box_model(nx, scene);
    const real reach = contact ? 2 * global.mean_edge : 0;  // a fixed distance: weak scaling
    const PartitionPlan plan = plan_partition(global, partition_tets(global, P), reach);
    const HaloSample h = sample_halo(global, plan, P, sample);
    const double compute = c.tet_us * h.own * (1 + h.twice);
    const double contact_us = c.contact_us * h.own * (1 + h.border);
    const double halo = P > 1 ? h.neighbours * c.latency_us + h.bytes / (c.gbps * 1e3) : 0;
    const double reduce = c.latency_us * std::ceil(std::log2(double(P)));
    const double step = compute + contact_us + halo + reduce;
    if (P == 1) t1 = step / h.own;
    // What the step costs beyond one rank's own work, term by term: the largest names the limit.
    const std::pair<double, const char*> losses[] = {{c.tet_us * h.own * h.twice, "CE6s computed twice"},
                                                     {c.contact_us * h.own * h.border, "contact pairs twice"},
                                                     {h.neighbours * c.latency_us, "neighbour latency"},
                                                     {h.bytes / (c.gbps * 1e3), "halo bytes"},
                                                     {reduce, "reduction"}};
    const auto* worst = &losses[0];
    for (const auto& l : losses) worst = l.first > worst->first ? &l : worst;
    std::printf(
        "| %d | %zu | %.0f | %.3f | %.3f | %.3f | %.0f | %.1f | %.0f | %.0f | %.1f | %.1f | %.0f | %.3f | %s |\n", P,
        global.tet_nodes.size(), h.own, h.ghost_ratio, h.twice, h.border, h.neighbours, h.bytes / 1e3, compute,
        contact_us, halo, reduce, step, t1 * h.own / step, P > 1 ? worst->second : "-");
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  std::vector<int> cells = {6, 10, 14};
  int steps = 200, sample = 6;
  long per_rank = 0;
  bool contact = false, uniform = false;
  double tet_us = 0.5, contact_us = 0, latency_us = 2, gbps = 12.5, fracture_below = 0;
  std::vector<int> ranks = {1, 2, 8, 64};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
    if (a == "--cells")
      cells = parse_ints(next());
    else if (a == "--steps")
      steps = std::atoi(next().c_str());
    else if (a == "--contact")
      contact = true;
    else if (a == "--uniform")
      uniform = true;
    else if (a == "--fracture-below")
      fracture_below = std::atof(next().c_str());
    else if (a == "--weak")
      per_rank = std::atol(next().c_str());
    else if (a == "--tet-us")
      tet_us = std::atof(next().c_str());
    else if (a == "--contact-us")
      contact_us = std::atof(next().c_str());
    else if (a == "--ranks")
      ranks = parse_ints(next());
    else if (a == "--latency-us")
      latency_us = std::atof(next().c_str());
    else if (a == "--gbps")
      gbps = std::atof(next().c_str());
    else if (a == "--sample")
      sample = std::atoi(next().c_str());
    else {
      std::fprintf(stderr, "bench_ranks: unknown option %s (see the comment at the top of bench/bench_ranks.cpp)\n",
                   a.c_str());
      MPI_Finalize();
      return 2;
    }
  }
  const bool counts_ok = std::all_of(ranks.begin(), ranks.end(), [](int p) { return p >= 1; });
  if (per_rank > 0 && (ranks.empty() || ranks.front() != 1 || !counts_ok)) {
    std::fprintf(
        stderr,
        "bench_ranks: --ranks must be counts of 1 or more starting with 1 (the efficiency is against one rank)\n");
    MPI_Finalize();
    return 2;
  }
  if (per_rank > 0)
    weak(per_rank, ranks, WeakCosts{tet_us, contact_us, latency_us, gbps}, sample);
  else
    measured(cells, steps, contact, fracture_below, uniform);
  MPI_Finalize();
  return 0;
}
