// bench_fields (MPI): the time to write one ParaView frame on P ranks, three ways, alternated:
//   per-rank   each rank its own fields_rank<r>.h5 (the layout before one shared file);
//   collective one fields.h5, each rank its slab through MPI-IO (parallel HDF5);
//   gathered   one fields.h5, rank 0 gathers the slabs and writes them (serial HDF5's way).
// A frame holds what a run's frame holds for T tets a rank: 4 T nodes (x, u, v), the tets,
// stress, von Mises, three more per-tet fields and crack faces on a tenth of the tets.
//
//   mpiexec -n 8 build/bench/bench_fields [--tets 20000] [--frames 5] [--repeats 5] [--dir /tmp/x]
//
// Each write is timed from a barrier to the slowest rank's end (what a run waits for). The table
// gives the median and the best over the repeats, per frame, and the bytes of a frame.
#include <mpi.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "io/fields.hpp"

using namespace fdem;

namespace {

/// One rank's frame of `tets` tets, with values that differ per rank and frame.
struct Slab {
  std::vector<Vec3> x, u, v;
  std::vector<std::array<int, 4>> tets;
  std::vector<Sym3> stress;
  std::vector<real> von_mises, active, material, rank;
  std::vector<std::array<int, 3>> faces;
  std::vector<real> damage;
  std::vector<int> mode;

  Slab(int tets_n, int r) {
    for (int t = 0; t < tets_n; ++t) {
      for (int k = 0; k < 4; ++k) {
        const real a = 1e-4 * (4 * t + k) + r;
        x.push_back({a, 2 * a, 3 * a}), u.push_back({1e-6 * a, 0, -1e-6 * a}), v.push_back({0, a, 0});
      }
      tets.push_back({4 * t, 4 * t + 1, 4 * t + 2, 4 * t + 3});
      stress.push_back({1e6 * t, 2e6, 3e6, 1e5, 2e5, 3e5});
      von_mises.push_back(1e6 + t), active.push_back(t % 2), material.push_back(0), rank.push_back(r);
      if (t % 10 == 0) faces.push_back({4 * t, 4 * t + 1, 4 * t + 2}), damage.push_back(0.5), mode.push_back(1);
    }
  }
  FieldFrame frame(int index) const {
    FieldFrame f;
    f.time = 1e-4 * index, f.step = 1000 * index;
    f.x = &x, f.u = &u, f.v = &v, f.tets = &tets, f.stress = &stress, f.von_mises = &von_mises;
    f.extra = {{"active", &active}, {"material", &material}, {"rank", &rank}};
    f.crack_faces = &faces, f.crack_damage = &damage, f.crack_mode = &mode;
    return f;
  }
  double bytes() const {
    return double(x.size()) * 3 * 3 * sizeof(real) + double(tets.size()) * (4 * 4 + (6 + 4) * sizeof(real)) +
           double(faces.size()) * (3 * 4 + sizeof(real) + 4);
  }
};

const char* kWays[3] = {"per-rank", "collective", "gathered"};

/// Seconds per frame of `frames` frames written one way, the slowest rank's.
double seconds_per_frame(int way, const Slab& slab, int frames, const std::string& dir, int rank) {
  MPI_Barrier(MPI_COMM_WORLD);
  const auto t0 = std::chrono::steady_clock::now();
  {
    const std::string folder = dir + "/" + kWays[way];
    if (way == 0) {
      FieldWriter w(folder, "fields_rank" + std::to_string(rank));
      for (int i = 0; i < frames; ++i) w.write(slab.frame(i));
    } else {
      FieldWriter w(folder, "fields", MPI_COMM_WORLD, way == 1 ? SharedWrite::collective : SharedWrite::gathered);
      for (int i = 0; i < frames; ++i) w.write(slab.frame(i));
    }
  }
  double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  MPI_Allreduce(MPI_IN_PLACE, &s, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return s / frames;
}

long arg(int argc, char** argv, const char* name, long fallback) {
  for (int i = 1; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], name) == 0) return std::atol(argv[i + 1]);
  return fallback;
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const int tets = int(arg(argc, argv, "--tets", 20000)), frames = int(arg(argc, argv, "--frames", 5));
  const int repeats = int(arg(argc, argv, "--repeats", 5));
  std::string dir = "/tmp/bench_fields_" + std::to_string(::getpid());
  for (int i = 1; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], "--dir") == 0) dir = argv[i + 1];
  int len = int(dir.size());
  MPI_Bcast(&len, 1, MPI_INT, 0, MPI_COMM_WORLD);
  dir.resize(len);
  MPI_Bcast(dir.data(), len, MPI_CHAR, 0, MPI_COMM_WORLD);
  const Slab slab(tets, rank);
  std::array<std::vector<double>, 3> times;
  for (int k = 0; k < repeats; ++k)
    for (int w = 0; w < 3; ++w) times[w].push_back(seconds_per_frame((w + k) % 3, slab, frames, dir, rank));
  // (each repeat starts with another way, so that none always follows the same one)
  std::array<std::vector<double>, 3> by_way;
  for (int k = 0; k < repeats; ++k)
    for (int w = 0; w < 3; ++w) by_way[(w + k) % 3].push_back(times[w][k]);
  if (rank == 0) {
    const double mb = slab.bytes() * size / 1e6;
    std::printf("%d ranks, %d tets a rank, %d frames a write, %d repeats; %.1f MB a frame (all ranks)\n\n", size, tets,
                frames, repeats, mb);
    std::printf("| write | ms/frame (median) | ms/frame (best) | MB/s (median) | median / per-rank |\n");
    std::printf("|---|---|---|---|---|\n");
    std::array<double, 3> median;
    for (int w = 0; w < 3; ++w) {
      std::vector<double> t = by_way[w];
      std::sort(t.begin(), t.end());
      median[w] = t[t.size() / 2];
      std::printf("| %s | %.1f | %.1f | %.0f | %.2f |\n", kWays[w], 1e3 * median[w], 1e3 * t.front(), mb / median[w],
                  median[w] / median[0]);
    }
    std::filesystem::remove_all(dir);
  }
  MPI_Finalize();
  return 0;
}
