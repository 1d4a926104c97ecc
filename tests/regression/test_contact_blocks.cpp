// Tet-tet contact in whole runs: a block bouncing off a block (energy conserved), a block on
// an incline (Coulomb stick and slide with the analytic acceleration), and a bar cut by CE6s
// that is pulled apart and pushed back together (contact only once the CE6s have broken).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "model/structured.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

constexpr real kEdge = 0.01;  // m, block edge

/// Two kEdge cubes of c x c x c Kuhn cells: one on [0,e]^3, one above it shifted by `shift`.
/// The lower block's (c+1)^3 vertices come first.
Mesh two_blocks(Vec3 shift, int c) {
  Mesh a = structured_box_mesh({kEdge, kEdge, kEdge}, c, c, c);
  const Mesh b = structured_box_mesh({kEdge, kEdge, kEdge}, c, c, c);
  const int off = int(a.vertices.size());
  for (Vec3 p : b.vertices) a.vertices.push_back(p + Vec3{0, 0, kEdge} + shift);
  for (auto t : b.tets) a.tets.push_back({t[0] + off, t[1] + off, t[2] + off, t[3] + off});
  a.source = "two blocks";
  return a;
}

Scene block_scene() {
  Scene s = test::test_scene();
  s.platens.enabled = false;
  s.fracture.everywhere = false;  // no CE6: each block is one continuous body
  s.contact.activation = Activation::full;
  return s;
}

struct Body {
  real mass = 0;
  Vec3 momentum{0, 0, 0};
  Vec3 centre{0, 0, 0};
};

bool in_upper(const Model& m, std::size_t n, int cells) {
  return m.node_vertex[n] >= (cells + 1) * (cells + 1) * (cells + 1);
}

/// Mass, momentum and centre of the upper or the lower block.
Body body(const Solver& s, bool upper, int cells) {
  s.sync_host();
  Body b;
  const Model& m = s.model();
  for (std::size_t n = 0; n < m.X.size(); ++n) {
    if (in_upper(m, n, cells) != upper) continue;
    b.mass += m.mass[n];
    b.momentum += m.mass[n] * s.state.v[n];
    b.centre += m.mass[n] * s.state.x[n];
  }
  b.centre = (1 / b.mass) * b.centre;
  return b;
}

}  // namespace

TEST(ContactBlocks, BlockBouncesOffABlockConservingEnergy) {
  Scene scene = block_scene();
  scene.solver.damping_scale = 0;  // undamped: all the energy must come back
  scene.material().friction_rock = 0;
  const real gap = 2e-5, v0 = 1.0;  // m, m/s
  Solver s(scene, build_model(two_blocks({0, 0, gap}, 2), scene));
  const Model& m = s.model();
  for (std::size_t n = 0; n < m.X.size(); ++n) {
    if (in_upper(m, n, 2))
      s.state.v[n] = {0, 0, -v0};
    else
      s.prescribe(int(n), 7, {0, 0, 0});  // the lower block is the ground
  }
  const real e0 = s.measure().kinetic;
  bool touched = false;
  long apart_steps = 0;
  Monitors row;
  while (s.step_count() < 200000) {
    s.step();
    row = s.measure();
    touched = touched || row.contacts > 0;
    // Done once the blocks have been apart for a while after the impact.
    apart_steps = touched && row.contacts == 0 ? apart_steps + 1 : 0;
    if (apart_steps > 200) break;
  }
  ASSERT_TRUE(touched) << "the blocks never met";
  ASSERT_GT(apart_steps, 200) << "the blocks did not separate";
  // The upper block flies up again (part of the energy stays in its vibration).
  const Body top = body(s, true, 2);
  EXPECT_GT(top.momentum.z / top.mass, 0.5 * v0);
  // No damping: kinetic plus elastic (vibration) energy after the bounce equals the start,
  // and the net work of the contact force over the impact is (nearly) zero.
  const real e1 = row.kinetic + row.strain;
  EXPECT_NEAR(e1, e0, 0.02 * e0) << "kinetic " << row.kinetic << " J, strain " << row.strain << " J";
  EXPECT_LT(std::fabs(row.contact), 0.02 * e0);
  RecordProperty("energy_ratio", std::to_string(e1 / e0));
}

namespace {

/// The upper block resting on the fixed lower one under gravity tilted by `angle` from the
/// normal (an incline of that angle). Returns the upper block's mean velocity along x at
/// times t1 and t2 and its displacement along x by t2.
struct Slide {
  real v1, v2, t1, t2, dx;
};

Slide incline(real angle, real g, real mu) {
  Scene scene = block_scene();
  scene.material().friction_rock = mu;
  scene.gravity = {g * std::sin(angle), 0, -g * std::cos(angle)};
  // Blocks of one Kuhn cell each (6 tets): the upper one starts just touching the lower one.
  Solver s(scene, build_model(two_blocks({0, 0, 0}, 1), scene));
  const Model& m = s.model();
  for (std::size_t n = 0; n < m.X.size(); ++n)
    if (!in_upper(m, n, 1)) s.prescribe(int(n), 7, {0, 0, 0});
  const real x0 = body(s, true, 1).centre.x;
  Slide r{};
  r.t1 = 0.5e-3;
  r.t2 = 1.5e-3;
  while (s.time() < r.t1) s.step();
  Body b = body(s, true, 1);
  r.v1 = b.momentum.x / b.mass;
  r.t1 = s.time();
  while (s.time() < r.t2) s.step();
  b = body(s, true, 1);
  r.v2 = b.momentum.x / b.mass;
  r.t2 = s.time();
  r.dx = b.centre.x - x0;
  return r;
}

}  // namespace

TEST(ContactBlocks, BlockOnAnInclineSticksBelowMuAndSlidesAbove) {
  const real g = 1000, mu = 0.5;  // m/s^2 (strong, to slide far in few steps); Coulomb coefficient
  // tan(angle) = 0.3 < mu: the block sticks (only the elastic creep of the friction springs).
  const Slide stick = incline(std::atan(0.3), g, mu);
  const real free_fall = 0.5 * g * std::sin(std::atan(0.3)) * stick.t2 * stick.t2;
  EXPECT_LT(std::fabs(stick.dx), 1e-3 * free_fall) << "dx " << stick.dx << " m";
  EXPECT_LT(std::fabs(stick.v2), 1e-3 * g * stick.t2);
  // tan(angle) = 0.8 > mu: sliding with a = g (sin - mu cos).
  const real angle = std::atan(0.8);
  const Slide slide = incline(angle, g, mu);
  const real a = (slide.v2 - slide.v1) / (slide.t2 - slide.t1);
  const real expect = g * (std::sin(angle) - mu * std::cos(angle));
  EXPECT_NEAR(a, expect, 0.02 * expect) << "measured " << a << " m/s^2";
  RecordProperty("acceleration_ratio", std::to_string(a / expect));
}

TEST(ContactBlocks, FrictionHistorySurvivesACandidateListRebuild) {
  // A block held on an incline by friction (tan 0.3 < mu 0.5): its friction springs carry
  // the tangential load. Rebuilding the candidate list must keep every pair's spring.
  Scene scene = block_scene();
  const real g = 1000, angle = std::atan(0.3);
  scene.gravity = {g * std::sin(angle), 0, -g * std::cos(angle)};
  Solver s(scene, build_model(two_blocks({0, 0, 0}, 1), scene));
  const Model& m = s.model();
  for (std::size_t n = 0; n < m.X.size(); ++n)
    if (!in_upper(m, n, 1)) s.prescribe(int(n), 7, {0, 0, 0});
  while (s.time() < 2e-4) s.step();
  s.sync_host();
  const std::vector<ContactPair> pairs = s.contacts.pairs;
  const std::vector<PairHistory> history = s.contacts.history;
  real total = 0;
  for (const PairHistory& h : history) total += norm(h.spring);
  ASSERT_GT(total, 0) << "no friction spring is loaded";
  const long builds = s.contacts.times.rebuilds;
  s.contacts.request_rebuild();
  s.step();
  s.sync_host();
  ASSERT_EQ(s.contacts.times.rebuilds, builds + 1);
  ASSERT_EQ(s.contacts.pairs.size(), pairs.size());
  // One step later each spring has moved by at most |v| dt: nothing was reset. Every pair
  // keeps its overlap zero, which only ever falls (a new pair's would be set anew).
  real change = 0, after = 0;
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    ASSERT_EQ(s.contacts.pairs[p].a, pairs[p].a);
    ASSERT_EQ(s.contacts.pairs[p].b, pairs[p].b);
    change += norm(s.contacts.history[p].spring - history[p].spring);
    after += norm(s.contacts.history[p].spring);
    ASSERT_GE(history[p].overlap_zero, 0) << "pair " << p << " was evaluated";
    EXPECT_LE(s.contacts.history[p].overlap_zero, history[p].overlap_zero) << "pair " << p;
  }
  EXPECT_LT(change, 1e-3 * total);
  EXPECT_NEAR(after, total, 1e-3 * total);
}

TEST(ContactBlocks, CohesiveFacesOnARegionBorderAreCandidatesToo) {
  // With a fracture region covering part of a block, the CE6s at the region's border have
  // one or two single-node pairs (their tets share a node) and can still break. Their two
  // tets must still be a candidate pair, joined by that CE6, or broken faces there would
  // pass through each other.
  Scene scene = block_scene();
  scene.fracture.boxes.push_back({{-1, -1, -1}, {0.5 * kEdge + 1e-9, 1, 1}});
  Solver s(scene, build_model(structured_box_mesh({kEdge, kEdge, kEdge}, 4, 4, 4), scene));
  const Model& m = s.model();
  int border = 0;
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    const auto& q = m.ce6_nodes[c];
    const int shared = (q[0] == q[3]) + (q[1] == q[4]) + (q[2] == q[5]);
    if (shared == 0 || shared == 3) continue;
    ++border;
    const int a = std::min(m.ce6_tets[c][0], m.ce6_tets[c][1]), b = std::max(m.ce6_tets[c][0], m.ce6_tets[c][1]);
    bool found = false;
    for (const ContactPair& p : s.contacts.pairs) found = found || (p.a == a && p.b == b && p.joint == int(c));
    EXPECT_TRUE(found) << "CE6 #" << c << " with " << shared << " shared node pair(s) has no contact pair";
  }
  EXPECT_GT(border, 0) << "the region border should hold CE6s with single-node pairs";
}

namespace {

/// A 2x2x2-cell bar of height 2h (h = 0.01 m) with CE6s only on its mid-plane z = h (the region
/// holds just the tets with a face on that plane), platens off. `mid`: the CE6s on the plane
/// (8: 2 triangles per cell); the region's inner faces get CE6s whose node pairs are single
/// nodes (joined to the continuous halves), which never open.
std::unique_ptr<Solver> mid_plane_bar(const std::string& activation, std::vector<int>& mid) {
  const real h = 0.01;
  Scene scene = test::test_scene();
  scene.platens.enabled = false;
  scene.contact.activation = test::named<Activation>(activation);
  scene.fracture.everywhere = false;
  scene.fracture.boxes.push_back({{-1, -1, h - 0.3 * h / 2}, {1, 1, h + 0.3 * h / 2}});
  auto s = std::make_unique<Solver>(scene, build_model(structured_box_mesh({h, h, 2 * h}, 2, 2, 4), scene));
  const Model& m = s->model();
  mid.clear();
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    bool on_plane = true;
    for (int i = 0; i < 3; ++i) on_plane = on_plane && std::fabs(m.X[m.ce6_nodes[c][i]].z - h) < 1e-9;
    if (on_plane) mid.push_back(int(c));
  }
  return s;
}

void bar_halves(const std::string& activation) {
  // The mid-plane bar pulled apart until the mid-plane breaks, then pushed back together.
  const real h = 0.01;
  std::vector<int> mid_ce6;
  const auto bar = mid_plane_bar(activation, mid_ce6);
  Solver& s = *bar;
  const Model& m = s.model();
  ASSERT_EQ(mid_ce6.size(), 8u) << "expected 8 CE6s on the mid-plane";
  auto mid_broken = [&] {
    s.sync_host();
    int k = 0;
    for (int c : mid_ce6) k += ce6_broken(s.state.ce6[c]);
    return k;
  };
  const real v = 0.5;  // m/s, each end
  std::vector<int> top, bottom;
  for (std::size_t n = 0; n < m.X.size(); ++n) {
    if (m.X[n].z > 2 * h - 1e-9) top.push_back(int(n));
    if (m.X[n].z < 1e-9) bottom.push_back(int(n));
  }
  for (int n : top) s.prescribe(n, 4, {0, 0, v});
  for (int n : bottom) s.prescribe(n, 4, {0, 0, -v});
  // Gap between the halves: the lowest mid-plane node of the upper half minus the highest of
  // the lower half (each side has its own copy of a mid-plane vertex once split).
  std::vector<int> mid_upper, mid_lower;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    real zc = 0;
    for (int q : m.tet_nodes[t]) zc += 0.25 * m.X[q].z;
    for (int q : m.tet_nodes[t])
      if (std::fabs(m.X[q].z - h) < 1e-9) (zc > h ? mid_upper : mid_lower).push_back(q);
  }
  auto gap = [&] {
    s.sync_host();
    real lo_top = 1e9, hi_bottom = -1e9;
    for (int n : mid_upper) lo_top = std::min(lo_top, s.state.x[n].z);
    for (int n : mid_lower) hi_bottom = std::max(hi_bottom, s.state.x[n].z);
    return lo_top - hi_bottom;
  };
  Monitors row = s.measure();
  while (mid_broken() < 8 && s.step_count() < 400000) {
    s.step();
    row = s.measure();
    if (row.broken == 0) {
      ASSERT_EQ(row.contacts, 0) << "contact force while the CE6s are intact, step " << s.step_count();
      ASSERT_EQ(row.contact, 0);
    }
  }
  ASSERT_EQ(mid_broken(), 8) << "the mid-plane did not break";
  // Adaptive activation: exactly the tets with a vertex on the broken plane.
  long near = 0;
  for (const auto& q : m.tet_nodes) {
    bool touches = false;
    for (int n : q) touches = touches || std::fabs(m.X[n].z - h) < 1e-9;
    near += touches;
  }
  if (activation == "adaptive") {
    EXPECT_EQ(row.active_tets, near) << "the vicinity of the broken plane is activated";
  }
  // Open a clear gap, then reverse and push the halves back together past contact.
  while (gap() < 2e-5) s.step();
  for (int n : top) s.prescribe(n, 4, {0, 0, -v});
  for (int n : bottom) s.prescribe(n, 4, {0, 0, v});
  real min_gap = 1;
  long touching_steps = 0;
  const real travel = 6e-5;  // m of approach after closing: a compressive strain of about 3e-3
  const real t_end = s.time() + (2e-5 + travel) / (2 * v);
  while (s.time() < t_end) {
    s.step();
    row = s.measure();
    min_gap = std::min(min_gap, gap());
    touching_steps += row.contacts > 0;
  }
  EXPECT_GT(touching_steps, 0) << "the halves never met";
  EXPECT_GT(row.contact_pairs, 0);
  // Never interpenetrate: the overlap that carries the compressive stress stays tiny next to h.
  EXPECT_GT(min_gap, -1e-3 * h) << "overlap " << -min_gap << " m";
  // The compression reached the far halves: the bar carries load through contact.
  EXPECT_GT(row.contacts, 0);
  EXPECT_GT(row.strain, 0);
  ::testing::Test::RecordProperty("max_overlap_over_h_" + activation, std::to_string(-min_gap / h));
}

}  // namespace

TEST(ContactBlocks, BarHalvesTouchOnlyThroughContactOnceBrokenAdaptive) {
  bar_halves("adaptive");
}

// With full activation the pairs across the intact mid-plane are candidates from step 0, so
// "no contact force while the CE6s are intact" is a real check here.
TEST(ContactBlocks, BarHalvesTouchOnlyThroughContactOnceBrokenFull) {
  bar_halves("full");
}

namespace {

/// The mid-plane bar, its base held and its top driven sideways while pressed down, so the
/// mid-plane breaks in shear under compression. Step by step: a CE6 that breaks holds its faces
/// in that evaluation (its law's overlap penalty and friction), and its tets' contact pair
/// carries no force there. From the next evaluation on contact holds them and the CE6 carries
/// none. That first evaluation sets the pair's overlap zero (the volume law starts from the
/// overlap the faces have); pressed on, the pair then carries force. Returns the number of CE6s
/// whose pair was evaluated on the evaluation after their break and carried force later.
int shear_break_handover(const std::string& activation) {
  const real h = 0.01;
  std::vector<int> mid;
  const auto bar = mid_plane_bar(activation, mid);
  Solver& s = *bar;
  const Model& m = s.model();
  EXPECT_EQ(mid.size(), 8u);
  for (std::size_t n = 0; n < m.X.size(); ++n) {
    if (m.X[n].z > 2 * h - 1e-9) s.prescribe(int(n), 7, {0.5, 0, -0.05});
    if (m.X[n].z < 1e-9) s.prescribe(int(n), 7, {0, 0, 0});
  }
  // The force a pair joined by CE6 c carried in the last evaluation (0 when no such pair).
  auto joint_force = [&](int c) {
    real sum = 0;
    const auto& pairs = s.contacts.pairs;
    for (std::size_t p = 0; p < pairs.size(); ++p)
      if (pairs[p].joint == c)
        for (int i = 0; i < 8; ++i) sum += norm(s.contacts.pair_force[8 * p + i]);
    return sum;
  };
  // The overlap zero of the pair joined by CE6 c (-2 when no such pair).
  auto joint_zero = [&](int c) {
    for (std::size_t p = 0; p < s.contacts.pairs.size(); ++p)
      if (s.contacts.pairs[p].joint == c) return s.contacts.history[p].overlap_zero;
    return real(-2);
  };
  std::vector<char> broken(mid.size(), 0), evaluated(mid.size(), 0), pushed(mid.size(), 0);
  std::vector<long> broke_at(mid.size(), -1);
  int breaks = 0;
  const long settle = 200;  // steps after the last break in which the pairs may push
  long last_break = -1;
  for (long step = 0; step < 400000 && (breaks < 8 || s.step_count() < last_break + settle); ++step) {
    s.step();
    s.sync_host();
    for (std::size_t k = 0; k < mid.size(); ++k) {
      const int c = mid[k];
      if (broke_at[k] >= 0 && s.step_count() == broke_at[k] + 1) {
        EXPECT_FALSE(ce6_carries_force(s.laws().ce6[0], s.state.ce6[c])) << "CE6 #" << c;
        evaluated[k] = joint_zero(c) >= 0;
      }
      if (broke_at[k] >= 0 && s.step_count() > broke_at[k]) pushed[k] |= joint_force(c) > 0;
      if (broken[k] || !ce6_broken(s.state.ce6[c])) continue;
      broken[k] = 1, ++breaks;
      broke_at[k] = last_break = s.step_count();
      EXPECT_EQ(joint_force(c), 0) << "CE6 #" << c << " broke at step " << s.step_count()
                                   << ": contact held its faces in the same evaluation as the CE6";
    }
  }
  EXPECT_EQ(breaks, 8) << "the mid-plane did not break";
  int handed_over = 0;
  for (std::size_t k = 0; k < mid.size(); ++k) handed_over += evaluated[k] && pushed[k];
  return handed_over;
}

}  // namespace

// Full activation: the pairs across the mid-plane are candidates throughout, so the check that
// a breaking CE6's pair carries nothing on its break is a real one.
TEST(ContactBlocks, ABreakingCe6HandsItsFacesToContactOnTheNextEvaluationFull) {
  EXPECT_GT(shear_break_handover("full"), 0) << "no CE6 broke pressed together";
}

// Adaptive: the vicinity joins the candidates after the break, in time for the next evaluation.
TEST(ContactBlocks, ABreakingCe6HandsItsFacesToContactOnTheNextEvaluationAdaptive) {
  EXPECT_GT(shear_break_handover("adaptive"), 0) << "no CE6 broke pressed together";
}
