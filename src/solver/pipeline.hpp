#pragma once
// The way from a scene to a running solver, one function for every command and test:
// scene -> mesh -> model -> this rank's part (rank files, DMPlex, or rank 0's cut) -> Solver.
#include <mpi.h>

#include <iosfwd>
#include <memory>
#include <string>

#include "model/model.hpp"
#include "partition/partition.hpp"
#include "scene/scene.hpp"
#include "solver/solver.hpp"

namespace fdem {

/// Several ranks without rank files: how rank 0's model reaches the ranks (fdem run
/// --distribute). `automatic`: plex where fdem has PETSc, else root.
enum class Distribution { automatic, plex, root };
/// The distribution a --distribute value names ("" = automatic); InputError for another.
Distribution distribution_named(const std::string& name);

/// Where a run's model comes from and how it reaches the ranks.
struct ModelSource {
  std::string partitioned;  // a folder of rank files (fdem partition); "" = build from the scene
  Distribution distribute = Distribution::automatic;
  double contact_reach = 0;  // m, several ranks; 0 = the default (partition/partition.hpp)
  std::string write_mesh;    // one rank: also write the mesh to this .msh file (fdem check)
};

/// The scene's mesh and model; InputError naming the scene and the mesh. With write_mesh, the
/// mesh is also written there (checked before the meshing), and a line about it goes to log.
Model build_scene_model(const Scene& scene, const std::string& write_mesh, std::ostream& log);

/// The METIS partition of a scene's model for `size` ranks and its plan (contact reach: the
/// given one where > 0, else the default); InputError naming the scene.
PartitionPlan plan_scene(const Scene& scene, const Model& global, int size, double contact_reach);

/// <folder>/rank_<rank>.fdp.
std::string rank_file_path(const std::string& folder, int rank);

/// The solver of this rank of comm for the scene: its model built, or read from rank files, or
/// cut by rank 0 and distributed; what the distribution did goes to log (rank 0's).
std::unique_ptr<Solver> make_solver(const Scene& scene, const ModelSource& source, MPI_Comm comm, std::ostream& log);

}  // namespace fdem
