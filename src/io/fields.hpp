#pragma once
// ParaView output: heavy data in one HDF5 file, an XDMF 3 index next to it.
//
//   <folder>/<basename>.h5     /mesh/tets                 M x 4 int32 (written once; topology is constant)
//                              /frame_000000/x,u,v        N x 3 float64 (node positions, displacement, velocity)
//                                           /stress       M x 6 float64, order xx, yy, zz, yz, xz, xy (Pa)
//                                           /von_mises    M float64 (Pa)
//                                           /<extra>      M float64, one per TetField
//                                           /crack_faces  K x 3 int32, crack_damage K float64, crack_mode K int32
//                              attributes on each frame group: time, step, label
//   <folder>/<basename>.xdmf   Temporal collection; per frame a Spatial collection with a "rock" tet grid
//                              and (when K > 0) a "cracks" triangle grid. Rewritten atomically after
//                              every frame (write to .xdmf.tmp, then rename).
//
// The .h5 file is opened and closed for every frame, so a crash keeps all earlier frames.
//
// Several ranks write one file together: each frame's nodes, tets and crack faces are the
// ranks' slabs in rank order, node ids shifted to the file's numbering. Parallel HDF5 (MPI-IO)
// lets every rank write its own slab; without it rank 0 gathers the slabs and writes them.
#include <mpi.h>

#include <array>
#include <string>
#include <vector>

#include "core/vec.hpp"

namespace fdem {

/// A per-tet scalar written as a cell attribute; name must be non-empty and contain no '/'.
struct TetField {
  std::string name;
  const std::vector<real>* values;  // one value per tet
};

/// One output frame. Pointers are borrowed for the duration of write(). x and tets are required;
/// u, v, stress, von_mises and the crack arrays may be null (then they are not written).
/// Several ranks: each gives its slab (its nodes, its tets and crack faces by index into them);
/// the time, step, label, the arrays given and the extra fields' names are the same on all.
struct FieldFrame {
  real time = 0;
  long step = 0;
  std::string label;  // "" or e.g. "peak", "final", "diagnostic"; stored as an attribute and in the grid name
  const std::vector<Vec3>* x = nullptr;  // current node positions (discontinuous tets: nodes are per tet)
  const std::vector<Vec3>* u = nullptr;  // displacement per node
  const std::vector<Vec3>* v = nullptr;  // velocity per node
  const std::vector<std::array<int, 4>>* tets = nullptr;         // node ids
  const std::vector<Sym3>* stress = nullptr;                     // Cauchy stress per tet (Pa)
  const std::vector<real>* von_mises = nullptr;                  // per tet (Pa)
  std::vector<TetField> extra;                                   // more per-tet scalars (e.g. rank, active)
  const std::vector<std::array<int, 3>>* crack_faces = nullptr;  // node ids of damaged/broken CE6 faces
  const std::vector<real>* crack_damage = nullptr;               // D in [0,1] per crack face
  const std::vector<int>* crack_mode = nullptr;  // 0 intact(damaged), 1 I, 2 II, 3 mixed, 4 never bonded
};

/// What a FieldWriter has written, so that a restarted run can take over its files.
struct FieldWriterState {
  std::vector<std::string> grids;             // XDMF text of each frame
  std::vector<std::string> labels;            // label of each frame
  std::vector<std::array<int, 4>> mesh_tets;  // connectivity in /mesh/tets
  bool have_mesh = false;
};

/// HDF5 files still open in this process: after a close that failed (disk full at the final
/// flush), HDF5 1.10's own shutdown inside MPI_Finalize crashes on such a file, so that the
/// program leaves without it (src/app/main.cpp).
int open_hdf5_files();

/// How the ranks of a shared file write it.
enum class SharedWrite {
  collective,  // parallel HDF5: every rank writes its slab through MPI-IO
  gathered,    // rank 0 gathers the slabs and writes them (HDF5 built without MPI)
};
/// Collective where this build's HDF5 has MPI-IO, gathered where it has not.
SharedWrite default_shared_write();

/// Appends frames to <folder>/<basename>.h5 and keeps <folder>/<basename>.xdmf up to date.
/// A file-system or HDF5 failure throws OutputError; a non-finite value or inconsistent sizes
/// throw RunError
/// naming the file or the field and index; a failed write() leaves the index of the earlier
/// frames intact.
class FieldWriter {
 public:
  /// Creates folder if missing, starts a fresh .h5 (truncating an old one) and removes a stale .xdmf.
  /// `ranks`: the ranks that write the file together (collective over them, every call after
  /// too); MPI_COMM_NULL for this process alone. An error on one rank is thrown on all.
  FieldWriter(const std::string& folder, const std::string& basename, MPI_Comm ranks = MPI_COMM_NULL,
              SharedWrite how = default_shared_write());
  /// Takes over the files of an earlier writer whose state was saved (a restart): frames after
  /// those in `state` are removed from the .h5, the labels of the kept ones are set as saved
  /// (a later relabel is undone) and the index is rewritten. Throws OutputError if the .h5 is
  /// missing or lacks a saved frame.
  /// A frame cut short (the disk filled) that cannot be removed: the kept frames are copied into
  /// a new .h5 and repaired() says so.
  FieldWriter(const std::string& folder, const std::string& basename, const FieldWriterState& state,
              MPI_Comm ranks = MPI_COMM_NULL, SharedWrite how = default_shared_write());
  /// After a restart that had to copy the kept frames into a new file: why; else "".
  const std::string& repaired() const { return repaired_; }
  FieldWriterState state() const { return {grids_, labels_, mesh_tets_, have_mesh_}; }
  /// Appends one frame.
  void write(const FieldFrame& f);
  /// Changes the label of frame `index` (0-based, already written) in the .h5 and the index.
  void relabel(int index, const std::string& label);
  /// Number of frames written so far.
  int frames() const { return static_cast<int>(grids_.size()); }
  /// Several ranks write the file together (every call is collective over them).
  bool shared() const { return size_ > 1; }

  const std::string& h5_path() const { return h5_path_; }
  const std::string& xdmf_path() const { return xdmf_path_; }

 private:
  std::string h5_name_;  // file name only, as referenced from the XDMF
  std::string h5_path_;
  std::string xdmf_path_;
  std::vector<std::array<int, 4>> mesh_tets_;  // copy of /mesh/tets, to detect a topology change
  bool have_mesh_ = false;
  std::vector<std::string> grids_;   // XDMF text of each frame written so far
  std::vector<std::string> labels_;  // and its label

  std::string repaired_;
  MPI_Comm ranks_ = MPI_COMM_NULL;  // the ranks sharing the file; null: this process alone
  int rank_ = 0, size_ = 1;
  SharedWrite how_ = SharedWrite::collective;

  void share(MPI_Comm ranks, SharedWrite how);
  /// Runs `work` on every rank (everywhere) or on rank 0 only; where it threw on a rank, every
  /// rank throws the first such rank's error, of its kind.
  template <class Work>
  void agree(Work&& work, bool everywhere) const;
  /// Several ranks writing through MPI-IO: file operations are collective (else rank 0's alone).
  bool collective() const { return shared() && how_ == SharedWrite::collective; }
  void rewrite_index() const;
  /// The restart's work on the .h5: the kept frames' labels as saved, later frames removed.
  void take_over();
  /// Copies /mesh and the kept frames into <h5>.copy and renames it over the .h5; "" or why not.
  std::string copy_kept_frames() const;
};

}  // namespace fdem
