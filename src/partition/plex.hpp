#pragma once
// Distribution through PETSc DMPlex (where fdem is built with PETSc): rank 0's global model goes
// to the ranks along DMPlexDistribute's migration, and each rank cuts its model out of what
// arrived. PETSc does this and nothing else. See docs/architecture.md, "Multi-rank runs".
#include <mpi.h>

#include <cstdint>

#include "partition/partition.hpp"

namespace fdem {

/// Whether this fdem was built with PETSc (FDEM_ENABLE_PETSC, found by pkg-config).
bool plex_available();
/// InputError naming --distribute plex and the fixes unless plex_available().
void require_plex();

/// What a distribution moved, summed over the ranks (for the run log and the tests).
struct PlexReport {
  long overlap_tets = 0;    // held tets that arrived as cells of the distributed plex
  long contact_ghosts = 0;  // held tets beyond the plex's overlap, sent beside it
  long extra_cells = 0;     // cells of the plex that no rank model holds
};

/// Collective on comm. Rank 0 passes the global model and its plan (plan.size == ranks of comm);
/// the others pass null. Rank 0 makes a DMPlex of the global tets over their mesh vertices,
/// hands plan.part to a shell partitioner and calls DMPlexDistribute with overlap 1 (the ghost
/// layer that the CE6s and the node forces need); each tet's data (its nodes, CE6s, surfaces,
/// colours and plan entries) travels as the plex's cell data (DMPlexDistributeData). Contact
/// ghosts are geometric (tets within the reach, a separate body too), not a topological
/// overlap, so those the plex did not bring are sent beside it. Each rank then cuts its model
/// out of the piece that arrived: the result equals extract_rank(global, plan, rank) field for
/// field. RunError naming the step when PETSc fails or a held tet did not arrive; require_plex's
/// InputError where fdem was built without PETSc.
/// The tet data goes in passes of at most pass_bytes (PETSc 3.18 counts a rank's received bytes
/// in an int); tests pass a few kilobytes to make many passes.
RankModel distribute_with_plex(MPI_Comm comm, const Model* global, const PartitionPlan* plan,
                               PlexReport* report = nullptr, std::uint64_t pass_bytes = std::uint64_t(1) << 30);

/// Finalises PETSc if distribute_with_plex initialised it (call before MPI_Finalize).
void plex_finalize();

}  // namespace fdem
