#pragma once
// DeviceLoopImpl<Exec>: the device loop (device_loop.hpp) for one Exec. Included by
// device_loop.cpp (HostExec, the debug backend) and by cuda/device_loop.cu (CudaExec), so the
// passes are one source. Lambdas capture raw pointers by value; members are copied to locals
// first (a device lambda cannot read `this`).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <limits>

#include "core/forall.hpp"
#include "physics/cohesive6.hpp"
#include "physics/contact.hpp"
#include "physics/integrate.hpp"
#include "physics/platen.hpp"
#include "physics/tet4.hpp"
#include "solver/device_loop.hpp"
#include "solver/solver.hpp"

namespace fdem {

/// A finite number (NaN and inf fail), on host and device alike.
FDEM_HD bool finite_value(real a) {
  return a - a == 0;
}

template <class Exec>
class DeviceLoopImpl final : public DeviceLoop {
 public:
  explicit DeviceLoopImpl(Backend b) : b_(b) {
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(tet_nodes_, tet_order_, ce6_nodes_, ce6_order_, platen_nodes_, fixed_node_, fixed_mask_, lat_faces_, lat_ptr_,
        lat_face_, lat_node_, node_vertex_, vt_ptr_, vt_tets_, watch_nodes_, gather_node_, gather_ptr_, gather_slot_);
    set(Xinv_, V0_, eta_, ce6_h_, mass_, inv_mass_, platen_k_, sums_);
    set(x_, v_, f_, anchor_, fixed_v_, lat_force_, watch_x_, spring_, pair_force_);
    set(ce6_, broke_, active_, pairs_, eval_);
  }

  Backend backend() const override { return b_; }
  void set_timing(bool on) override { timing_ = on; }
  const DeviceTimes& times() const override { return t_; }

  void upload(const Solver& s) override {
    const auto t0 = now();
    const Model& m = s.model_;
    if (!constants_) {
      tet_nodes_.upload(reinterpret_cast<const int*>(m.tet_nodes.data()), 4 * m.tet_nodes.size());
      tet_order_.upload(m.tet_colours.order);
      ce6_nodes_.upload(reinterpret_cast<const int*>(m.ce6_nodes.data()), 6 * m.ce6_nodes.size());
      ce6_order_.upload(m.ce6_colours.order);
      Xinv_.upload(m.tet_Xinv);
      V0_.upload(m.tet_V0);
      eta_.upload(m.tet_eta);
      ce6_h_.upload(m.ce6_h);
      mass_.upload(m.mass);
      inv_mass_.upload(s.inv_mass_);
      platen_nodes_.upload(m.platen_nodes);
      platen_k_.upload(s.platen_k_);
      node_vertex_.upload(m.node_vertex);
      if (s.contacts.enabled()) {
        vt_ptr_.upload(s.contacts.vertex_tet_ptr_);
        vt_tets_.upload(s.contacts.vertex_tets_);
      }
      // Confining pressure: the lateral faces and, per node, the faces it sums in face order
      // (the order of the CPU loop, so the sums agree bit for bit).
      const auto& faces = s.lateral_faces_;
      lat_faces_.upload(reinterpret_cast<const int*>(faces.data()), 3 * faces.size());
      std::vector<std::array<int, 2>> nf;
      for (int i = 0; i < int(faces.size()); ++i)
        for (int n : faces[i]) nf.push_back({n, i});
      std::stable_sort(nf.begin(), nf.end(), [](const auto& a, const auto& b) { return a[0] < b[0]; });
      std::vector<int> node, ptr{0}, face;
      for (std::size_t k = 0; k < nf.size(); ++k) {
        if (k > 0 && nf[k][0] != nf[k - 1][0]) ptr.push_back(int(k));
        if (k == 0 || nf[k][0] != nf[k - 1][0]) node.push_back(nf[k][0]);
        face.push_back(nf[k][1]);
      }
      if (!nf.empty()) ptr.push_back(int(nf.size()));
      lat_node_.upload(node);
      lat_ptr_.upload(ptr);
      lat_face_.upload(face);
      constants_ = true;
    }
    x_.upload(s.x);
    v_.upload(s.v);
    f_.upload(s.f);
    ce6_.upload(s.ce6);
    broke_.upload(s.ce6_broke_);
    anchor_.upload(s.platen_anchor);
    fixed_node_.upload(s.fixed_node_);
    fixed_mask_.upload(s.fixed_mask_);
    fixed_v_.upload(s.fixed_velocity_);
    lat_force_.upload(s.lateral_force_);
    if (s.contacts.enabled()) {
      const ContactSet& c = s.contacts;
      active_.upload(c.active_);
      upload_pairs(c);
      eval_.upload(c.eval_);
      pair_force_.upload(c.pair_force_);
    }
    t_.copies += seconds_since(t0);
  }

  void download(Solver& s) override {
    const auto t0 = now();
    x_.download(s.x);
    v_.download(s.v);
    f_.download(s.f);
    ce6_.download(s.ce6);
    broke_.download(s.ce6_broke_);
    anchor_.download(s.platen_anchor);
    lat_force_.download(s.lateral_force_);
    if (s.contacts.enabled()) {
      ContactSet& c = s.contacts;
      active_.download(c.active_);
      c.active_count_ = std::count(c.active_.begin(), c.active_.end(), 1);
      spring_.download(c.spring);
      eval_.download(c.eval_);
      pair_force_.download(c.pair_force_);
    }
    t_.copies += seconds_since(t0);
  }

  void poison_host(Solver& s) override {
    const real nan = std::numeric_limits<real>::quiet_NaN();
    const Vec3 bad{nan, nan, nan};
    for (auto* a : {&s.x, &s.v, &s.f, &s.platen_anchor, &s.lateral_force_}) std::fill(a->begin(), a->end(), bad);
    for (Ce6State& c : s.ce6) c.D[0] = c.D[1] = c.D[2] = nan, c.mode = -1;
    std::fill(s.ce6_broke_.begin(), s.ce6_broke_.end(), 0xAA);
    if (s.contacts.enabled()) {
      ContactSet& c = s.contacts;
      std::fill(c.active_.begin(), c.active_.end(), 0xAA);
      std::fill(c.spring.begin(), c.spring.end(), bad);
      std::fill(c.pair_force_.begin(), c.pair_force_.end(), bad);
      std::fill(c.eval_.begin(), c.eval_.end(), ContactEval{bad, bad, nan});
    }
  }

  real kinetic2() override {
    const Vec3* v = v_.data();
    const real* mass = mass_.data();
    return Exec::template sum<1>(int(v_.size()),
                                 [=] FDEM_LAMBDA(int n, real* acc) { acc[0] += mass[n] * dot(v[n], v[n]); })[0];
  }

  void compute_forces(Solver& s) override {
    const Model& m = s.model_;
    const Scene& scene = s.scene_;
    const int nn = int(x_.size());
    const Vec3* x = x_.data();
    const Vec3* v = v_.data();
    Vec3* f = f_.data();
    const real* mass = mass_.data();
    auto t0 = now();

    // Gravity (or zero) starts the sum.
    const Vec3 g = scene.gravity;
    if (g.x == 0 && g.y == 0 && g.z == 0) {
      Exec::forall(nn, [=] FDEM_LAMBDA(int n) { f[n] = Vec3{0, 0, 0}; });
      s.p_gravity_ = 0;
    } else {
      s.p_gravity_ = Exec::template sum<1>(nn, [=] FDEM_LAMBDA(int n, real* acc) {
        f[n] = mass[n] * g;
        acc[0] += dot(f[n], v[n]);
      })[0];
    }

    // TET4, colour by colour (no two elements of a colour share a node).
    const int* tn = tet_nodes_.data();
    const int* torder = tet_order_.data();
    const Mat3* Xinv = Xinv_.data();
    const real* V0 = V0_.data();
    const real* eta = eta_.data();
    const real lambda = s.lambda_, mu = s.mu_;
    // Sums over all colours stay on the device and are read once: [viscous power, inverted].
    clear_sums();
    real* tet_sums = sums_.data();
    for (int c = 0; c < m.tet_colours.colours(); ++c) {
      const int b = m.tet_colours.offsets[c], e = m.tet_colours.offsets[c + 1];
      Exec::template sum_to<2>(
          e - b,
          [=] FDEM_LAMBDA(int k, real* acc) {
            const int t = torder[b + k];
            const int* q = tn + 4 * t;
            Vec3 xe[4], ve[4], fe[4];
            for (int i = 0; i < 4; ++i) xe[i] = x[q[i]], ve[i] = v[q[i]];
            const Tet4Eval ev = tet4_forces(xe, ve, Xinv[t], V0[t], lambda, mu, eta[t], fe);
            if (!(ev.J > 0)) acc[1] += 1;
            for (int i = 0; i < 4; ++i) f[q[i]] += fe[i];
            acc[0] += ev.viscous_power;
          },
          tet_sums);
    }
    t0 = lap(t0, t_.tet4);

    // CE6, colour by colour; a CE6 that breaks raises its flag.
    const int* cn = ce6_nodes_.data();
    const int* corder = ce6_order_.data();
    const real* h = ce6_h_.data();
    Ce6State* st = ce6_.data();
    std::uint8_t* broke = broke_.data();
    const Ce6Params p = s.ce6p_;
    // [cohesive power, friction power of broken CE6s, breaks], after the TET4 sums.
    real* ce6_sums = sums_.data() + 2;
    for (int c = 0; c < m.ce6_colours.colours(); ++c) {
      const int b = m.ce6_colours.offsets[c], e = m.ce6_colours.offsets[c + 1];
      Exec::template sum_to<3>(
          e - b,
          [=] FDEM_LAMBDA(int k, real* acc) {
            const int i = corder[b + k];
            const int* q = cn + 6 * i;
            Vec3 xe[6], ve[6], fe[6];
            for (int j = 0; j < 6; ++j) xe[j] = x[q[j]], ve[j] = v[q[j]];
            const bool was_broken = ce6_broken(st[i]);
            const Ce6Eval ev = cohesive6_forces(p, xe, ve, h[i], st[i], fe);
            for (int j = 0; j < 6; ++j) f[q[j]] += fe[j];
            acc[was_broken ? 1 : 0] += ev.power;
            if (!was_broken && ce6_broken(st[i])) broke[i] = 1, acc[2] += 1;
          },
          ce6_sums);
    }
    const std::array<real, 5> fs = read_sums<5>();
    const real p_visc = fs[0], inverted = fs[1], p_coh = fs[2], p_fric = fs[3], breaks = fs[4];
    t0 = lap(t0, t_.ce6);
    if (inverted > 0) {  // rare: the host finds and names the element
      download(s);
      s.report_inverted();
    }

    // Adaptive activation: the vicinity of each CE6 that broke on this step (every tet sharing a
    // vertex of its face). Flags only rise, so concurrent writes of 1 agree.
    if (breaks > 0) {
      const int nc = int(ce6_.size());
      if (s.contacts.enabled()) {
        const int* nv = node_vertex_.data();
        const int* vptr = vt_ptr_.data();
        const int* vtets = vt_tets_.data();
        std::uint8_t* active = active_.data();
        const real added = Exec::template sum<1>(nc, [=] FDEM_LAMBDA(int i, real* acc) {
          if (!broke[i]) return;
          broke[i] = 0;
          for (int a = 0; a < 3; ++a) {
            const int vtx = nv[cn[6 * i + a]];
            for (int k = vptr[vtx]; k < vptr[vtx + 1]; ++k)
              if (!active[vtets[k]]) active[vtets[k]] = 1, acc[0] += 1;
          }
        })[0];
        if (added > 0) s.contacts.dirty_ = true;
      } else {
        Exec::forall(nc, [=] FDEM_LAMBDA(int i) { broke[i] = 0; });
      }
    }
    t0 = lap(t0, t_.activation);

    // Tet-tet contact: pairs from the host's broad phase when flags changed or a node moved half
    // the buffer; narrow phase, friction and the deterministic per-node sum here.
    real c_power = 0, c_dissipated = 0, c_stored = 0, c_touching = 0;
    if (s.contacts.enabled()) {
      ContactSet& cs = s.contacts;
      bool rebuild = cs.dirty_;
      if (!rebuild && watch_nodes_.size() > 0) {
        const int* wn = watch_nodes_.data();
        const Vec3* wx = watch_x_.data();
        const real lim2 = 0.25 * cs.buffer_ * cs.buffer_;
        rebuild = Exec::template sum<1>(int(watch_nodes_.size()), [=] FDEM_LAMBDA(int i, real* acc) {
                    const Vec3 d = x[wn[i]] - wx[i];
                    if (dot(d, d) > lim2) acc[0] += 1;
                  })[0] > 0;
      }
      if (rebuild) {
        // The host's broad phase needs positions and flags; springs carry over by pair.
        x_.download(s.x);
        active_.download(cs.active_);
        cs.active_count_ = std::count(cs.active_.begin(), cs.active_.end(), 1);
        spring_.download(cs.spring);
        const long before = pairs_capacity_grown();
        cs.rebuild(m, s.x);
        upload_pairs(cs);
        eval_.resize(cs.pairs_.size());
        pair_force_.resize(8 * cs.pairs_.size());
        t_.pair_growth += pairs_capacity_grown() - before;
        ++t_.rebuilds;
      }
      t0 = lap(t0, t_.broad);

      const int np = int(pairs_.size());
      const ContactPair* pairs = pairs_.data();
      ContactEval* ev = eval_.data();
      Vec3* pf = pair_force_.data();
      Vec3* spring = spring_.data();
      const real P = cs.penalty_, mu_rock = cs.mu_, dt = s.dt_;
      c_touching = Exec::template sum<1>(np, [=] FDEM_LAMBDA(int k, real* acc) {
        const ContactPair cp = pairs[k];
        Vec3* fp = pf + 8 * k;
        if (cp.joint >= 0 && !ce6_broken(st[cp.joint])) {
          for (int i = 0; i < 8; ++i) fp[i] = Vec3{0, 0, 0};
          ev[k] = ContactEval{{0, 0, 0}, {0, 0, 0}, 0};
          return;
        }
        Vec3 xa[4], xb[4], fa[4], fb[4];
        for (int i = 0; i < 4; ++i) xa[i] = x[tn[4 * cp.a + i]], xb[i] = x[tn[4 * cp.b + i]];
        ev[k] = contact_tet_pair(xa, xb, P, fa, fb);
        if (ev[k].weight > 0) acc[0] += 1;
        for (int i = 0; i < 4; ++i) fp[i] = fa[i], fp[4 + i] = fb[i];
      })[0];
      t0 = lap(t0, t_.narrow);
      const auto fr = Exec::template sum<2>(np, [=] FDEM_LAMBDA(int k, real* acc) {
        if (!(ev[k].weight > 0)) {
          spring[k] = Vec3{0, 0, 0};
          return;
        }
        const ContactPair cp = pairs[k];
        Vec3 xa[4], xb[4], va[4], vb[4], fa[4], fb[4];
        for (int i = 0; i < 4; ++i) {
          const int na = tn[4 * cp.a + i], nb = tn[4 * cp.b + i];
          xa[i] = x[na], xb[i] = x[nb], va[i] = v[na], vb[i] = v[nb];
          fa[i] = fb[i] = Vec3{0, 0, 0};
        }
        const real k_t = contact_tangential_stiffness(xa, xb, P);
        acc[0] += contact_friction(xa, xb, va, vb, ev[k], mu_rock, k_t, dt, spring[k], fa, fb);
        acc[1] += 0.5 * k_t * dot(spring[k], spring[k]);
        Vec3* fp = pf + 8 * k;
        for (int i = 0; i < 4; ++i) fp[i] += fa[i], fp[4 + i] += fb[i];
      });
      c_dissipated = fr[0], c_stored = fr[1];
      t0 = lap(t0, t_.friction);
      const int* gn = gather_node_.data();
      const int* gp = gather_ptr_.data();
      const int* gs = gather_slot_.data();
      Exec::forall(int(gather_node_.size()), [=] FDEM_LAMBDA(int k) {
        Vec3 sum{0, 0, 0};
        for (int j = gp[k]; j < gp[k + 1]; ++j) sum += pf[gs[j]];
        f[gn[k]] += sum;
      });
      c_power = contact_power(v);
      t0 = lap(t0, t_.contact_sum);
      cs.times.broad = t_.broad;
      cs.times.narrow = t_.narrow + t_.contact_sum;
      cs.times.friction = t_.friction;
    }
    s.p_contact_ = c_power;
    s.w_contact_slip_ += c_dissipated;
    s.contact_spring_ = c_stored;
    s.touching_ = long(c_touching);

    // Platens: each node against the nearer one.
    real ftop = 0, fbot = 0, dfric = 0;
    if (scene.platens.enabled) {
      const int* pn = platen_nodes_.data();
      const real* pk = platen_k_.data();
      Vec3* anchor = anchor_.data();
      const real ztop = s.top_z0_ - s.top_offset, zbot = s.bottom_z0_, mu_p = scene.material.friction_platen;
      const auto r = Exec::template sum<3>(int(platen_nodes_.size()), [=] FDEM_LAMBDA(int i, real* acc) {
        const int n = pn[i];
        const bool near_top = x[n].z > 0.5 * (ztop + zbot);
        const Vec3 xr = x[n] - Vec3{0, 0, near_top ? ztop : zbot};
        const PlatenEval pe = platen_node_force(xr, Vec3{0, 0, near_top ? -1.0 : 1.0}, pk[i], mu_p, anchor[i]);
        f[n] += pe.force;
        acc[near_top ? 0 : 1] += pe.force.z;
        acc[2] += pe.dissipated;
      });
      ftop = r[0], fbot = r[1], dfric = r[2];
    }
    s.force_top_ = ftop;
    s.force_bottom_ = fbot;
    t0 = lap(t0, t_.platens);

    // Confining pressure, a follower load: -p a / 3 per node of each lateral face.
    if (scene.confinement.enabled) {
      const Confinement& cf = scene.confinement;
      const real pr = s.hydrostatic_ ? std::min(cf.pressure, std::max(real(0), s.axial_stress()))
                                     : ramped_speed(s.time_, cf.pressure, s.confine_ramp_);
      s.pressure_ = pr;
      const int* lf = lat_faces_.data();
      Vec3* lforce = lat_force_.data();
      Exec::forall(int(lat_force_.size()), [=] FDEM_LAMBDA(int i) {
        const Vec3 a = 0.5 * cross(x[lf[3 * i + 1]] - x[lf[3 * i]], x[lf[3 * i + 2]] - x[lf[3 * i]]);
        lforce[i] = (-pr / 3) * a;
      });
      const int* ln = lat_node_.data();
      const int* lp = lat_ptr_.data();
      const int* lfa = lat_face_.data();
      Exec::forall(int(lat_node_.size()), [=] FDEM_LAMBDA(int k) {
        for (int j = lp[k]; j < lp[k + 1]; ++j) f[ln[k]] += lforce[lfa[j]];
      });
      s.p_pressure_ = pressure_power(v);
    }
    t0 = lap(t0, t_.pressure);
    s.p_viscous_ = p_visc;
    s.p_cohesive_ = p_coh;
    s.p_friction_ = p_fric;
    s.w_platen_friction_ += dfric;
  }

  AdvanceSums advance(Solver& s, real dt) override {
    auto t0 = now();
    Vec3* x = x_.data();
    Vec3* v = v_.data();
    const Vec3* f = f_.data();
    const real* inv_mass = inv_mass_.data();
    const real* mass = mass_.data();
    AdvanceSums out;
    const auto r = Exec::template sum<2>(int(x_.size()), [=] FDEM_LAMBDA(int n, real* acc) {
      central_difference(x[n], v[n], f[n], inv_mass[n], dt);
      acc[0] += !finite_value(v[n].x + v[n].y + v[n].z);
      acc[1] += mass[n] * dot(v[n], v[n]);
    });
    out.bad = r[0], out.kinetic2 = r[1];
    const int* fn = fixed_node_.data();
    const int* fm = fixed_mask_.data();
    const Vec3* fv = fixed_v_.data();
    Exec::forall(int(fixed_node_.size()), [=] FDEM_LAMBDA(int i) {
      const int n = fn[i];
      for (int d = 0; d < 3; ++d)
        if (fm[i] >> d & 1) {
          x[n][d] += dt * (fv[i][d] - v[n][d]);
          v[n][d] = fv[i][d];
        }
    });
    t0 = lap(t0, t_.integrate);
    if (s.contacts.enabled()) out.contact_power = contact_power(v);
    if (s.scene_.confinement.enabled) out.pressure_power = pressure_power(v);
    const Vec3 g = s.scene_.gravity;
    if (g.x != 0 || g.y != 0 || g.z != 0)
      out.gravity_power = Exec::template sum<1>(
          int(x_.size()), [=] FDEM_LAMBDA(int n, real* acc) { acc[0] += mass[n] * dot(g, v[n]); })[0];
    lap(t0, t_.energy);
    ++t_.steps;
    return out;
  }

  double bytes_per_step() const override {
    const double nn = double(x_.size()), nt = double(V0_.size()), nc = double(ce6_.size()), np = double(pairs_.size());
    const double vec = sizeof(Vec3);
    // TET4: connectivity, X0^-1, V0, eta; x and v of its 4 nodes read, f read and written.
    const double tet = nt * (4 * sizeof(int) + sizeof(Mat3) + 2 * sizeof(real) + 4 * 4 * vec);
    // CE6: connectivity, h, state read and written; x, v of 6 nodes, f read and written.
    const double ce6 = nc * (6 * sizeof(int) + sizeof(real) + 2 * sizeof(Ce6State) + 6 * 4 * vec);
    // Contact pairs: pair, evaluation, spring, 8 forces written then read, 8 nodes' x and v.
    const double con =
        np * (sizeof(ContactPair) + 2 * sizeof(ContactEval) + 2 * vec + 16 * vec + 16 * vec + 8 * 4 * sizeof(int));
    // Zeroing f, integration (x, v, f, 1/m, m) and the kinetic-energy sum.
    const double node = nn * (vec + 5 * vec + 2 * sizeof(real));
    return tet + ce6 + con + node;
  }

 private:
  using Clock = std::chrono::steady_clock;
  static Clock::time_point now() { return Clock::now(); }
  static double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
  /// Adds the time since t0 to `into` (after waiting for the device when timing) and restarts.
  Clock::time_point lap(Clock::time_point t0, double& into) const {
    if (timing_) Exec::synchronize();
    const auto t1 = now();
    into += std::chrono::duration<double>(t1 - t0).count();
    return t1;
  }
  void clear_sums() {
    const real zero[kSums] = {};
    sums_.upload(zero, kSums);
  }
  template <int N>
  std::array<real, N> read_sums() const {
    real all[kSums];
    sums_.download(all);
    std::array<real, N> out;
    for (int k = 0; k < N; ++k) out[k] = all[k];
    return out;
  }
  long pairs_capacity_grown() const { return pairs_.times_grown() + pair_force_.times_grown(); }

  void upload_pairs(const ContactSet& c) {
    pairs_.upload(c.pairs_);
    spring_.upload(c.spring);
    gather_node_.upload(c.gather_node_);
    gather_ptr_.upload(c.gather_ptr_);
    gather_slot_.upload(c.gather_slot_);
    watch_nodes_.upload(c.watch_nodes_);
    watch_x_.upload(c.watch_x_);
  }

 public:  // (public: nvcc's device lambdas cannot live in private member functions)
  /// -sum f.v of the last contact pair forces with velocities v (ContactSet::power).
  real contact_power(const Vec3* v) {
    const int* tn = tet_nodes_.data();
    const ContactPair* pairs = pairs_.data();
    const Vec3* pf = pair_force_.data();
    return Exec::template sum<1>(int(pairs_.size()), [=] FDEM_LAMBDA(int k, real* acc) {
      const Vec3* fp = pf + 8 * k;
      for (int i = 0; i < 4; ++i)
        acc[0] -= dot(fp[i], v[tn[4 * pairs[k].a + i]]) + dot(fp[4 + i], v[tn[4 * pairs[k].b + i]]);
    })[0];
  }
  /// The power of the confining pressure's last forces with velocities v.
  real pressure_power(const Vec3* v) {
    const int* lf = lat_faces_.data();
    const Vec3* lforce = lat_force_.data();
    return Exec::template sum<1>(int(lat_force_.size()), [=] FDEM_LAMBDA(int i, real* acc) {
      for (int j = 0; j < 3; ++j) acc[0] += dot(lforce[i], v[lf[3 * i + j]]);
    })[0];
  }

 private:
  static constexpr int kSums = 8;
  Backend b_;
  bool constants_ = false, timing_ = false;
  DeviceTimes t_;
  DeviceArray<int> tet_nodes_, tet_order_, ce6_nodes_, ce6_order_, platen_nodes_, fixed_node_, fixed_mask_, lat_faces_,
      lat_ptr_, lat_face_, lat_node_, node_vertex_, vt_ptr_, vt_tets_, watch_nodes_, gather_node_, gather_ptr_,
      gather_slot_;
  DeviceArray<Mat3> Xinv_;
  DeviceArray<real> V0_, eta_, ce6_h_, mass_, inv_mass_, platen_k_, sums_;
  DeviceArray<Vec3> x_, v_, f_, anchor_, fixed_v_, lat_force_, watch_x_, spring_, pair_force_;
  DeviceArray<Ce6State> ce6_;
  DeviceArray<std::uint8_t> broke_, active_;
  DeviceArray<ContactPair> pairs_;
  DeviceArray<ContactEval> eval_;
};

}  // namespace fdem
