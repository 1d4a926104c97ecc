#pragma once
// A serial reference time loop for the tests: one rank, plain loops, no executor, no device
// arrays. It calls the same element laws (src/physics) as the solver, and adds every node's
// forces in the order the solver documents (docs/architecture.md): gravity, then the TET4s and
// the CE6s in colour order, then contact's per-node sum, the platens, and the pressure's faces
// in face order. So it must give the solver's state bit for bit, whatever backend, schedule or
// iteration order the solver runs. It is the oracle that replaces a second time loop in src/.
//
// Its interface mirrors the Solver's: the constructor evaluates the forces of the start
// state; v may be set before the first step; prescribe() and step() as the Solver's.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "contact/broad_phase.hpp"
#include "model/laws.hpp"
#include "model/model.hpp"
#include "physics/cohesive6.hpp"
#include "physics/contact.hpp"
#include "physics/integrate.hpp"
#include "physics/platen.hpp"
#include "physics/tet4.hpp"
#include "scene/scene.hpp"
#include "solver/contact_set.hpp"

namespace fdem::test {

class ReferenceStepper {
 public:
  /// The scene and model of a solver, and its time step dt (s).
  ReferenceStepper(const Scene& scene, const Model& model, real dt) : s_(scene), m_(model), dt_(dt) {
    const Material& mat = s_.material();
    lambda_ = mat.lame_lambda();
    mu_ = mat.lame_mu();
    ce6p_ = make_ce6_params(mat);
    ce6p_.broken_inert = s_.contact.enabled() ? 1 : 0;
    const std::size_t nn = m_.X.size();
    x = m_.X;
    v.assign(nn, Vec3{0, 0, 0});
    f.assign(nn, Vec3{0, 0, 0});
    ce6.assign(m_.ce6_nodes.size(), Ce6State{});
    broke_.assign(m_.ce6_nodes.size(), 0);
    for (int n : m_.platen_nodes) platen_anchor.push_back(Vec3{m_.X[n].x, m_.X[n].y, 0});
    const real c = std::sqrt((lambda_ + 2 * mu_) / (s_.solver.mass_scaling * mat.density));
    platen_ramp_ = s_.platens.ramp_time > 0 ? s_.platens.ramp_time : 10 * m_.height0 / c;
    pressure_ramp_ = s_.confinement.ramp_time > 0 ? s_.confinement.ramp_time : 10 * m_.height0 / c;
    set_up_lateral_faces();
    set_up_contact();
    forces();
  }

  /// Velocity components (mask bit d: axis d) of `node` held at `velocity` from now on.
  void prescribe(int node, int mask, Vec3 velocity) {
    auto it = std::find_if(fixed_.begin(), fixed_.end(), [node](const Fixed& p) { return p.node == node; });
    if (it == fixed_.end()) it = fixed_.insert(fixed_.end(), Fixed{node, 0, Vec3{0, 0, 0}});
    it->mask |= mask;  // one entry per node: a later call sets its components anew
    for (int d = 0; d < 3; ++d)
      if (mask >> d & 1) it->velocity[d] = velocity[d], v[node][d] = velocity[d];
  }

  /// Central difference with the forces at t, the clock and the platen's travel, then the
  /// forces at t + dt.
  void step() {
    const real speed = s_.platens.enabled ? ramped_speed(time + 0.5 * dt_, s_.platens.velocity, platen_ramp_) : 0;
    for (std::size_t n = 0; n < x.size(); ++n) central_difference(x[n], v[n], f[n], 1 / m_.mass[n], dt_);
    for (const Fixed& p : fixed_) prescribe_velocity(x[p.node], v[p.node], p.mask, p.velocity, dt_);
    top_offset = top_offset + speed * dt_;
    time = time + dt_;
    ++steps;
    forces();
  }

  // The state, as the Solver's host copy names it.
  std::vector<Vec3> x, v, f;
  std::vector<Ce6State> ce6;
  std::vector<Vec3> platen_anchor;
  real top_offset = 0, time = 0;
  long steps = 0;
  // Contact: the tets' flags (bit 0 a candidate, bit 1 + i the CE6 on face i opened), the
  // candidate pairs (a < b), their histories (friction spring, overlap zero), and how often the
  // list was built.
  std::vector<std::uint8_t> active;
  std::vector<ContactPair> pairs;
  std::vector<PairHistory> history;
  long rebuilds = 0;
  // Platen reactions on the rock along +z (N) and touching contact pairs, of the last evaluation.
  real force_top = 0, force_bottom = 0;
  long touching = 0;

 private:
  struct Fixed {
    int node, mask;
    Vec3 velocity;
  };

  /// Every node's force at the state now, in the documented order of additions.
  void forces() {
    for (std::size_t n = 0; n < x.size(); ++n) f[n] = s_.has_gravity() ? m_.mass[n] * s_.gravity : Vec3{0, 0, 0};
    for (int t : m_.tet_colours.order) {
      Vec3 xe[4], ve[4], fe[4];
      for (int i = 0; i < 4; ++i) xe[i] = x[m_.tet_nodes[t][i]], ve[i] = v[m_.tet_nodes[t][i]];
      tet4_forces(xe, ve, m_.tet_Xinv[t], m_.tet_V0[t], lambda_, mu_, m_.tet_eta[t], fe);
      for (int i = 0; i < 4; ++i) f[m_.tet_nodes[t][i]] += fe[i];
    }
    for (int c : m_.ce6_colours.order) {
      if (!ce6_carries_force(ce6p_, ce6[c])) continue;
      Vec3 xe[6], ve[6], fe[6];
      for (int j = 0; j < 6; ++j) xe[j] = x[m_.ce6_nodes[c][j]], ve[j] = v[m_.ce6_nodes[c][j]];
      const bool was_broken = ce6_broken(ce6[c]);
      cohesive6_forces(ce6p_, xe, ve, m_.ce6_h[c], ce6[c], fe);  // (one homogeneous material only)
      for (int j = 0; j < 6; ++j) f[m_.ce6_nodes[c][j]] += fe[j];
      if (!was_broken && ce6_broken(ce6[c])) broke_[c] = 1;
    }
    if (s_.contact.enabled()) contact_forces();
    activate_around_breaks();
    if (s_.platens.enabled) platen_forces();
    if (s_.confinement.enabled) pressure_forces();
  }

  void platen_forces() {
    const real ztop = m_.box_max.z - top_offset, zbot = m_.box_min.z;
    force_top = force_bottom = 0;
    for (std::size_t i = 0; i < m_.platen_nodes.size(); ++i) {
      const int n = m_.platen_nodes[i];
      const bool near_top = x[n].z > 0.5 * (ztop + zbot);  // a node meets the nearer platen only
      const real k = s_.material().contact_penalty * m_.platen_node_area[i] / m_.platen_node_h[i];
      const PlatenEval e =
          platen_node_force(x[n] - Vec3{0, 0, near_top ? ztop : zbot}, Vec3{0, 0, near_top ? -1.0 : 1.0}, k,
                            s_.material().friction_platen, platen_anchor[i]);
      f[n] += e.force;
      (near_top ? force_top : force_bottom) += e.force.z;
    }
  }

  /// The lateral surface: surface faces not lying wholly on the top or the bottom end.
  void set_up_lateral_faces() {
    if (!s_.confinement.enabled) return;
    std::vector<char> top(x.size(), 0), bottom(x.size(), 0);
    for (int n : m_.top_nodes) top[n] = 1;
    for (int n : m_.bottom_nodes) bottom[n] = 1;
    for (const auto& q : m_.surface_faces)
      if (!(top[q[0]] && top[q[1]] && top[q[2]]) && !(bottom[q[0]] && bottom[q[1]] && bottom[q[2]]))
        lateral_faces_.push_back(q);
  }

  /// The confining pressure, a follower load: -p a / 3 on each node of a lateral face (a: its
  /// current area vector). The hydrostatic path follows the platen reactions up to sigma_3.
  void pressure_forces() {
    const Confinement& cf = s_.confinement;
    real p = ramped_speed(time, cf.pressure, pressure_ramp_);
    if (cf.path == ConfinementPath::hydrostatic) {
      const real axial = m_.area0 > 0 ? 0.5 * (-force_top + force_bottom) / m_.area0 : 0;
      p = std::min(cf.pressure, std::max(real(0), axial));
    }
    for (const auto& q : lateral_faces_) {
      const Vec3 face_force = (-p / 3) * (0.5 * cross(x[q[1]] - x[q[0]], x[q[2]] - x[q[0]]));
      for (int n : q) f[n] += face_force;
    }
  }

  void set_up_contact() {
    if (!s_.contact.enabled()) return;
    buffer_ = s_.contact.buffer > 0 ? s_.contact.buffer : 0.1 * m_.mean_edge;
    const int nt = int(m_.tet_nodes.size());
    active.assign(nt, s_.contact.activation == Activation::full ? 1 : 0);
    std::vector<char> loaded(x.size(), 0);
    for (int n : m_.top_nodes) loaded[n] = 1;
    for (int n : m_.bottom_nodes) loaded[n] = 1;
    if (s_.contact.activation != Activation::full && s_.platens.enabled)  // adaptive: the loaded ends from the start
      for (int t = 0; t < nt; ++t)
        for (int n : m_.tet_nodes[t])
          if (loaded[n]) active[t] = 1;
    tet_ce6_.assign(nt, {});
    for (int c = 0; c < int(m_.ce6_tets.size()); ++c)
      for (int t : m_.ce6_tets[c]) tet_ce6_[t].push_back(c);
    VertexTets vt(m_);
    vertex_ptr_ = vt.ptr;
    vertex_tets_ = vt.tets;
    vertex_ce6_.assign(vertex_ptr_.size() - 1, {});
    for (int c = 0; c < int(m_.ce6_nodes.size()); ++c)
      for (int j = 0; j < 3; ++j) vertex_ce6_[m_.node_vertex[m_.ce6_nodes[c][j]]].push_back(c);
    opened_.assign(m_.ce6_nodes.size(), 0);
    std::vector<int> seen(x.size(), 0);  // CE6s weld only where no two tets share a node
    for (const auto& q : m_.tet_nodes)
      for (int n : q) welds_ = welds_ && ++seen[n] == 1;
  }

  /// The tets sharing a vertex with the face of each CE6 broken in this evaluation become
  /// candidates, and the CE6 welds no more (its tets' faces flagged), for the next evaluation's
  /// contact.
  void activate_around_breaks() {
    for (std::size_t c = 0; c < broke_.size(); ++c) {
      if (!broke_[c]) continue;
      broke_[c] = 0;
      if (!s_.contact.enabled()) continue;
      for (int j = 0; j < 3; ++j) {
        const int vtx = m_.node_vertex[m_.ce6_nodes[c][j]];
        for (int k = vertex_ptr_[vtx]; k < vertex_ptr_[vtx + 1]; ++k)
          if (!(active[vertex_tets_[k]] & 1)) active[vertex_tets_[k]] |= 1, dirty_ = true;
      }
      opened_[c] = 1;
      dirty_ = true;
      for (int t : m_.ce6_tets[c])
        for (int i = 0; i < 4; ++i) {  // the face opposite the corner off the CE6
          bool on = false;
          for (int j = 0; j < 3; ++j)
            on = on || m_.node_vertex[m_.ce6_nodes[c][j]] == m_.node_vertex[m_.tet_nodes[t][i]];
          if (!on) active[t] |= std::uint8_t(2 << i);
        }
    }
  }

  /// Nodes na and nb at mesh vertex u are joined by intact CE6s, through the node pairs they
  /// hold at u (a search over nodes; stars of more than 64 tets weld nothing).
  bool welded(int u, int na, int nb) const {
    if (na == nb) return true;
    if (!welds_ || vertex_ptr_[u + 1] - vertex_ptr_[u] > 64) return false;
    std::vector<int> reached{na};
    for (std::size_t k = 0; k < reached.size(); ++k)
      for (int c : vertex_ce6_[u]) {
        if (opened_[c]) continue;
        for (int j = 0; j < 3; ++j) {
          if (m_.node_vertex[m_.ce6_nodes[c][j]] != u) continue;
          const int p = m_.ce6_nodes[c][j], q = m_.ce6_nodes[c][j + 3];
          const int next = p == reached[k] ? q : q == reached[k] ? p : -1;
          if (next >= 0 && std::find(reached.begin(), reached.end(), next) == reached.end()) reached.push_back(next);
        }
      }
    return std::find(reached.begin(), reached.end(), nb) != reached.end();
  }

  /// Tets a and b share a mesh vertex and are welded at every one they share; without welds,
  /// they share a node.
  bool bonded(int a, int b) const {
    if (!welds_) {
      for (int na : m_.tet_nodes[a])
        for (int nb : m_.tet_nodes[b])
          if (na == nb) return true;
      return false;
    }
    bool shares = false;
    for (int na : m_.tet_nodes[a])
      for (int nb : m_.tet_nodes[b])
        if (m_.node_vertex[na] == m_.node_vertex[nb]) {
          shares = true;
          if (!welded(m_.node_vertex[na], na, nb)) return false;
        }
    return shares;
  }

  /// True when a node of the tets listed at the last build has moved half the buffer since.
  bool moved_half_the_buffer() const {
    for (std::size_t i = 0; i < watch_.size(); ++i) {
      const Vec3 d = x[watch_[i]] - watch_x_[i];
      if (dot(d, d) > 0.25 * buffer_ * buffer_) return true;
    }
    return false;
  }

  /// Pairs of active tets whose boxes (grown by half the buffer) overlap, without bonded
  /// neighbours unless a CE6 joins them; histories kept for the pairs that stay.
  void build_pairs() {
    std::vector<int> ids;
    std::vector<Aabb> boxes(m_.tet_nodes.size());
    for (std::size_t t = 0; t < active.size(); ++t) {
      if (!(active[t] & 1)) continue;
      ids.push_back(int(t));
      Aabb b{x[m_.tet_nodes[t][0]], x[m_.tet_nodes[t][0]]};
      for (int n : m_.tet_nodes[t])
        for (int d = 0; d < 3; ++d) b.lo[d] = std::min(b.lo[d], x[n][d]), b.hi[d] = std::max(b.hi[d], x[n][d]);
      for (int d = 0; d < 3; ++d) b.lo[d] -= 0.5 * buffer_, b.hi[d] += 0.5 * buffer_;
      boxes[t] = b;
    }
    std::vector<std::array<int, 2>> found;
    find_box_pairs(boxes, ids, 0, found);
    std::vector<ContactPair> next;
    for (const auto& p : found) {
      int joint = -1;
      for (int c : tet_ce6_[p[0]])
        if (m_.ce6_tets[c][0] == p[1] || m_.ce6_tets[c][1] == p[1]) joint = c;
      if (joint < 0 && bonded(p[0], p[1])) continue;  // welded by intact CE6s or shared nodes
      next.push_back({p[0], p[1], joint});
    }
    std::vector<PairHistory> next_history(next.size(), new_pair_history());
    auto less = [](const ContactPair& p, const ContactPair& q) { return p.a != q.a ? p.a < q.a : p.b < q.b; };
    for (std::size_t i = 0; i < next.size(); ++i) {  // (both lists sorted by (a, b))
      const auto it = std::lower_bound(pairs.begin(), pairs.end(), next[i], less);
      if (it != pairs.end() && it->a == next[i].a && it->b == next[i].b) next_history[i] = history[it - pairs.begin()];
    }
    pairs = next;
    history = next_history;
    watch_.clear();
    watch_x_.clear();
    std::vector<char> seen(x.size(), 0);
    for (int t : ids)
      for (int n : m_.tet_nodes[t])
        if (!seen[n]) seen[n] = 1, watch_.push_back(n), watch_x_.push_back(x[n]);
    dirty_ = false;
    ++rebuilds;
  }

  /// Narrow phase and friction of every pair; each node then gets the sum of its pair forces,
  /// pair by pair, a's nodes before b's.
  void contact_forces() {
    if (dirty_ || moved_half_the_buffer()) build_pairs();
    std::vector<Vec3> sum(x.size(), Vec3{0, 0, 0});
    std::vector<char> listed(x.size(), 0);
    touching = 0;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      const ContactPair& p = pairs[k];
      Vec3 xa[4], xb[4], va[4], vb[4], fa[4], fb[4];
      for (int i = 0; i < 4; ++i) {
        xa[i] = x[m_.tet_nodes[p.a][i]], xb[i] = x[m_.tet_nodes[p.b][i]];
        va[i] = v[m_.tet_nodes[p.a][i]], vb[i] = v[m_.tet_nodes[p.b][i]];
        fa[i] = fb[i] = Vec3{0, 0, 0};
      }
      // A pair joined by a CE6 touches once the CE6 broke in an earlier evaluation.
      const bool held = p.joint >= 0 && (!ce6_broken(ce6[p.joint]) || broke_[p.joint]);
      PairHistory& h = history[k];
      const ContactEval e =
          held ? ContactEval{}
               : contact_tet_pair(s_.contact.law, xa, xb, s_.material().contact_penalty, fa, fb, h.overlap_zero);
      if (held) {
        h = new_pair_history();  // its first evaluation after the break sets its zero
      } else if (h.overlap_zero = next_overlap_zero(h.overlap_zero, e); !(e.weight > 0)) {
        h.spring = Vec3{0, 0, 0};
      } else {
        ++touching;
        Vec3 ga[4], gb[4];
        for (int i = 0; i < 4; ++i) ga[i] = gb[i] = Vec3{0, 0, 0};
        const real k_t = contact_tangential_stiffness(xa, xb, s_.material().contact_penalty);
        contact_friction(xa, xb, va, vb, e, s_.material().friction_rock, k_t, dt_, h.spring, ga, gb);
        for (int i = 0; i < 4; ++i) fa[i] += ga[i], fb[i] += gb[i];
      }
      for (int i = 0; i < 4; ++i) {
        sum[m_.tet_nodes[p.a][i]] += fa[i], listed[m_.tet_nodes[p.a][i]] = 1;
        sum[m_.tet_nodes[p.b][i]] += fb[i], listed[m_.tet_nodes[p.b][i]] = 1;
      }
    }
    for (std::size_t n = 0; n < x.size(); ++n)
      if (listed[n]) f[n] += sum[n];
  }

  Scene s_;
  Model m_;
  real dt_;
  real lambda_ = 0, mu_ = 0, platen_ramp_ = 0, pressure_ramp_ = 0, buffer_ = 0;
  Ce6Params ce6p_{};
  std::vector<Fixed> fixed_;
  std::vector<std::array<int, 3>> lateral_faces_;
  std::vector<std::uint8_t> broke_;  // CE6s broken in this evaluation (their faces still held)
  bool dirty_ = true;                // the candidate list is to be built
  std::vector<int> vertex_ptr_, vertex_tets_, watch_;
  std::vector<std::vector<int>> tet_ce6_;     // the CE6s on each tet's faces
  std::vector<std::vector<int>> vertex_ce6_;  // the CE6s with a vertex of their face at each mesh vertex
  std::vector<char> opened_;                  // per CE6: broken, and its faces flagged
  bool welds_ = true;                         // every node belongs to one tet: CE6s weld
  std::vector<Vec3> watch_x_;
};

}  // namespace fdem::test
