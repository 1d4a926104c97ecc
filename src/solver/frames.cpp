#include "solver/frames.hpp"

#include <mpi.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>

#include "core/error.hpp"
#include "io/checkpoint.hpp"

namespace fdem {
namespace {

/// Every field of a FrameState in checkpoint order, for one visitor (put or get).
template <class F, class S>
void frame_state_fields(F&& f, S& s) {
  f(s.time), f(s.stress), f(s.step), f(s.x), f(s.v), f(s.ce6), f(s.active);
}
/// Several ranks, or an excavation: the frame of this rank's own tets (ghosts are written by
/// their owners), not those an excavation removed, with the rank of each tet as a field. Its
/// nodes are those of its tets and crack faces, renumbered: the rank's slab of the shared file.
void write_own_tets(FieldWriter& w, const Solver& s, FieldFrame& fr) {
  std::vector<std::uint8_t> own = s.owned_tets();
  own.resize(s.model().tet_nodes.size(), 1);  // (one rank: every tet its own)
  for (std::size_t t = 0; t < own.size(); ++t) own[t] = own[t] && !s.removed_tet(t);
  // Every array is sized before it is filled: a frame is the largest thing a rank builds
  // between checkpoints, and arrays that double as they grow would take up to twice it.
  const std::size_t kept = std::size_t(std::count(own.begin(), own.end(), 1));
  std::vector<std::array<int, 4>> tets;
  std::vector<Sym3> stress;
  std::vector<real> von_mises, rank(kept, real(s.rank()));
  std::vector<std::vector<real>> extra(fr.extra.size());
  tets.reserve(kept), stress.reserve(kept), von_mises.reserve(kept);
  for (auto& e : extra) e.reserve(kept);
  for (std::size_t t = 0; t < own.size(); ++t) {
    if (!own[t]) continue;
    tets.push_back(s.model().tet_nodes[t]);
    stress.push_back((*fr.stress)[t]);
    von_mises.push_back((*fr.von_mises)[t]);
    for (std::size_t k = 0; k < extra.size(); ++k) extra[k].push_back((*fr.extra[k].values)[t]);
  }
  std::vector<std::array<int, 3>> faces = *fr.crack_faces;
  // The slab's nodes: those of its tets and crack faces, numbered in the order first met.
  std::vector<int> slot(fr.x->size(), -1);
  int nodes = 0;
  auto renumber = [&](int& n) { n = slot[n] < 0 ? (slot[n] = nodes++) : slot[n]; };
  for (auto& q : tets) std::for_each(q.begin(), q.end(), renumber);
  for (auto& q : faces) std::for_each(q.begin(), q.end(), renumber);
  std::vector<Vec3> x(nodes), u(nodes), v(nodes);
  const std::vector<Vec3>& X = s.model().X;
  for (std::size_t n = 0; n < slot.size(); ++n)
    if (slot[n] >= 0) x[slot[n]] = (*fr.x)[n], u[slot[n]] = (*fr.x)[n] - X[n], v[slot[n]] = (*fr.v)[n];
  fr.x = &x, fr.u = &u, fr.v = &v, fr.tets = &tets, fr.crack_faces = &faces;
  fr.stress = &stress;
  fr.von_mises = &von_mises;
  for (std::size_t k = 0; k < extra.size(); ++k) fr.extra[k].values = &extra[k];
  if (s.distributed()) fr.extra.push_back({"rank", &rank});
  w.write(fr);
}

/// One ParaView frame of the state (x, v, ce6, activation flags). `more` adds per-tet fields; a
/// diagnostic frame shows a stress that is not finite (an inverted tet) as zero instead of
/// refusing the frame.
void write_frame(FieldWriter& w, const Solver& s, real time, long step, const std::vector<Vec3>& x,
                 const std::vector<Vec3>& v, const std::vector<Ce6Damage>& ce6, const std::vector<std::uint8_t>* flags,
                 const std::string& label, const std::vector<TetField>& more = {}, bool diagnostic = false) {
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
  fr.v = &v;  // (u with the nodes written: x - X)
  fr.tets = &s.model().tet_nodes;
  fr.stress = &stress;
  fr.von_mises = &vm;
  fr.crack_faces = &faces;
  fr.crack_damage = &damage;
  fr.crack_mode = &mode;
  std::vector<real> active;
  if (flags) {
    active.reserve(flags->size());
    for (std::uint8_t f : *flags) active.push_back((f & TetFlag::kCandidate) ? 1 : 0);
    fr.extra.push_back({"active", &active});
  }
  std::vector<real> material;  // with several materials: each tet's index in scene.materials
  if (s.laws().tet4.size() > 1) {
    material.assign(s.model().tet_material.begin(), s.model().tet_material.end());
    fr.extra.push_back({"material", &material});
  }
  std::vector<real> joint;  // with joints: 0, or 1 + the joint a face of the tet lies on
  if (!s.laws().joint_friction.empty()) {
    joint.assign(s.model().tet_joint.begin(), s.model().tet_joint.end());
    joint.resize(s.model().tet_nodes.size(), 0);
    fr.extra.push_back({"joint", &joint});
  }
  std::vector<real> group;                    // with volume groups: each tet's gmsh tag (0: none)
  int groups = !s.model().tet_group.empty();  // (a rank whose tets are in none holds no list)
  if (w.shared()) MPI_Allreduce(MPI_IN_PLACE, &groups, 1, MPI_INT, MPI_MAX, s.comm());
  if (groups) {
    group.assign(s.model().tet_group.begin(), s.model().tet_group.end());
    group.resize(s.model().tet_nodes.size(), 0);
    fr.extra.push_back({"group", &group});
  }
  // With heterogeneous E: each tet's factor on its material's E.
  const auto& mats = s.scene().materials;
  if (std::any_of(mats.begin(), mats.end(), [](const Material& m) { return m.heterogeneity.youngs_modulus; }))
    fr.extra.push_back({"youngs_modulus_factor", &s.model().tet_stiffness});
  // With an in-situ stress: each tet's, Pa, the six components apart.
  std::array<std::vector<real>, 6> in_situ;
  if (s.scene().initial_stress.given) {  // (every rank, also one that holds no tets)
    static const char* const kNames[6] = {"initial_stress_xx", "initial_stress_yy", "initial_stress_zz",
                                          "initial_stress_yz", "initial_stress_xz", "initial_stress_xy"};
    for (auto& c : in_situ) c.reserve(s.model().tet_initial_stress.size());
    for (const Sym3& t : s.model().tet_initial_stress) {
      const real c[6] = {t.xx, t.yy, t.zz, t.yz, t.xz, t.xy};
      for (int k = 0; k < 6; ++k) in_situ[k].push_back(c[k]);
    }
    for (int k = 0; k < 6; ++k) fr.extra.push_back({kNames[k], &in_situ[k]});
  }
  fr.extra.insert(fr.extra.end(), more.begin(), more.end());
  if (!s.distributed() && s.excavation_stages_done() == 0) {
    std::vector<Vec3> u(x.size());
    for (std::size_t n = 0; n < u.size(); ++n) u[n] = x[n] - s.model().X[n];
    fr.u = &u;
    w.write(fr);
  } else {
    write_own_tets(w, s, fr);
  }
}

}  // namespace

FrameState frame_state_now(const Solver& s, real stress) {
  s.sync_host();
  FrameState f;
  f.time = s.time();
  f.step = s.step_count();
  f.stress = stress;
  f.x = s.state.x;
  f.v = s.state.v;
  f.ce6 = s.state.ce6.damage;
  if (s.contacts.enabled()) f.active = s.contacts.tet_flags;
  return f;
}

void save_frame_state(CheckpointOut& o, const FrameState& f) {
  frame_state_fields([&](const auto& v) { o.put(v); }, f);
}
void load_frame_state(CheckpointIn& in, FrameState& f) {
  frame_state_fields([&](auto& v) { in.get(v); }, f);
}

void write_frame(FieldWriter& w, const Solver& s, const std::string& label) {
  s.sync_host();
  write_frame(w, s, s.time(), s.step_count(), s.state.x, s.state.v, s.state.ce6.damage,
              s.contacts.enabled() ? &s.contacts.tet_flags : nullptr, label);
}

void write_frame(FieldWriter& w, const Solver& s, const FrameState& f, const std::string& label) {
  if (f.x.size() < s.state.x.size() || f.ce6.size() < s.state.ce6.size() ||
      (!f.active.empty() && f.active.size() < s.model().tet_nodes.size())) {
    // The contact ghosts grew since the frame was kept: the ghosts appended since take their
    // present state (this rank writes its own tets only, and their nodes are the old ones).
    s.sync_host();
    FrameState g = f;
    g.x.insert(g.x.end(), s.state.x.begin() + f.x.size(), s.state.x.end());
    g.v.insert(g.v.end(), s.state.v.begin() + f.v.size(), s.state.v.end());
    g.ce6.insert(g.ce6.end(), s.state.ce6.damage.begin() + f.ce6.size(), s.state.ce6.damage.end());
    if (!g.active.empty())
      g.active.insert(g.active.end(), s.contacts.tet_flags.begin() + f.active.size(), s.contacts.tet_flags.end());
    write_frame(w, s, g, label);
    return;
  }
  write_frame(w, s, f.time, f.step, f.x, f.v, f.ce6, f.active.empty() ? nullptr : &f.active, label);
}

void write_diagnostic(FieldWriter& w, const Solver& s) {
  try {
    s.sync_host();
    const Model& m = s.model();
    std::vector<Vec3> x = s.state.x, v = s.state.v;
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
    write_frame(w, s, s.time(), s.step_count(), x, v, s.state.ce6.damage,
                s.contacts.enabled() ? &s.contacts.tet_flags : nullptr, "diagnostic",
                {{"non_finite", &non_finite}, {"inverted", &inverted}}, true);
  } catch (const std::exception&) {
    // Nothing more to show; the frames written before remain valid.
  }
}

void PeakFrames::observe(const Solver& s, real stress) {
  if (stress <= max_) return;
  max_ = stress;
  peak_ = frame_state_now(s, stress);
  if (ladder_.empty() || stress >= real(1.05) * ladder_.back().stress) ladder_.push_back(peak_);
  while (ladder_.size() > 1 && ladder_.front().stress < real(0.7) * max_) ladder_.pop_front();
}

void PeakFrames::write(FieldWriter& w, const Solver& s) {
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

void PeakFrames::save(CheckpointOut& o) const {
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

namespace {

// Marks of what no saved rank has set yet (finish_saved gives it the state now).
constexpr std::uint8_t kUnsetFlags = 0xFF;  // (no TetFlag combination sets bits 5 and 6)
bool unset(const Vec3& x) {
  return std::isnan(x.x);
}

/// A kept state's clock and stress, its arrays sized for solver s and marked unset.
FrameState unset_like(const FrameState& saved, const Solver& s) {
  FrameState f;
  f.time = saved.time, f.stress = saved.stress, f.step = saved.step;
  if (saved.x.empty()) return f;  // (no state kept)
  const Vec3 nan{NAN, NAN, NAN};
  f.x.assign(s.state.x.size(), nan), f.v.assign(s.state.x.size(), nan);
  Ce6Damage c{};
  c.D[0] = NAN;
  f.ce6.assign(s.state.ce6.size(), c);
  if (!saved.active.empty()) f.active.assign(s.contacts.tet_flags.size(), kUnsetFlags);
  return f;
}

void take_saved_state(const FrameState& saved, const EntityMap& map, FrameState& f) {
  if (f.x.empty()) return;
  scatter_saved(saved.x, map.node, f.x);
  scatter_saved(saved.v, map.node, f.v);
  scatter_saved(saved.ce6, map.ce6, f.ce6);
  if (!f.active.empty()) scatter_saved(saved.active, map.tet, f.active);
}

void finish_saved_state(FrameState& f, const Solver& s) {
  for (std::size_t n = 0; n < f.x.size(); ++n)
    if (unset(f.x[n])) f.x[n] = s.state.x[n], f.v[n] = s.state.v[n];
  for (std::size_t c = 0; c < f.ce6.size(); ++c)
    if (std::isnan(f.ce6[c].D[0])) f.ce6[c] = s.state.ce6.damage[c];
  for (std::size_t t = 0; t < f.active.size(); ++t)
    if (f.active[t] == kUnsetFlags) f.active[t] = s.contacts.tet_flags[t];
}

}  // namespace

void PeakFrames::take_saved(const PeakFrames& saved, const EntityMap& map, const Solver& s, bool first) {
  if (first) {
    max_ = saved.max_;
    written_ = saved.written_;
    peak_ = unset_like(saved.peak_, s);
    ladder_.clear();
    for (const FrameState& f : saved.ladder_) ladder_.push_back(unset_like(f, s));
  }
  if (saved.ladder_.size() != ladder_.size())
    throw InputError("the checkpoint's rank files keep different peak states (" + std::to_string(saved.ladder_.size()) +
                     " and " + std::to_string(ladder_.size()) +
                     "). Fix: restart from a whole set of rank files of one step");
  take_saved_state(saved.peak_, map, peak_);
  for (std::size_t i = 0; i < ladder_.size(); ++i) take_saved_state(saved.ladder_[i], map, ladder_[i]);
}

void PeakFrames::finish_saved(const Solver& s) {
  finish_saved_state(peak_, s);
  for (FrameState& f : ladder_) finish_saved_state(f, s);
}

void PeakFrames::load(CheckpointIn& in) {
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

}  // namespace fdem
