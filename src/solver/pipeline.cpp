#include "solver/pipeline.hpp"

#include <filesystem>
#include <ostream>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/checkpoint.hpp"
#include "io/mesh_io.hpp"
#include "partition/halo.hpp"
#include "partition/plex.hpp"

namespace fdem {
namespace {

namespace fs = std::filesystem;

/// Before minutes of meshing: --write-mesh names a new or regular file in a folder that exists,
/// and neither the scene nor its mesh file (writing would replace what this run reads).
void check_mesh_target(const Scene& scene, const std::string& write_mesh) {
  const fs::path folder = fs::absolute(write_mesh).parent_path();
  std::error_code ec;
  if (!fs::is_directory(folder, ec) || fs::is_directory(write_mesh, ec))
    throw OutputError("cannot write the mesh to " + write_mesh + ": " +
                      (fs::is_directory(write_mesh, ec) ? "it is a folder" : folder.string() + " is not a folder") +
                      ". Fix: give --write-mesh a file name in a folder that exists, e.g. mesh.msh");
  for (const auto& [what, input] : {std::pair<const char*, std::string>{"the scene file", scene.file},
                                    std::pair<const char*, std::string>{"the scene's mesh.file", scene.mesh.file}})
    if (!input.empty() && fs::equivalent(write_mesh, input, ec))
      throw InputError("--write-mesh " + write_mesh + " is " + what + " (" + input +
                       "), which writing would replace. Fix: give --write-mesh another file name");
  if (fs::exists(write_mesh, ec) && !fs::is_regular_file(write_mesh, ec))
    throw OutputError("cannot write the mesh to " + write_mesh +
                      ": it exists and is not a regular file (a device, socket or pipe). Fix: give "
                      "--write-mesh a file name in a folder that exists, e.g. mesh.msh");
}

/// This rank's part from the rank files of fdem partition, checked against the job.
RankModel read_rank_model(const Scene& scene, const ModelSource& src, int rank, int size) {
  const std::string file = rank_file_path(src.partitioned, rank);
  RankModel rm = read_rank_file(file, model_key(scene));
  if (rm.dd.size != size || rm.dd.rank != rank)
    throw InputError(file + ": written for rank " + std::to_string(rm.dd.rank) + " of " + std::to_string(rm.dd.size) +
                     ", run as rank " + std::to_string(rank) + " of " + std::to_string(size) + ". Fix: mpiexec -n " +
                     std::to_string(rm.dd.size) + ", or fdem partition -n " + std::to_string(size));
  // The contact reach is the rank files': a partition made without contact holds no ghosts for
  // it, and the run would lose contacts across ranks without a word.
  if (size > 1 && scene.contact.enabled() && !(rm.dd.reach > 0))
    throw InputError(file + ": written for a scene without contact (contact reach 0 m); " + scene.file +
                     " has contact (" + name_of(scene.contact.activation) +
                     "). Fix: fdem partition this scene again, or run with --contact none");
  if (src.contact_reach > 0)
    throw InputError("--contact-reach " + fmt(src.contact_reach) +
                     " with --partitioned: the rank files hold their own reach (" + fmt(rm.dd.reach) +
                     " m). Fix: give --contact-reach to fdem partition, or leave it out here");
  return rm;
}

/// Rank 0 builds the model and partitions it with METIS; DMPlex distributes it, or rank 0 sends
/// every rank its part: the other ranks never hold the whole model. (A failure on rank 0 ends the
/// job, MPI_Abort.)
RankModel distribute_model(const Scene& scene, const ModelSource& src, MPI_Comm comm, std::ostream& log) {
  const int rank = rank_in(comm), size = size_of(comm);
  const bool plex = src.distribute == Distribution::automatic ? plex_available() : src.distribute == Distribution::plex;
  if (plex) require_plex();  // before rank 0 spends minutes on the model
  const std::uint64_t key = model_key(scene);
  Model global;
  PartitionPlan plan;
  if (rank == 0) {
    global = build_scene_model(scene, "", log);
    plan = plan_scene(scene, global, size, src.contact_reach);
  }
  const double start = MPI_Wtime();
  if (plex) {
    PlexReport report;
    RankModel mine = distribute_with_plex(comm, rank == 0 ? &global : nullptr, rank == 0 ? &plan : nullptr, &report);
    log << "distribution: PETSc DMPlex (shell partitioner with METIS's partition, overlap 1): " << report.overlap_tets
        << " held tets as plex cells"
        << (report.contact_ghosts > 0
                ? ", " + std::to_string(report.contact_ghosts) + " contact ghosts beyond the overlap sent beside"
                : std::string())
        << " (" << fmt(MPI_Wtime() - start, 3) << " s)\n";
    return mine;
  }
  if (rank != 0) {
    CheckpointIn in(receive_bytes(comm, 0), "the model part sent by rank 0");
    RankModel mine = get_rank_model(in, key);
    in.finish();
    return mine;
  }
  for (int r = 1; r < size; ++r) {
    CheckpointOut o;
    put_rank_model(o, extract_rank(global, plan, r), key);
    send_bytes(comm, o.payload(), r);
  }
  log << "distribution: rank 0 cut every rank's part and sent it (" << fmt(MPI_Wtime() - start, 3) << " s)\n";
  return extract_rank(global, plan, 0);
}

}  // namespace

Model build_scene_model(const Scene& scene, const std::string& write_mesh, std::ostream& log) {
  if (!write_mesh.empty()) check_mesh_target(scene, write_mesh);
  Mesh mesh;
  Model model;
  try {
    mesh = load_mesh(scene.mesh);
    model = build_model(mesh, scene);
  } catch (const InputError& e) {
    // Name the scene too: the mesh message names the mesh file and the element. (A boundary
    // condition's message names the scene and its key already.)
    const std::string what = e.what();
    if (what.rfind(scene.file + ": ", 0) == 0) throw;
    throw InputError(scene.file + ": mesh: " + what);
  }
  log << describe_groups(mesh);
  if (!write_mesh.empty()) {
    try {
      write_msh(mesh, write_mesh);
    } catch (const OutputError& e) {
      throw OutputError("cannot write the mesh to " + write_mesh + " (" + e.what() +
                        "). Fix: give --write-mesh a file in a folder that can be written, with space");
    }
    log << "mesh written: " << write_mesh << " (" << mesh.vertices.size() << " vertices, " << mesh.tets.size()
        << " tets, " << mesh.groups.size() << " groups, gmsh .msh 2.2, m; give it as mesh.file)\n";
  }
  return model;
}

PartitionPlan plan_scene(const Scene& scene, const Model& global, int size, double contact_reach) {
  std::vector<int> part;
  try {
    part = partition_tets(global, size);
  } catch (const InputError& e) {
    throw InputError(scene.file + ": " + e.what());
  }
  const double reach = !scene.contact.enabled() ? 0 : contact_reach > 0 ? contact_reach : default_reach(global, scene);
  return plan_partition(global, part, reach);
}

std::string rank_file_path(const std::string& folder, int rank) {
  return (fs::path(folder) / ("rank_" + std::to_string(rank) + ".fdp")).string();
}

Distribution distribution_named(const std::string& name) {
  if (name.empty()) return Distribution::automatic;
  if (name == "plex") return Distribution::plex;
  if (name == "root") return Distribution::root;
  throw InputError("--distribute " + name + ": not a way to distribute the model. Fix: --distribute plex or root");
}

std::unique_ptr<Solver> make_solver(const Scene& scene, const ModelSource& source, MPI_Comm comm, std::ostream& log) {
  // (A program that never started MPI, such as a test running a series, is one rank.)
  int mpi = 0;
  MPI_Initialized(&mpi);
  const int rank = mpi ? rank_in(comm) : 0, size = mpi ? size_of(comm) : 1;
  RankModel mine;
  if (!source.partitioned.empty())
    mine = read_rank_model(scene, source, rank, size);
  else if (size == 1)
    mine.model = build_scene_model(scene, source.write_mesh, log);
  else
    mine = distribute_model(scene, source, comm, log);
  return std::make_unique<Solver>(scene, std::move(mine.model), std::move(mine.dd), comm);
}

}  // namespace fdem
