// PETSc DMPlex (built where PETSc is found; run at 1 and 2 ranks through ctest's MPIEXEC
// variables, label mpi). PlexCheck: DMPlex's own view as an independent check of the cut
// (docs/architecture.md, "Multi-rank runs"): the same METIS partition through a shell
// partitioner and DMPlexDistribute with overlap 1 must hold exactly the tets the rank model
// holds (without contact: its own and one layer of ghosts), own exactly its own ones, and its
// interpolated faces with two local cells must be exactly the rank's CE6s. PlexDistribute: the
// solver's distribution through DMPlex (partition/plex.cpp) gives every rank the cut's model,
// byte for byte, with and without contact ghosts beyond the overlap.
#include <gtest/gtest.h>
#include <mpi.h>
#include <petscdmplex.h>
#include <petscsf.h>

#include <algorithm>
#include <array>
#include <set>
#include <utility>
#include <vector>

#include "io/checkpoint.hpp"
#include "model/structured.hpp"
#include "partition/halo.hpp"
#include "partition/partition.hpp"
#include "partition/plex.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

void check(PetscErrorCode e, const char* what) {
  ASSERT_EQ(e, 0) << "PETSc: " << what;
}

/// What the distributed plex gives this rank, in global (original) tet ids.
struct PlexPart {
  std::set<long> cells, owned;
  std::set<std::pair<long, long>> faces;  // interior faces: their two cells, lower id first
};

/// Rank 0 makes the plex of the model's tets over its mesh vertices (cell c = global tet c),
/// the shell partitioner takes `part`, DMPlexDistribute spreads it with overlap 1.
void distribute(const Model& global, const std::vector<int>& part, PlexPart& out) {
  const int rank = rank_in(MPI_COMM_WORLD), size = size_of(MPI_COMM_WORLD);
  const int nt = int(global.tet_nodes.size());
  int nv = 0;
  for (int v : global.node_vertex) nv = std::max(nv, v + 1);
  std::vector<PetscInt> cells;
  std::vector<PetscReal> coords(3 * std::size_t(nv));
  for (int t = 0; t < nt; ++t)
    for (int n : global.tet_nodes[t]) cells.push_back(global.node_vertex[n]);
  for (std::size_t n = 0; n < global.X.size(); ++n)
    for (int d = 0; d < 3; ++d) coords[3 * global.node_vertex[n] + d] = global.X[n][d];
  const bool root = rank == 0;
  DM dm = nullptr;
  check(DMPlexCreateFromCellListPetsc(PETSC_COMM_WORLD, 3, root ? nt : 0, root ? nv : 0, 4, PETSC_TRUE, cells.data(), 3,
                                      coords.data(), &dm),
        "DMPlexCreateFromCellListPetsc");
  PetscPartitioner partitioner;
  check(DMPlexGetPartitioner(dm, &partitioner), "DMPlexGetPartitioner");
  check(PetscPartitionerSetType(partitioner, PETSCPARTITIONERSHELL), "PetscPartitionerSetType");
  std::vector<PetscInt> sizes(size, 0), points;
  if (root) {
    for (int r = 0; r < size; ++r)
      for (int t = 0; t < nt; ++t)
        if (part[t] == r) ++sizes[r], points.push_back(t);
  }
  check(PetscPartitionerShellSetPartition(partitioner, size, sizes.data(), root ? points.data() : nullptr),
        "PetscPartitionerShellSetPartition");
  DM dist = nullptr;
  PetscSF migration = nullptr;
  check(DMPlexDistribute(dm, 1, &migration, &dist), "DMPlexDistribute");
  const DM local = dist ? dist : dm;  // one rank: nothing to distribute

  // Original point of each local point: the migration SF's roots (identity on one rank).
  PetscInt p_start, p_end, c_start, c_end, f_start, f_end;
  check(DMPlexGetChart(local, &p_start, &p_end), "DMPlexGetChart");
  check(DMPlexGetHeightStratum(local, 0, &c_start, &c_end), "cells");
  check(DMPlexGetHeightStratum(local, 1, &f_start, &f_end), "faces");
  std::vector<long> original(p_end - p_start);
  for (PetscInt p = p_start; p < p_end; ++p) original[p - p_start] = p;
  if (migration) {
    PetscInt nroots, nleaves;
    const PetscInt* ilocal;
    const PetscSFNode* iremote;
    check(PetscSFGetGraph(migration, &nroots, &nleaves, &ilocal, &iremote), "PetscSFGetGraph");
    for (PetscInt i = 0; i < nleaves; ++i) {
      ASSERT_EQ(iremote[i].rank, 0) << "every point comes from rank 0's serial plex";
      original[(ilocal ? ilocal[i] : i) - p_start] = iremote[i].index;
    }
  }
  // Cells owned elsewhere: the leaves of the point SF.
  std::set<PetscInt> ghost_points;
  PetscSF point_sf;
  check(DMGetPointSF(local, &point_sf), "DMGetPointSF");
  PetscInt nroots, nleaves;
  const PetscInt* ilocal;
  const PetscSFNode* iremote;
  check(PetscSFGetGraph(point_sf, &nroots, &nleaves, &ilocal, &iremote), "PetscSFGetGraph");
  for (PetscInt i = 0; i < std::max<PetscInt>(nleaves, 0); ++i) ghost_points.insert(ilocal ? ilocal[i] : i);

  for (PetscInt c = c_start; c < c_end; ++c) {
    const long g = original[c - p_start];
    ASSERT_GE(g, 0);
    ASSERT_LT(g, nt) << "cells come first in the serial plex";
    out.cells.insert(g);
    if (!ghost_points.count(c)) out.owned.insert(g);
  }
  for (PetscInt f = f_start; f < f_end; ++f) {
    PetscInt n;
    const PetscInt* support;
    check(DMPlexGetSupportSize(local, f, &n), "DMPlexGetSupportSize");
    check(DMPlexGetSupport(local, f, &support), "DMPlexGetSupport");
    if (n != 2) continue;
    const long a = original[support[0] - p_start], b = original[support[1] - p_start];
    out.faces.insert({std::min(a, b), std::max(a, b)});
  }
  if (migration) PetscSFDestroy(&migration);
  if (dist) DMDestroy(&dist);
  DMDestroy(&dm);
}

/// What fdem's own cut gives this rank, in the same terms.
PlexPart cut(const Model& global, const std::vector<int>& part, std::set<std::pair<long, long>>& ce6) {
  const RankModel rm = extract_rank(global, part, rank_in(MPI_COMM_WORLD), 0);
  const Decomposition& dd = rm.dd;
  auto gid = [&](int t) { return dd.distributed() ? dd.tet_global[t] : long(t); };
  PlexPart out;
  for (std::size_t t = 0; t < rm.model.tet_nodes.size(); ++t) {
    out.cells.insert(gid(int(t)));
    if (!dd.distributed() || dd.tet_owned[t]) out.owned.insert(gid(int(t)));
  }
  for (const auto& ab : rm.model.ce6_tets)
    ce6.insert({std::min(gid(ab[0]), gid(ab[1])), std::max(gid(ab[0]), gid(ab[1]))});
  return out;
}

Vec3 centroid(const Model& m, long t) {
  Vec3 c{0, 0, 0};
  for (int n : m.tet_nodes[t]) c += 0.25 * m.X[n];
  return c;
}

class PlexCheck : public ::testing::TestWithParam<bool> {};

TEST_P(PlexCheck, DistributionWithOverlapOneHoldsTheRankModelsTetsAndCe6s) {
  // true: fracture everywhere (a CE6 on every internal face); false: only in the lower half
  // of the box (faces with a tet outside join their nodes, no CE6 there).
  const bool everywhere = GetParam();
  Scene scene = test::test_scene();
  scene.contact.activation = Activation::none;  // no contact ghosts: the held tets are own + one layer
  if (!everywhere) {
    scene.fracture.everywhere = false;
    scene.fracture.boxes.push_back({{-1, -1, -1}, {1, 1, 0.01}});
  }
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene);
  const std::vector<int> part = partition_tets(global, size_of(MPI_COMM_WORLD));
  PlexPart plex;
  ASSERT_NO_FATAL_FAILURE(distribute(global, part, plex));
  std::set<std::pair<long, long>> ce6;
  const PlexPart mine = cut(global, part, ce6);

  EXPECT_FALSE(plex.owned.empty()) << "no rank is empty";
  EXPECT_EQ(plex.owned, mine.owned) << "own tets: the METIS partition";
  EXPECT_EQ(plex.cells, mine.cells) << "own tets and the ghost layer";
  if (size_of(MPI_COMM_WORLD) > 1) {
    EXPECT_GT(plex.cells.size(), plex.owned.size()) << "ghosts";
  }
  // The CE6s: the plex's faces between two held tets that are both in a fracture region.
  std::set<std::pair<long, long>> expected;
  for (const auto& ab : plex.faces) {
    const bool in_a = everywhere || centroid(global, ab.first).z < 0.01;
    const bool in_b = everywhere || centroid(global, ab.second).z < 0.01;
    if (in_a && in_b) expected.insert(ab);
  }
  EXPECT_EQ(ce6, expected);
  // Over all ranks (one rank may hold only tets inside or only outside the region).
  long counts[2] = {long(ce6.size()), long(plex.faces.size())};
  MPI_Allreduce(MPI_IN_PLACE, counts, 2, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_GT(counts[0], 0);
  if (!everywhere) {
    EXPECT_LT(counts[0], counts[1]);
  }
}

INSTANTIATE_TEST_SUITE_P(Regions, PlexCheck, ::testing::Values(true, false), [](const auto& i) {
  return std::string(i.param ? "FractureEverywhere" : "FractureInLowerHalf");
});

/// A rank model as bytes (every field, in the rank file's layout).
std::string bytes_of(const RankModel& rm) {
  CheckpointOut o;
  put_rank_model(o, rm, 0);
  return o.payload();
}

struct DistributeCase {
  const char* name;
  bool contact, everywhere, two_bodies;
};

void PrintTo(const DistributeCase& c, std::ostream* os) {
  *os << c.name;
}

class PlexDistribute : public ::testing::TestWithParam<DistributeCase> {};

TEST_P(PlexDistribute, GivesEveryRankTheModelOfTheCut) {
  // The solver's path for several ranks (fdem run --distribute plex): the model travels as
  // DMPlex cell data, and each rank's model must be the cut's, byte for byte (so runs are too).
  const DistributeCase& c = GetParam();
  const int rank = rank_in(MPI_COMM_WORLD), size = size_of(MPI_COMM_WORLD);
  Scene scene = test::test_scene();
  scene.contact.activation = c.contact ? Activation::full : Activation::none;
  if (!c.everywhere) {
    scene.fracture.everywhere = false;
    scene.fracture.boxes.push_back({{-1, -1, -1}, {1, 1, 0.01}});
  }
  Mesh mesh = structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6);
  if (c.two_bodies) {  // a second box 0.2 mm above the first: contact across a gap, no shared vertex
    const Mesh b = structured_box_mesh({0.01, 0.01, 0.01}, 3, 3, 3);
    const int off = int(mesh.vertices.size());
    for (Vec3 p : b.vertices) mesh.vertices.push_back(p + Vec3{0.001, 0, 0.0202});
    for (auto q : b.tets) mesh.tets.push_back({q[0] + off, q[1] + off, q[2] + off, q[3] + off});
  }
  const Model global = build_model(mesh, scene);
  std::vector<int> part = partition_tets(global, size);
  if (c.two_bodies)  // the upper body on the last rank, the lower on the others
    for (std::size_t t = 0; t < part.size(); ++t)
      part[t] = centroid(global, long(t)).z > 0.02 ? size - 1 : std::min(part[t], std::max(size - 2, 0));
  const real reach = c.contact ? default_reach(global, scene) : 0;
  const PartitionPlan plan = plan_partition(global, part, reach);
  PlexReport report;
  const RankModel plex =
      distribute_with_plex(MPI_COMM_WORLD, rank == 0 ? &global : nullptr, rank == 0 ? &plan : nullptr, &report);
  const RankModel cut = extract_rank(global, plan, rank);
  EXPECT_EQ(plex.model.tet_nodes.size(), cut.model.tet_nodes.size());
  EXPECT_EQ(plex.model.ce6_nodes.size(), cut.model.ce6_nodes.size());
  EXPECT_EQ(plex.dd.neighbours.size(), cut.dd.neighbours.size());
  EXPECT_TRUE(bytes_of(plex) == bytes_of(cut)) << "the rank model, field for field";
  // The tet data in passes of 16 kB (a few dozen tets each): the same model.
  const RankModel passes =
      distribute_with_plex(MPI_COMM_WORLD, rank == 0 ? &global : nullptr, rank == 0 ? &plan : nullptr, nullptr, 16384);
  EXPECT_TRUE(bytes_of(passes) == bytes_of(cut)) << "in passes";

  long held = 0;
  for (int t = 0; t < int(part.size()); ++t) held += long(plan.held[t].size());
  EXPECT_EQ(report.overlap_tets + report.contact_ghosts, held) << "every held tet arrived once";
  if (!c.contact || size == 1) {
    // The overlap of one brings the ghost layer the CE6s and node forces need: nothing beside it.
    EXPECT_EQ(report.contact_ghosts, 0);
    EXPECT_EQ(report.extra_cells, 0) << "and no cell no rank holds";
  } else {
    EXPECT_GT(report.contact_ghosts, 0) << "contact ghosts reach beyond one layer";
  }
  if (c.two_bodies && size > 1) {
    // The upper body's tets near the gap are contact ghosts below it: no plex overlap has them.
    long upper_below = 0;
    if (rank < size - 1)
      for (long t : plex.dd.tet_global) upper_below += centroid(global, t).z > 0.02;
    MPI_Allreduce(MPI_IN_PLACE, &upper_below, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    EXPECT_GT(upper_below, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Models, PlexDistribute,
                         ::testing::Values(DistributeCase{"FractureInLowerHalf", false, false, false},
                                           DistributeCase{"FractureEverywhereWithContact", true, true, false},
                                           DistributeCase{"TwoBodiesWithContact", true, true, true}),
                         [](const auto& i) { return std::string(i.param.name); });

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  PetscInitializeNoArguments();
  ::testing::InitGoogleTest(&argc, argv);
  const int code = RUN_ALL_TESTS();
  int worst = code;
  MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  PetscFinalize();
  MPI_Finalize();
  return worst;
}
