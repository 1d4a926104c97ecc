#include "solver/run.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"
#include "io/fields.hpp"
#include "io/run_lock.hpp"

namespace fdem {

const char* const kSummaryHeader =
    "name,peak_stress_Pa,strain_at_peak,peak_indirect_tensile_Pa,confining_pressure_Pa,platen_velocity_m_s,"
    "energy_error,broken_ce6,broken_mode_I,broken_mode_II,broken_mixed,broken_area_m2,failure_plane_angle_deg,"
    "planarity,mean_facet_angle_deg,crack_centroid_x_m,crack_centroid_y_m,crack_centroid_z_m,steps,time_s,wall_s,"
    "end_reason";

namespace {

const char* kCsvHeader =
    "step,time_s,axial_strain,axial_stress_Pa,lateral_strain,volumetric_strain,force_top_N,force_bottom_N,"
    "damaged_ce6,broken_ce6,broken_mode_I,broken_mode_II,broken_mixed,kinetic_J,strain_J,cohesive_stored_J,"
    "cohesive_dissipated_J,friction_J,viscous_J,platen_stored_J,platen_friction_J,external_work_J,energy_error,"
    "contact_J,contact_friction_J,active_tets,contact_pairs,contacts,confining_pressure_Pa,"
    "indirect_tensile_Pa,lateral_stress_Pa";

/// One monitor row (10 significant digits); a row with a non-finite value throws RunError
/// instead (no output file holds NaN or inf), naming the step and the column.
std::string monitor_row(const Monitors& m, const Solver& solver) {
  std::ostringstream o;
  o << std::setprecision(10);
  o << m.step << ',' << m.time << ',' << m.axial_strain << ',' << m.axial_stress << ',' << m.lateral_strain << ','
    << m.volumetric_strain << ',' << m.force_top << ',' << m.force_bottom << ',' << m.damaged << ',' << m.broken << ','
    << m.broken_I << ',' << m.broken_II << ',' << m.broken_mixed << ',' << m.kinetic << ',' << m.strain << ','
    << m.cohesive_stored << ',' << m.cohesive_dissipated << ',' << m.friction << ',' << m.viscous << ','
    << m.platen_stored << ',' << m.platen_friction << ',' << m.external_work << ',' << m.energy_error << ','
    << m.contact << ',' << m.contact_friction << ',' << m.active_tets << ',' << m.contact_pairs << ',' << m.contacts
    << ',' << m.confining_pressure << ',' << m.indirect_tensile << ',' << m.lateral_stress << '\n';
  const std::string row = o.str();
  if (row.find("nan") != std::string::npos || row.find("inf") != std::string::npos) {
    std::stringstream names(kCsvHeader), cells(row);
    std::string name, cell;
    while (std::getline(names, name, ',') && std::getline(cells, cell, ','))
      if (cell.find("nan") != std::string::npos || cell.find("inf") != std::string::npos) break;
    throw RunError("step " + std::to_string(m.step) + ": the monitor " + name + " is " + cell +
                   ": the run is unstable. " + solver.instability_advice());
  }
  return row;
}

/// One row under kSummaryHeader, written atomically: its presence marks a finished run.
void write_summary(const std::string& path, const Scene& scene, const RunSummary& r) {
  std::ostringstream o;
  o << std::setprecision(10) << kSummaryHeader << '\n';
  const FracturePattern& f = r.fracture;
  o << csv_field(scene.name) << ',' << r.peak_stress << ',' << r.strain_at_peak << ',' << r.peak_indirect_tensile << ','
    << scene.confinement.pressure * scene.confinement.enabled << ',' << scene.platens.velocity << ','
    << r.last.energy_error << ',' << f.broken << ',' << f.mode_I << ',' << f.mode_II << ',' << f.mixed << ',' << f.area
    << ',' << f.plane_angle_deg << ',' << f.planarity << ',' << f.mean_facet_angle_deg << ',' << f.centroid.x << ','
    << f.centroid.y << ',' << f.centroid.z << ',' << r.steps << ',' << r.time << ',' << r.wall_seconds << ','
    << csv_field(r.end_reason) << '\n';
  write_file_atomically(path, o.str());
}

std::string duration(real s) {
  if (!std::isfinite(s) || s < 0) return "?";
  char b[32];
  if (s < 60)
    std::snprintf(b, sizeof b, "%.0fs", s);
  else if (s < 3600)
    std::snprintf(b, sizeof b, "%dm%02ds", int(s / 60), int(s) % 60);
  else
    std::snprintf(b, sizeof b, "%dh%02dm", int(s / 3600), int(s / 60) % 60);
  return b;
}

/// The state a ParaView frame shows. Frames before and at the peak are written from saved
/// copies once the peak is known (the stress has fallen 5 % below it).
struct FrameState {
  real time = 0, stress = 0;
  long step = 0;
  std::vector<Vec3> x, v;
  std::vector<Ce6State> ce6;
  std::vector<std::uint8_t> active;
};

FrameState save_state(const Solver& s, real stress) {
  s.sync_host();
  FrameState f;
  f.time = s.time();
  f.step = s.step_count();
  f.stress = stress;
  f.x = s.x;
  f.v = s.v;
  f.ce6 = s.ce6;
  if (s.contacts.enabled()) f.active = s.contacts.active();
  return f;
}

/// Every field of a FrameState in checkpoint order, for one visitor (put or get).
template <class F, class S>
void frame_state_fields(F&& f, S& s) {
  f(s.time), f(s.stress), f(s.step), f(s.x), f(s.v), f(s.ce6), f(s.active);
}
void save_frame_state(CheckpointOut& o, const FrameState& f) {
  frame_state_fields([&](const auto& v) { o.put(v); }, f);
}
void load_frame_state(CheckpointIn& in, FrameState& f) {
  frame_state_fields([&](auto& v) { in.get(v); }, f);
}

/// One ParaView frame of the state (x, v, ce6, activation flags). `more` adds per-tet fields; a
/// diagnostic frame shows a stress that is not finite (an inverted tet) as zero instead of
/// refusing the frame.
void write_frame(FieldWriter& w, const Solver& s, real time, long step, const std::vector<Vec3>& x,
                 const std::vector<Vec3>& v, const std::vector<Ce6State>& ce6, const std::vector<std::uint8_t>* flags,
                 const std::string& label, const std::vector<TetField>& more = {}, bool diagnostic = false) {
  std::vector<Vec3> u(x.size());
  for (std::size_t n = 0; n < u.size(); ++n) u[n] = x[n] - s.model().X[n];
  std::vector<Sym3> stress;
  std::vector<real> vm;
  s.tet_stress(x, v, stress, vm);
  if (diagnostic)
    for (std::size_t t = 0; t < vm.size(); ++t)
      if (!std::isfinite(vm[t])) stress[t] = Sym3{}, vm[t] = 0;
  std::vector<std::array<int, 3>> faces;
  std::vector<real> damage;
  std::vector<int> mode;
  s.crack_faces(ce6, faces, damage, mode);
  FieldFrame fr;
  fr.time = time;
  fr.step = step;
  fr.label = label;
  fr.x = &x;
  fr.u = &u;
  fr.v = &v;
  fr.tets = &s.model().tet_nodes;
  fr.stress = &stress;
  fr.von_mises = &vm;
  fr.crack_faces = &faces;
  fr.crack_damage = &damage;
  fr.crack_mode = &mode;
  std::vector<real> active;
  if (flags) {
    active.assign(flags->begin(), flags->end());
    fr.extra.push_back({"active", &active});
  }
  fr.extra.insert(fr.extra.end(), more.begin(), more.end());
  if (!s.distributed()) {
    w.write(fr);
    return;
  }
  // Several ranks: this rank's own tets only (ghosts are written by their owners), and the
  // rank of each tet as a field.
  const std::vector<std::uint8_t>& own = s.owned_tets();
  std::vector<std::array<int, 4>> tets;
  std::vector<Sym3> st;
  std::vector<real> vm_own, rank;
  std::vector<std::vector<real>> extra(fr.extra.size());
  for (std::size_t t = 0; t < own.size(); ++t) {
    if (!own[t]) continue;
    tets.push_back(s.model().tet_nodes[t]);
    st.push_back(stress[t]);
    vm_own.push_back(vm[t]);
    for (std::size_t k = 0; k < extra.size(); ++k) extra[k].push_back((*fr.extra[k].values)[t]);
  }
  rank.assign(tets.size(), real(s.rank()));
  fr.tets = &tets;
  fr.stress = &st;
  fr.von_mises = &vm_own;
  for (std::size_t k = 0; k < extra.size(); ++k) fr.extra[k].values = &extra[k];
  fr.extra.push_back({"rank", &rank});
  w.write(fr);
}

void write_frame(FieldWriter& w, const Solver& s, const std::string& label) {
  s.sync_host();
  write_frame(w, s, s.time(), s.step_count(), s.x, s.v, s.ce6, s.contacts.enabled() ? &s.contacts.active() : nullptr,
              label);
}

void write_frame(FieldWriter& w, const Solver& s, const FrameState& f, const std::string& label) {
  if (f.x.size() < s.x.size() || f.ce6.size() < s.ce6.size() ||
      (!f.active.empty() && f.active.size() < s.model().tet_nodes.size())) {
    // The contact ghosts grew since the frame was kept: the ghosts appended since take their
    // present state (this rank writes its own tets only, and their nodes are the old ones).
    s.sync_host();
    FrameState g = f;
    g.x.insert(g.x.end(), s.x.begin() + f.x.size(), s.x.end());
    g.v.insert(g.v.end(), s.v.begin() + f.v.size(), s.v.end());
    g.ce6.insert(g.ce6.end(), s.ce6.begin() + f.ce6.size(), s.ce6.end());
    if (!g.active.empty())
      g.active.insert(g.active.end(), s.contacts.active().begin() + f.active.size(), s.contacts.active().end());
    write_frame(w, s, g, label);
    return;
  }
  write_frame(w, s, f.time, f.step, f.x, f.v, f.ce6, f.active.empty() ? nullptr : &f.active, label);
}

/// The frame of an unstable run, labelled "diagnostic": non-finite positions and velocities are
/// replaced by the reference positions and zero (so no file holds NaN), and two per-tet fields
/// show where it went wrong: "non_finite" (a node of the tet had a non-finite value) and
/// "inverted" (volume ratio J <= 0). Never throws: the frames written before stay valid.
void write_diagnostic(FieldWriter& w, const Solver& s) {
  try {
    s.sync_host();
    const Model& m = s.model();
    std::vector<Vec3> x = s.x, v = s.v;
    std::vector<char> bad(x.size(), 0);
    for (std::size_t n = 0; n < x.size(); ++n)
      if (!std::isfinite(x[n].x + x[n].y + x[n].z + v[n].x + v[n].y + v[n].z)) {
        bad[n] = 1;
        x[n] = m.X[n];
        v[n] = {0, 0, 0};
      }
    const std::size_t nt = m.tet_nodes.size();
    std::vector<real> non_finite(nt, 0), inverted(nt, 0);
    for (std::size_t t = 0; t < nt; ++t) {
      const auto& q = m.tet_nodes[t];
      for (int n : q) non_finite[t] = std::max(non_finite[t], real(bad[n]));
      const real vol = dot(cross(x[q[1]] - x[q[0]], x[q[2]] - x[q[0]]), x[q[3]] - x[q[0]]) / 6;
      inverted[t] = non_finite[t] == 0 && !(vol / m.tet_V0[t] > 0);
    }
    write_frame(w, s, s.time(), s.step_count(), x, v, s.ce6, s.contacts.enabled() ? &s.contacts.active() : nullptr,
                "diagnostic", {{"non_finite", &non_finite}, {"inverted", &inverted}}, true);
  } catch (const std::exception&) {
    // Nothing more to show; the frames written before remain valid.
  }
}

/// Several ranks: each writes its own tets to fields_rank<r>.{h5,xdmf}; rank 0 writes fields.xdmf,
/// which shows every rank's grids in each frame (the per-rank "rock" and "cracks" grids of a
/// frame side by side, renamed rock_rank<r> and cracks_rank<r>). Collective; the frames must be
/// the same on every rank (they are: their labels and steps follow the global monitors).
void write_merged_index(const FieldWriter& w, const Solver& s, const std::string& folder) {
  std::string mine;
  for (const std::string& g : w.state().grids) mine += g + '\x1e';
  int len = int(mine.size());
  const int size = s.decomposition().size, root = s.rank() == 0;
  std::vector<int> lens(size), offs(size + 1, 0);
  MPI_Gather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, 0, s.comm());
  for (int r = 0; r < size; ++r) offs[r + 1] = offs[r] + lens[r];
  std::string all(root ? offs[size] : 0, '\0');
  MPI_Gatherv(mine.data(), len, MPI_CHAR, all.data(), lens.data(), offs.data(), MPI_CHAR, 0, s.comm());
  if (!root) return;
  std::vector<std::vector<std::string>> grids(size);  // [rank][frame]
  for (int r = 0; r < size; ++r) {
    std::stringstream in(all.substr(offs[r], lens[r]));
    for (std::string g; std::getline(in, g, '\x1e');) grids[r].push_back(g);
  }
  std::string text =
      "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
      "<Xdmf xmlns:xi=\"http://www.w3.org/2001/XInclude\" Version=\"3.0\">\n"
      "  <Domain>\n"
      "  <Grid Name=\"fdem\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (std::size_t i = 0; i < grids[0].size(); ++i) {
    // Head (the frame's collection, time, step, label) from rank 0; the inner grids of all.
    const std::string& g0 = grids[0][i];
    std::size_t head = 0;
    for (int l = 0; l < 4; ++l) head = g0.find('\n', head) + 1;
    text += g0.substr(0, head);
    for (int r = 0; r < size; ++r) {
      if (i >= grids[r].size())
        throw OutputError("field output: rank " + std::to_string(r) + " lacks frame " + std::to_string(i) +
                          " of the merged index");
      const std::string& g = grids[r][i];
      std::size_t b = 0;
      for (int l = 0; l < 4; ++l) b = g.find('\n', b) + 1;
      const std::size_t e = g.rfind("    </Grid>");
      std::string inner = g.substr(b, e - b);
      for (const char* name : {"rock", "cracks"}) {
        const std::string from = std::string("<Grid Name=\"") + name + "\"";
        const std::size_t at = inner.find(from);
        if (at != std::string::npos)
          inner.replace(at, from.size(), std::string("<Grid Name=\"") + name + "_rank" + std::to_string(r) + "\"");
      }
      text += inner;
    }
    text += "    </Grid>\n";
  }
  text += "  </Grid>\n  </Domain>\n</Xdmf>\n";
  write_file_atomically((std::filesystem::path(folder) / "fields.xdmf").string(), text);
}

/// Keeps what the pre-peak and peak frames need: the state at the running maximum of the axial
/// stress, and a ladder of states 5 % apart in stress between 0.7 and 1 of that maximum, from
/// which the one nearest kPrePeak of the peak is written as "pre-peak". At most 8 in the ladder
/// (0.7 x 1.05^7 < 1) and the peak: 9 copies.
class PeakFrames {
 public:
  static constexpr real kPrePeak = 0.8;
  void observe(const Solver& s, real stress) {
    if (stress <= max_) return;
    max_ = stress;
    peak_ = save_state(s, stress);
    if (ladder_.empty() || stress >= real(1.05) * ladder_.back().stress) ladder_.push_back(peak_);
    while (ladder_.size() > 1 && ladder_.front().stress < real(0.7) * max_) ladder_.pop_front();
  }
  /// Writes "pre-peak", "peak" and (the current state) "post-peak" frames; call once the stress
  /// has fallen past the peak. The frames of an earlier, lower peak are relabelled "local-...".
  void write(FieldWriter& w, const Solver& s) {
    for (const auto& [index, label] : written_) w.relabel(index, "local-" + label);
    written_.clear();
    const FrameState* pre = nullptr;
    for (const FrameState& f : ladder_)
      if (f.step < peak_.step &&
          (!pre || std::fabs(f.stress - kPrePeak * max_) < std::fabs(pre->stress - kPrePeak * max_)))
        pre = &f;
    if (pre) {
      write_frame(w, s, *pre, "pre-peak");
      written_.push_back({w.frames() - 1, "pre-peak"});
    }
    if (max_ > 0) {
      write_frame(w, s, peak_, "peak");
      written_.push_back({w.frames() - 1, "peak"});
    }
    write_frame(w, s, "post-peak");
    written_.push_back({w.frames() - 1, "post-peak"});
  }

  void save(CheckpointOut& o) const {
    o.put(max_);
    save_frame_state(o, peak_);
    o.put(std::uint64_t(ladder_.size()));
    for (const FrameState& f : ladder_) save_frame_state(o, f);
    o.put(std::uint64_t(written_.size()));
    for (const auto& [index, label] : written_) {
      o.put(index);
      o.put(label);
    }
  }
  void load(CheckpointIn& in) {
    in.get(max_);
    load_frame_state(in, peak_);
    std::uint64_t n = 0;
    in.get(n);
    ladder_.clear();
    for (std::uint64_t i = 0; i < n; ++i) load_frame_state(in, ladder_.emplace_back());
    in.get(n);
    written_.clear();
    for (std::uint64_t i = 0; i < n; ++i) {
      auto& [index, label] = written_.emplace_back();
      in.get(index);
      in.get(label);
    }
  }

 private:
  real max_ = 0;
  FrameState peak_;
  std::deque<FrameState> ladder_;
  std::vector<std::pair<int, std::string>> written_;  // frame index and label of the last set
};

/// Keeps the newest `keep` checkpoints of a folder and removes the rest.
void prune_checkpoints(const std::string& folder, std::size_t keep, const std::string& suffix) {
  std::vector<std::string> all = find_checkpoints(folder, suffix);
  for (std::size_t i = keep; i < all.size(); ++i) std::filesystem::remove(all[i]);
}

/// Flushes a file (or folder) to disk; best effort (a checkpoint must not end a run).
void sync_path(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

/// FNV-1a of the first `bytes` bytes of a file, or false if it is shorter.
bool hash_prefix(const std::string& path, std::uint64_t bytes, std::uint64_t& hash) {
  std::ifstream in(path, std::ios::binary);
  hash = kFnvSeed;
  std::vector<char> buf(1 << 20);
  while (bytes > 0 && in) {
    in.read(buf.data(), std::streamsize(std::min<std::uint64_t>(bytes, buf.size())));
    const std::uint64_t got = std::uint64_t(in.gcount());
    hash = fnv1a64(buf.data(), got, hash);
    bytes -= got;
    if (got == 0) break;
  }
  return bytes == 0;
}

/// monitors.csv with the length and FNV-1a of all it holds, so that a restart can check that
/// the file it cuts back is the one its checkpoint was taken with.
struct MonitorFile {
  std::ofstream f;
  std::uint64_t bytes = 0, hash = kFnvSeed;
  void put(const std::string& text) {
    f << text;
    bytes += text.size();
    hash = fnv1a64(text.data(), text.size(), hash);
  }
};

}  // namespace

// Checkpoint requests from signals: 1 = SIGUSR1 (write one, go on), 2 = SIGTERM or SIGINT (write
// one, stop). The handler only raises the value (lock-free atomics are async-signal-safe); the
// time loop takes it after every step, and a series looks at it between runs.
namespace {
std::atomic<int> g_signal_request{0};
static_assert(std::atomic<int>::is_always_lock_free, "the signal flag must be lock-free");

extern "C" void on_checkpoint_signal(int sig) {
  if (sig != SIGUSR1) {
    g_signal_request.store(2);
  } else {
    int none = 0;
    g_signal_request.compare_exchange_strong(none, 1);
  }
}
}  // namespace

SignalGuard::SignalGuard() {
  struct sigaction sa {};
  sa.sa_handler = on_checkpoint_signal;
  sigemptyset(&sa.sa_mask);
  for (int sig : kSignals) sigaddset(&sa.sa_mask, sig);
  sa.sa_flags = SA_RESTART;
  for (int i = 0; i < 3; ++i) sigaction(kSignals[i], &sa, &old_[i]);
}

SignalGuard::~SignalGuard() {
  for (int i = 0; i < 3; ++i) sigaction(kSignals[i], &old_[i], nullptr);
}

bool stop_requested() {
  return g_signal_request.load() == 2;
}

std::string checkpoint_suffix(int rank, int size) {
  return size > 1 ? ".rank" + std::to_string(rank) + "of" + std::to_string(size) + ".ckpt" : ".ckpt";
}

std::vector<std::string> find_checkpoints(const std::string& path, const std::string& suffix) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const bool one_rank = suffix == ".ckpt";
  if (one_rank && fs::is_regular_file(path, ec)) return {path};
  fs::path dir = path;
  if (fs::is_regular_file(dir, ec)) dir = dir.parent_path();  // several ranks: the folder of the file
  if (fs::is_directory(dir / "checkpoints", ec)) dir /= "checkpoints";
  std::vector<std::string> found;
  auto ends_with = [](const std::string& s, const std::string& e) {
    return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
  };
  if (fs::is_directory(dir, ec))
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
      const std::string name = e.path().filename().string();
      if (e.is_regular_file() && ends_with(name, suffix) && (!one_rank || name.find(".rank") == std::string::npos))
        found.push_back(e.path().string());
    }
  // step_<12 digits>.ckpt: the names sort by step.
  std::sort(found.rbegin(), found.rend());
  return found;
}

bool run_python_script(const std::string& script, std::vector<std::string> args) {
  const std::string py = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  args.insert(args.begin(), {py, std::string(FDEM_SCRIPTS_DIR) + "/" + script});
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t quiet;
  posix_spawn_file_actions_init(&quiet);
  posix_spawn_file_actions_addopen(&quiet, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&quiet, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, argv[0], &quiet, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&quiet);
  int status = 0;
  return rc == 0 && waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

/// A tet whose least altitude is below this fraction of the mean edge is named as a sliver: it
/// alone sets the stable step (a gmsh mesh's least altitude is about 0.1 to 0.2 of its mean edge).
constexpr real kSliver = 1e-2;

void report_model(const Solver& solver, std::ostream& out) {
  const Model& m = solver.model();
  const StableStep& st = solver.stable_step();
  const Decomposition& dd = solver.decomposition();
  if (dd.distributed()) {
    long own = 0;
    for (auto o : dd.tet_owned) own += o;
    out << "model " << m.source << "\n"
        << "  tets " << dd.global_tets << ", CE6 " << dd.global_ce6 << ", nodes " << dd.global_nodes << " on "
        << dd.size << " MPI ranks (contact reach " << dd.reach << " m); rank " << dd.rank << " holds " << own
        << " own and " << m.tet_nodes.size() - own << " ghost tets, " << m.X.size() << " nodes\n";
  } else {
    out << "model " << m.source << "\n"
        << "  tets " << m.tet_nodes.size() << ", CE6 " << m.ce6_nodes.size() << ", nodes " << m.X.size()
        << ", surface faces " << m.surface_faces.size() << "\n";
  }
  out << "  height " << m.height0 << " m, loaded area " << m.area0 << " m^2, mean edge " << m.mean_edge
      << " m, minimum altitude " << m.min_altitude << " m\n"
      << (m.min_altitude < kSliver * m.mean_edge && m.min_altitude_tet >= 0
              ? "  warning: tet " + std::to_string(m.min_altitude_tet + 1) + " of " + m.source +
                    " is a sliver (altitude " + fmt(m.min_altitude, 3) + " m, " + fmt(m.min_altitude / m.mean_edge, 2) +
                    " of the mean edge): it sets the stable step. Fix: remesh or optimise the mesh (gmsh "
                    "-optimize_netgen)\n"
              : std::string())
      << "  stable step " << solver.stable_bound() << " s limited by " << st.limit << " (TET4 " << st.dt_tet
      << " s, CE6 " << st.dt_ce6 << " s, platens " << st.dt_platen << " s, contact " << st.dt_contact << " s)\n"
      << "  backend " << backend_name(solver.backend())
      << (solver.backend() == Backend::cuda ? " (" + cuda_device_description() + ")" : std::string())
      << (solver.device_loop() ? solver.device_loop()->integrates()
                                     ? ", TET4, CE6, the forces held for their nodes and the step fused in one pass"
                                 : solver.device_loop()->fused() ? ", TET4 and CE6 fused in one pass"
                                                                 : ", TET4 and CE6 colour by colour"
                               : "")
      << (solver.device_loop() && dd.distributed() ? solver.device_loop()->halo_passes_device_buffers()
                                                         ? ", halo: device buffers to MPI"
                                                         : ", halo: staged through host memory"
                                                   : "")
      << "\n"
      << "  time step " << solver.dt() << " s ("
      << (solver.scene().solver.time_step > 0
              ? "solver.time_step, " + fmt(solver.dt() / solver.stable_bound(), 3) + " x the stable-step bound"
              : "safety " + fmt(solver.scene().solver.time_step_safety))
      << ", mass scaling " << solver.scene().solver.mass_scaling << ")\n";
}

namespace {
/// Before a fresh run removes or truncates anything of an earlier run in its folder: each of
/// `names` there is absent or a file it can replace ("checkpoints" a folder), and the folder can
/// be written. "" if so, else what stands in the way.
/// Rank 0 takes the lock of the run's folder for the whole job; where it cannot, every rank
/// throws its InputError.
std::unique_ptr<RunLock> lock_run_folder(const std::string& folder, const Solver& solver, std::ostream& log) {
  std::unique_ptr<RunLock> lock;
  std::string refused;
  if (solver.rank() == 0) {
    try {
      lock = std::make_unique<RunLock>(folder, this_command(), log);
    } catch (const InputError& e) {
      refused = e.what();
    }
  }
  if (solver.distributed()) {
    int n = int(refused.size());
    MPI_Bcast(&n, 1, MPI_INT, 0, solver.comm());
    refused.resize(std::size_t(n));
    MPI_Bcast(refused.data(), n, MPI_CHAR, 0, solver.comm());
  }
  if (!refused.empty()) throw InputError(refused);
  return lock;
}

std::string replace_problem(const std::string& folder, const std::vector<std::string>& names) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const std::string& name : names) {
    const fs::path p = fs::path(folder) / name;
    const fs::file_status st = fs::status(p, ec);
    if (!fs::exists(st)) continue;
    const bool folder_wanted = name == "checkpoints";
    if (folder_wanted ? !fs::is_directory(st) : !fs::is_regular_file(st))
      return p.string() + " is " + (fs::is_directory(st) ? "a folder" : "not a regular file") +
             " where the run writes its " + (folder_wanted ? "checkpoint folder" : "file");
    if (!folder_wanted && ::access(p.c_str(), W_OK) != 0)
      return p.string() + " cannot be written (" + std::strerror(errno) + ")";
  }
  if (::access(folder.c_str(), W_OK | X_OK) != 0) return folder + " cannot be written (" + std::strerror(errno) + ")";
  return "";
}
}  // namespace

real end_progress(const EndCondition& end, long step, real time, real axial_strain, real peak, real stress) {
  real p = 0;
  if (end.steps > 0) p = std::max(p, real(step) / real(end.steps));
  if (end.time > 0) p = std::max(p, time / end.time);
  if (end.axial_strain > 0) p = std::max(p, axial_strain / end.axial_strain);
  if (end.post_peak_fraction > 0 && end.post_peak_fraction < 1 && peak > 0 && stress < peak)
    p = std::max(p, (peak - stress) / (peak * (1 - end.post_peak_fraction)));
  return std::min(p, real(1));
}

RunSummary run_scene(Solver& solver, std::ostream& log, const RunOptions& options) {
  namespace fs = std::filesystem;
  const Scene& scene = solver.scene();
  const OutputSettings& out = scene.output;
  const EndCondition& end = scene.solver.end;
  RunSummary sum;
  sum.folder = out.folder;
  std::error_code ec;
  // A restart continues in a folder that holds the run (it is not created, so that a wrong one
  // is not left behind empty); a fresh run creates its own.
  if (options.restart.empty()) fs::create_directories(out.folder, ec);
  if (ec) throw InputError(scene.file + ": output.folder: cannot create '" + out.folder + "': " + ec.message());
  // Several ranks: rank 0 writes the monitors and the summary, every rank its own field files.
  const bool dist = solver.distributed(), root = solver.rank() == 0;
  const std::string csv_path = root ? (fs::path(out.folder) / "monitors.csv").string() : "/dev/null";
  const std::string ckpt_dir = (fs::path(out.folder) / "checkpoints").string();
  const std::string fields_name = dist ? "fields_rank" + std::to_string(solver.rank()) : "fields";
  const int ranks = dist ? solver.decomposition().size : 1;
  const std::string suffix = checkpoint_suffix(solver.rank(), ranks);
  // Several ranks decide together: true only where true on every rank.
  auto all_ranks = [&](bool ok) {
    if (!dist) return ok;
    int v = ok;
    MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_INT, MPI_MIN, solver.comm());
    return v != 0;
  };

  // Everything the loop below carries from step to step, besides the solver.
  Monitors mon;
  bool peak_written = false;
  PeakFrames peak_frames;
  real wall_before = 0;  // s, spent by the run before the checkpoint it continues from
  MonitorFile csv;
  std::unique_ptr<FieldWriter> fields;

  // Why the run ends after the step just taken ("" where it goes on); monitor_now: mon was just measured.
  auto end_reason = [&](bool monitor_now) {
    const long n = solver.step_count();
    const real strain = solver.top_offset / solver.model().height0;
    std::string reason;
    if (end.steps > 0 && n >= end.steps) reason = "step count " + std::to_string(end.steps) + " reached";
    if (end.time > 0 && solver.time() >= end.time) reason = "end time reached";
    if (end.axial_strain > 0 && strain >= end.axial_strain) reason = "axial strain reached";
    if (monitor_now && end.post_peak_fraction > 0 && sum.peak_stress > 0 &&
        mon.axial_stress < end.post_peak_fraction * sum.peak_stress)
      reason = "stress fell below " + std::to_string(end.post_peak_fraction) + " of the peak";
    return reason;
  };

  if (!options.restart.empty() && fs::is_directory(out.folder, ec) && ::access(out.folder.c_str(), W_OK) != 0)
    throw InputError("--restart: cannot write in " + out.folder + " (" + std::strerror(errno) +
                     "), where the run goes on; nothing was changed. Fix: make the folder writable, or copy it "
                     "somewhere writable and restart there (with -o)");
  // One run at a time in the folder (a restart's folder that does not exist is named below).
  std::unique_ptr<RunLock> lock;
  if (!options.folder_locked && (options.restart.empty() || all_ranks(fs::is_directory(out.folder, ec))))
    lock = lock_run_folder(out.folder, solver, log);
  if (!options.restart.empty()) {
    // The newest checkpoint that reads and matches the files here; a damaged one, or one whose
    // monitors.csv is not the one in this folder, falls back to the one before.
    // Several ranks: rank 0's steps are the candidates, and each rank reads its own file of one.
    std::vector<std::string> found = find_checkpoints(options.restart, suffix);
    auto step_of = [](const std::string& file) {
      const std::string name = fs::path(file).filename().string();
      return name.rfind("step_", 0) == 0 ? std::atol(name.c_str() + 5) : -1L;
    };
    if (dist) {
      std::vector<long> steps;
      for (const std::string& f : found) steps.push_back(step_of(f));
      long n = long(steps.size());
      MPI_Bcast(&n, 1, MPI_LONG, 0, solver.comm());
      steps.resize(n);
      MPI_Bcast(steps.data(), int(n), MPI_LONG, 0, solver.comm());
      std::vector<std::string> mine;
      for (long st : steps) {
        std::string file;  // "" where this rank has no file of that step
        for (const std::string& f : found)
          if (step_of(f) == st) file = f;
        mine.push_back(file);
      }
      found.swap(mine);
    }
    if (found.empty())
      throw InputError("--restart " + options.restart + ": no checkpoint there (files checkpoints/step_<n>" + suffix +
                       "). Fix: give the output folder of the interrupted run" +
                       (dist ? " and run it on as many ranks as it had" : " or one of its .ckpt files"));
    std::string problems;
    for (std::size_t k = 0; k < found.size(); ++k) {
      const std::string& file = found[k];
      std::string why;
      FieldWriterState fs_state;
      if (file.empty()) {
        why = "rank " + std::to_string(solver.rank()) + " has no file of the step rank 0 has";
      } else {
        std::optional<CheckpointIn> in;
        try {
          in.emplace(read_checkpoint(file));
        } catch (const CannotOpen& e) {
          // Not damaged, only unreadable: falling back would drop its rows and remove it.
          throw InputError("--restart " + options.restart + ": " + e.what() + "; nothing was changed");
        } catch (const InputError& e) {
          why = e.what();
        }
        if (in) {
          solver.load(*in);
          in->get(mon);
          in->get(sum.peak_stress);
          in->get(sum.strain_at_peak);
          in->get(sum.peak_indirect_tensile);
          in->get(peak_written);
          peak_frames.load(*in);
          in->get(wall_before);
          in->get(csv.bytes);
          in->get(csv.hash);
          in->get(fs_state.grids);
          in->get(fs_state.labels);
          in->get(fs_state.mesh_tets);
          in->get(fs_state.have_mesh);
          in->finish();
          std::uint64_t hash = 0;
          const fs::path h5 = fs::path(out.folder) / (fields_name + ".h5");
          const std::string back =
              ". Fix: put back the monitors.csv the run wrote, or restart in the interrupted "
              "run's folder (output.folder or -o)";
          if (root && !fs::is_regular_file(csv_path, ec))
            why = file + ": " + csv_path + " is missing" + back;
          else if (root && !hash_prefix(csv_path, csv.bytes, hash))
            why = file + ": " + csv_path + " holds " + std::to_string(fs::file_size(csv_path, ec)) +
                  " bytes, fewer than the " + std::to_string(csv.bytes) +
                  " it held at this checkpoint (cut short, or another run's)" + back;
          else if (root && hash != csv.hash)
            why = file + ": " + csv_path + " differs in its first " + std::to_string(csv.bytes) +
                  " bytes from the monitors.csv of this checkpoint (edited, saved again by a spreadsheet, or "
                  "another run's)" +
                  back;
          else if (!fs::is_regular_file(h5, ec))
            why = file + ": " + h5.string() + " is missing";
        }
      }
      if (!all_ranks(why.empty())) {
        if (why.empty()) why = (file.empty() ? "step " : file + ": ") + std::string("another rank cannot use its file");
        if (dist && !root) why = "rank " + std::to_string(solver.rank()) + ": " + why;
        (root ? log : std::cerr) << "warning: " << why << std::endl;
        problems += "\n  " + why;
        continue;
      }
      // A scene whose end was moved before the checkpoint: the loop would take one step more
      // and stop, after the rows and frames past the checkpoint had been dropped.
      if (const std::string reason = end_reason(true); !reason.empty())
        throw InputError("--restart " + options.restart + ": " + file + " is at step " +
                         std::to_string(solver.step_count()) + ", t = " + fmt(solver.time(), 6) +
                         " s, where the scene's end is already reached (" + reason +
                         "); nothing was changed. Fix: move solver.end in " + scene.file +
                         " past it to continue the run, or run without --restart to start again");
      // Rows and frames written after the checkpoint are dropped; the loop writes them again.
      // Newer checkpoints (damaged, or of the history being replaced) go too.
      fields = std::make_unique<FieldWriter>(out.folder, fields_name, fs_state);
      if (!fields->repaired().empty()) (root ? log : std::cerr) << "warning: " << fields->repaired() << std::endl;
      if (root) {
        fs::resize_file(csv_path, csv.bytes, ec);
        if (ec) throw OutputError("cannot truncate " + csv_path + ": " + ec.message());
      }
      csv.f.open(csv_path, std::ios::app);
      for (std::size_t j = 0; j < k; ++j)
        if (!found[j].empty() && fs::path(found[j]).parent_path() == fs::path(file).parent_path())
          fs::remove(found[j], ec);
      log << "restart: continuing from " << file << (dist ? " (and the other ranks' files of that step)" : "")
          << " at step " << solver.step_count() << ", t = " << solver.time() << " s" << std::endl;
      break;
    }
    if (!csv.f.is_open())
      throw InputError("--restart " + options.restart + ": no usable checkpoint:" + problems +
                       "\nnothing was changed; without a usable checkpoint the run can only start afresh (without "
                       "--restart)");
  } else {
    // A fresh run replaces an earlier run's outputs in this folder: first a check that it can
    // (on every rank), so that a failure leaves them whole; then its checkpoints, summary, plot
    // and broken-CE6 list go (they belong to the files replaced), and the rest is overwritten.
    std::vector<std::string> names{fields_name + ".h5", fields_name + ".xdmf"};
    if (root)
      names.insert(names.end(), {"monitors.csv", "summary.csv", "broken_ce6.csv", "stress_strain.png", "checkpoints"});
    if (root && dist) names.push_back("fields.xdmf");  // the merged index of the ranks' files
    const std::string problem = replace_problem(out.folder, names);
    if (!all_ranks(problem.empty()))
      throw OutputError(("the run cannot replace the outputs of an earlier one: " +
                         (problem.empty() ? "another rank found one in the way" : problem)) +
                        "; nothing was changed. Fix: move it away, or give the run another output folder (-o)");
    if (root) {
      fs::remove_all(ckpt_dir, ec);
      for (const char* stale : {"summary.csv", "broken_ce6.csv", "stress_strain.png"})
        fs::remove(fs::path(out.folder) / stale, ec);
    }
    csv.f.open(csv_path);
  }
  if (!csv.f) throw InputError(scene.file + ": output.folder: cannot write '" + csv_path + "'");
  if (!fields) {
    csv.put(std::string(kCsvHeader) + "\n");
    fields = std::make_unique<FieldWriter>(out.folder, fields_name);
  }
  // Several ranks: the merged index after every change of the frames (collective); at once
  // after a restart, which may have dropped frames.
  int merged_frames = options.restart.empty() ? 0 : -1;
  auto merge_index = [&] {
    if (!dist || fields->frames() == merged_frames) return;
    write_merged_index(*fields, solver, out.folder);
    merged_frames = fields->frames();
  };
  merge_index();

  // Expected number of steps, for the automatic field interval.
  const real end_steps = solver.end_steps().steps;
  const real expected = std::isfinite(end_steps) ? end_steps : 0;
  const long field_interval = out.field_interval > 0 ? out.field_interval : std::max<long>(1, long(expected / 20));

  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<real>(std::chrono::steady_clock::now() - t0).count(); };
  real next_progress = out.progress_interval;
  real last_checkpoint_wall = 0;
  const long first_step = solver.step_count();
  // The progress towards the end where this session starts (a restart's: where it left off).
  const real progress0 = end_progress(end, first_step, solver.time(), solver.top_offset / solver.model().height0,
                                      sum.peak_stress, mon.axial_stress);
  auto checkpoint = [&](const std::string& why) {
    csv.f.flush();
    if (!csv.f) throw OutputError("cannot write " + csv_path + ": " + write_failure(csv_path, errno));
    // The files the checkpoint refers to reach the disk before it does.
    sync_path(csv_path);
    sync_path(fields->h5_path());
    fs::create_directories(ckpt_dir, ec);
    CheckpointOut o;
    solver.save(o);
    o.put(mon);
    o.put(sum.peak_stress);
    o.put(sum.strain_at_peak);
    o.put(sum.peak_indirect_tensile);
    o.put(peak_written);
    peak_frames.save(o);
    o.put(wall_before + elapsed());
    o.put(csv.bytes);
    o.put(csv.hash);
    const FieldWriterState st = fields->state();
    o.put(st.grids);
    o.put(st.labels);
    o.put(st.mesh_tets);
    o.put(st.have_mesh);
    char name[48];
    std::snprintf(name, sizeof name, "step_%012ld", solver.step_count());
    const std::string path = (fs::path(ckpt_dir) / (name + suffix)).string();
    write_checkpoint(path, o);
    sync_path(ckpt_dir);
    prune_checkpoints(ckpt_dir, 2, suffix);
    last_checkpoint_wall = elapsed();
    log << "checkpoint (" << why << "): " << path << std::endl;
    return path;
  };
  SignalGuard signals;
  long pair_growth_seen = 0;  // device backends: growths of the contact pair buffers reported so far
  GhostGrowths growths_seen = solver.ghost_growths();  // several ranks: contact ghosts gathered again
  int pending_request = 0;                             // several ranks: a signal waits for the next monitor row
  if (options.restart.empty()) {
    mon = solver.measure();
    csv.put(monitor_row(mon, solver));
    write_frame(*fields, solver, "initial");
    merge_index();
  }
  try {
    for (;;) {
      solver.step();
      const long n = solver.step_count();
      const bool monitor_now = n % out.monitor_interval == 0;
      if (monitor_now) {
        mon = solver.measure();
        csv.put(monitor_row(mon, solver));
        if (const DeviceLoop* d = solver.device_loop(); d && d->times().pair_growth != pair_growth_seen) {
          pair_growth_seen = d->times().pair_growth;  // the buffers grow by half each time
          log << "device: contact pair buffers grew to hold " << mon.contact_pairs << " pairs (device memory "
              << fmt(double(device::bytes_in_use()) / 1e6, 4) << " MB)" << std::endl;
        }
        if (const GhostGrowths& g = solver.ghost_growths(); g.count != growths_seen.count) {
          log << "contact ghosts: gathered again " << g.count - growths_seen.count << " time(s) by step " << g.step
              << " (a node had moved a quarter of the contact reach " << solver.decomposition().reach << " m), "
              << g.tets - growths_seen.tets << " tets added to the rank models ("
              << fmt(g.seconds - growths_seen.seconds, 3) << " s)" << std::endl;
          growths_seen = g;
        }
        csv.f.flush();
        if (!csv.f) throw OutputError("cannot write " + csv_path + ": " + write_failure(csv_path, errno));
        if (mon.axial_stress > sum.peak_stress) {
          sum.peak_stress = mon.axial_stress;
          sum.strain_at_peak = mon.axial_strain;
          sum.peak_indirect_tensile = mon.indirect_tensile;
          peak_written = false;
          if (out.peak_frames) peak_frames.observe(solver, mon.axial_stress);
        } else if (!peak_written && sum.peak_stress > 0 && mon.axial_stress < 0.95 * sum.peak_stress) {
          // The peak has passed: the fracture pattern before, at and just after it.
          peak_written = true;
          if (out.peak_frames)
            peak_frames.write(*fields, solver);
          else
            write_frame(*fields, solver, "post-peak");
        }
      }
      if (n % field_interval == 0) write_frame(*fields, solver, "");
      merge_index();
      const real strain = solver.top_offset / solver.model().height0;
      const std::string reason = end_reason(monitor_now);
      const real wall = elapsed();
      if (!reason.empty() || (out.progress_interval > 0 && wall >= next_progress)) {
        // The ETA extrapolates the progress made since this session started at the pace so far.
        const real done = end_progress(end, n, solver.time(), strain, sum.peak_stress, mon.axial_stress) - progress0;
        char line[256];
        const real rate = (n - first_step) / std::max(wall, 1e-9);
        std::snprintf(line, sizeof line,
                      "step %ld  t %.4g s  axial strain %.3e  stress %.3f MPa  broken CE6 %ld  %.0f steps/s  ETA %s", n,
                      solver.time(), strain, mon.axial_stress / 1e6, mon.broken, rate,
                      !reason.empty() ? "done"
                      : done > 0      ? duration(wall * (1 - done - progress0) / done).c_str()
                                      : "?");
        log << line << std::endl;
        next_progress = wall + out.progress_interval;
      }
      if (!reason.empty()) {
        sum.end_reason = reason;
        break;
      }
      // Checkpoints: by steps, by wall time, or asked for by a signal. Several ranks agree on
      // signals and on rank 0's wall clock at monitor rows (one reduction there), so that all
      // write the same step.
      int request = std::max(pending_request, g_signal_request.exchange(0));
      bool wall_due = out.checkpoint_wall_interval > 0 && wall - last_checkpoint_wall >= out.checkpoint_wall_interval;
      if (dist) {
        if (!monitor_now) {
          pending_request = request;
          request = 0;
          wall_due = false;
        } else {
          int v[2] = {request, root && wall_due};
          MPI_Allreduce(MPI_IN_PLACE, v, 2, MPI_INT, MPI_MAX, solver.comm());
          request = v[0];
          wall_due = v[1] != 0;
          pending_request = 0;
        }
      }
      if (request == 2) {
        const std::string path = checkpoint("signal");
        throw Interrupted("stopped by a signal at step " + std::to_string(n) + " after writing " + path);
      }
      std::string why;
      if (request == 1)
        why = "SIGUSR1";
      else if (out.checkpoint_interval > 0 && n % out.checkpoint_interval == 0)
        why = "every " + std::to_string(out.checkpoint_interval) + " steps";
      else if (wall_due)
        why = "wall-time interval";
      if (!why.empty()) {
        // A checkpoint that cannot be written (disk full, folder gone) does not end the run:
        // the run goes on and tries again at the next one.
        try {
          checkpoint(why);
        } catch (const OutputError& e) {
          last_checkpoint_wall = elapsed();
          log << "warning: checkpoint (" << why << ") not written, the run goes on: " << e.what() << std::endl;
        }
      }
    }
    mon = solver.measure();
    if (solver.step_count() % out.monitor_interval != 0) csv.put(monitor_row(mon, solver));
  } catch (const RunError&) {
    write_diagnostic(*fields, solver);
    throw;
  }
  csv.f.close();
  if (!csv.f) throw OutputError("cannot write " + csv_path + ": " + write_failure(csv_path, errno));
  write_frame(*fields, solver, "final");
  merge_index();
  sum.steps = solver.step_count();
  sum.time = solver.time();
  sum.wall_seconds = wall_before + elapsed();
  sum.last = mon;
  {
    std::vector<std::array<Vec3, 3>> faces;
    std::vector<int> mode;
    solver.broken_faces(faces, mode);
    sum.fracture = fracture_pattern(faces, mode, {0, 0, 1});
  }
  if (out.plot && root) {
    const std::string png = (fs::path(out.folder) / "stress_strain.png").string();
    if (!run_python_script("plot_curves.py", {csv_path, png, "--title=" + scene.name}))
      log << "warning: could not plot " << png << " (needs python3-matplotlib); the curves are in " << csv_path
          << std::endl;
  }
  {
    // The broken CE6s by id (the fracture pattern, for comparisons such as `fdem study`).
    // Global CE6 ids; several ranks send theirs (owned ones) to rank 0.
    std::vector<long> broken;  // id, mode
    solver.sync_host();
    for (std::size_t i = 0; i < solver.ce6.size(); ++i)
      if (solver.ce6[i].mode != 0 && solver.owned_ce6()[i])
        broken.insert(broken.end(), {dist ? solver.decomposition().ce6_global[i] : long(i), long(solver.ce6[i].mode)});
    if (dist) {
      const int size = solver.decomposition().size;
      int len = int(broken.size());
      std::vector<int> lens(size), offs(size + 1, 0);
      MPI_Gather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, 0, solver.comm());
      for (int r = 0; r < size; ++r) offs[r + 1] = offs[r] + lens[r];
      std::vector<long> all(root ? offs[size] : 0);
      MPI_Gatherv(broken.data(), len, MPI_LONG, all.data(), lens.data(), offs.data(), MPI_LONG, 0, solver.comm());
      std::vector<std::array<long, 2>> rows;
      for (std::size_t k = 0; k + 1 < all.size(); k += 2) rows.push_back({all[k], all[k + 1]});
      std::sort(rows.begin(), rows.end());
      broken.clear();
      for (const auto& r : rows) broken.insert(broken.end(), {r[0], r[1]});
    }
    if (root) {
      const std::string path = (fs::path(out.folder) / "broken_ce6.csv").string();
      std::ofstream o(path);
      o << "ce6,mode\n";
      for (std::size_t k = 0; k + 1 < broken.size(); k += 2) o << broken[k] << ',' << broken[k + 1] << '\n';
      if (!o) throw OutputError("cannot write " + path);
    }
  }
  if (root) write_summary((fs::path(out.folder) / "summary.csv").string(), scene, sum);
  return sum;
}

}  // namespace fdem
