#pragma once
// The run's ParaView frames (run_scene): the state now, states kept for the frames before and at
// the peak, and the diagnostic frame of an unstable run.
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "io/fields.hpp"
#include "solver/solver.hpp"

namespace fdem {

class CheckpointOut;
class CheckpointIn;

/// The state a ParaView frame shows. Frames before and at the peak are written from saved
/// copies once the peak is known (the stress has fallen 5 % below it). A frame needs each
/// CE6's damage, not its friction anchors: up to nine copies are kept (PeakFrames).
struct FrameState {
  real time = 0, stress = 0;
  long step = 0;
  std::vector<Vec3> x, v;
  std::vector<Ce6Damage> ce6;
  std::vector<std::uint8_t> active;
};

/// The solver's state now (synchronised to the host), at axial stress `stress` (Pa).
FrameState frame_state_now(const Solver& s, real stress);
/// A kept state in a checkpoint, and back.
void save_frame_state(CheckpointOut& o, const FrameState& f);
void load_frame_state(CheckpointIn& in, FrameState& f);

/// A frame of the state now, labelled (ParaView sees the label in the frame's name).
void write_frame(FieldWriter& w, const Solver& s, const std::string& label);
/// A frame of a kept state (the ghosts gathered since it was kept take their present state).
void write_frame(FieldWriter& w, const Solver& s, const FrameState& f, const std::string& label);

/// The frame of an unstable run, labelled "diagnostic": non-finite positions and velocities are
/// replaced by the reference positions and zero (so no file holds NaN), and two per-tet fields
/// show where it went wrong: "non_finite" (a node of the tet had a non-finite value) and
/// "inverted" (volume ratio J <= 0). Never throws: the frames written before stay valid.
void write_diagnostic(FieldWriter& w, const Solver& s);

/// Keeps what the pre-peak and peak frames need: the state at the running maximum of the axial
/// stress, and a ladder of states 5 % apart in stress between 0.7 and 1 of that maximum, from
/// which the one nearest kPrePeak of the peak is written as "pre-peak". At most 8 in the ladder
/// (0.7 x 1.05^7 < 1) and the peak: 9 copies.
class PeakFrames {
 public:
  static constexpr real kPrePeak = 0.8;
  /// A monitor row at `stress` (Pa): kept where it is a new maximum.
  void observe(const Solver& s, real stress);
  /// Writes "pre-peak", "peak" and (the current state) "post-peak" frames; call once the stress
  /// has fallen past the peak. The frames of an earlier, lower peak are relabelled "local-...".
  void write(FieldWriter& w, const Solver& s);
  void save(CheckpointOut& o) const;
  void load(CheckpointIn& in);
  /// A restart on another rank count: the states a saved rank kept, mapped by `map` into this
  /// rank's layout (Solver::read_saved_rank), saved rank 0's first. finish_saved() then gives
  /// what no saved rank owned in a kept state (ghosts gathered after it was kept) the state now.
  void take_saved(const PeakFrames& saved, const EntityMap& map, const Solver& s, bool first);
  void finish_saved(const Solver& s);

 private:
  real max_ = 0;
  FrameState peak_;
  std::deque<FrameState> ladder_;
  std::vector<std::pair<int, std::string>> written_;  // frame index and label of the last set
};

}  // namespace fdem
