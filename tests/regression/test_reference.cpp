// Every backend, schedule and iteration order of the solver against the serial reference
// stepper (tests/reference_stepper.hpp): plain loops over the same element laws, adding each
// node's forces in the documented order. The states must agree bit for bit, step for step, on
// an elastic box, a box under gravity with prescribed nodes and a confining pressure, a box
// that fractures with contact, and two blocks that collide and slide.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <ostream>
#include <string>

#include "backend_support.hpp"
#include "core/forall.hpp"
#include "reference_stepper.hpp"

using namespace fdem;
using namespace fdem::test;

namespace {

/// One way to run the solver: its backend, the device loop's schedule and the host's order of
/// iterations within a launch.
struct Leg {
  const char* backend;
  const char* schedule;  // FDEM_DEVICE_SCHEDULE (nullptr: the backend's default)
  HostOrder order;
};

std::string leg_name(const Leg& l) {
  std::string name = l.backend;
  if (l.schedule) name += std::string("_") + l.schedule;
  if (std::string(l.backend) != "cpu") name += l.order == HostOrder::forward ? "_forward" : "_scrambled";
  return name;
}
std::string leg_test_name(const ::testing::TestParamInfo<Leg>& info) {
  return leg_name(info.param);
}
void PrintTo(const Leg& l, std::ostream* os) {
  *os << leg_name(l);
}

/// The host's order of iterations set for a test, restored after it.
struct OrderSetting {
  explicit OrderSetting(HostOrder o) : before_(host_order()) { set_host_order(o); }
  ~OrderSetting() { set_host_order(before_); }

 private:
  HostOrder before_;
};

/// The first node whose vector differs in any bit, or -1.
long first_difference(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  for (std::size_t n = 0; n < std::min(a.size(), b.size()); ++n)
    if (std::memcmp(&a[n], &b[n], sizeof(Vec3)) != 0) return long(n);
  return a.size() == b.size() ? -1 : long(std::min(a.size(), b.size()));
}

class Reference : public ::testing::TestWithParam<Leg> {
 protected:
  Reference() : schedule_("FDEM_DEVICE_SCHEDULE", GetParam().schedule), order_(GetParam().order) {}

  Scene scene(Scene s) const {
    s.solver.backend = named<Backend>(GetParam().backend);
    return s;
  }

  /// The solver's host state (synchronised) against the reference's: positions, velocities and
  /// forces bit for bit.
  static void expect_same_nodes(const Solver& s, const ReferenceStepper& r) {
    s.sync_host();
    ASSERT_EQ(s.step_count(), r.steps);
    EXPECT_EQ(s.time(), r.time);
    EXPECT_EQ(s.platen_travel(), r.top_offset);
    EXPECT_TRUE(same_bits(s.state.x, r.x)) << "first node apart: " << first_difference(s.state.x, r.x)
                                           << ", max relative difference " << max_rel_diff(s.state.x, r.x, 1e-9);
    EXPECT_TRUE(same_bits(s.state.v, r.v)) << "first node apart: " << first_difference(s.state.v, r.v);
    EXPECT_TRUE(same_bits(s.state.f, r.f)) << "first node apart: " << first_difference(s.state.f, r.f);
  }

  /// CE6 damage and break mode of every CE6, and the friction anchors of those that keep them
  /// (damaged or broken: an intact CE6 does not use its anchors, and the device does not store
  /// them). Returns the CE6s broken.
  static long expect_same_ce6(const Solver& s, const ReferenceStepper& r) {
    long broken = 0;
    for (std::size_t c = 0; c < r.ce6.size(); ++c) {
      EXPECT_EQ(s.state.ce6[c].mode, r.ce6[c].mode) << "CE6 " << c;
      EXPECT_EQ(std::memcmp(s.state.ce6[c].D, r.ce6[c].D, sizeof r.ce6[c].D), 0) << "CE6 " << c;
      if (ce6_max_damage(r.ce6[c]) > 0) {
        EXPECT_EQ(std::memcmp(s.state.ce6[c].slip, r.ce6[c].slip, sizeof r.ce6[c].slip), 0) << "CE6 " << c;
      }
      broken += r.ce6[c].mode != 0;
    }
    return broken;
  }

  /// Activation flags, candidate pairs, their histories and the builds of the list.
  static void expect_same_contact(const Solver& s, const ReferenceStepper& r) {
    EXPECT_EQ(s.contacts.tet_flags, r.active);
    ASSERT_EQ(s.contacts.pairs.size(), r.pairs.size());
    for (std::size_t k = 0; k < r.pairs.size(); ++k) {
      const ContactPair &p = s.contacts.pairs[k], &q = r.pairs[k];
      ASSERT_TRUE(p.a == q.a && p.b == q.b && p.joint == q.joint) << "pair " << k;
    }
    EXPECT_TRUE(same_bits(s.contacts.history, r.history));
    EXPECT_EQ(s.contacts.times.rebuilds, r.rebuilds);
  }

 private:
  EnvSetting schedule_;
  OrderSetting order_;
};

INSTANTIATE_TEST_SUITE_P(
    Legs, Reference,
    // (the cpu backend runs index order whatever the host order says)
    ::testing::Values(Leg{"cpu", nullptr, HostOrder::scrambled}, Leg{"cpu", "auto", HostOrder::scrambled},
                      Leg{"cpu", "fused", HostOrder::scrambled}, Leg{"debug", "auto", HostOrder::scrambled},
                      Leg{"debug", "auto", HostOrder::forward}, Leg{"debug", "fused", HostOrder::scrambled},
                      Leg{"debug", "colour", HostOrder::scrambled}, Leg{"debug", "colour", HostOrder::forward}),
    leg_test_name);

TEST_P(Reference, ElasticBox) {
  auto solver = backend_solver(scene(backend_elastic_scene("cpu")));
  ReferenceStepper ref(solver->scene(), solver->model(), solver->dt());
  for (int i = 0; i < 2000; ++i) solver->step(), ref.step();
  expect_same_nodes(*solver, ref);
  const Monitors m = solver->measure();
  EXPECT_GT(m.axial_stress, 1e6) << "the box should be loaded";
  EXPECT_NEAR(m.force_top, -ref.force_top, 1e-12 * std::fabs(ref.force_top));
  EXPECT_NEAR(m.force_bottom, ref.force_bottom, 1e-12 * std::fabs(ref.force_bottom));
}

TEST_P(Reference, GravityPrescribedNodesAndConstantPressure) {
  auto solver = backend_gravity_solver(GetParam().backend, "constant");
  solver->prescribe(5, 0b100, Vec3{0, 0, 0.03});
  ReferenceStepper ref(solver->scene(), solver->model(), solver->dt());
  ref.prescribe(0, 0b011, Vec3{0.01, -0.02, 0});  // as backend_gravity_solver
  ref.prescribe(0, 0b001, Vec3{0.015, 7, 7});
  ref.prescribe(5, 0b100, Vec3{0, 0, 0.03});
  for (int i = 0; i < 1500; ++i) solver->step(), ref.step();
  expect_same_nodes(*solver, ref);
  EXPECT_EQ(ref.v[0].x, 0.015);
  EXPECT_EQ(ref.v[0].y, -0.02);
  EXPECT_NE(ref.v[0].z, 0.0) << "z is free: gravity and the pressure move it";
  EXPECT_GT(solver->measure().confining_pressure, 1e5) << "the pressure should be rising";
}

TEST_P(Reference, FracturingBoxWithContactAndPressure) {
  auto solver = backend_solver(scene(backend_fracture_scene("cpu")));
  ReferenceStepper ref(solver->scene(), solver->model(), solver->dt());
  long touched = 0;
  for (int i = 0; i < 4000; ++i) {
    solver->step(), ref.step();
    touched += ref.touching;
  }
  expect_same_nodes(*solver, ref);
  const long broken = expect_same_ce6(*solver, ref);
  expect_same_contact(*solver, ref);
  EXPECT_GT(broken, 20) << "the box should fracture";
  EXPECT_GT(touched, 0) << "fragments should touch";
  EXPECT_GT(ref.rebuilds, 2) << "breaks should activate tets and rebuild the list";
  EXPECT_EQ(solver->measure().broken, broken);
}

/// Two 10 mm cubes of 2 x 2 x 2 Kuhn cells, the upper one 20 um above the lower and shifted
/// sideways by a quarter of a cell.
Mesh two_blocks() {
  constexpr real e = 0.01;  // m
  Mesh a = structured_box_mesh({e, e, e}, 2, 2, 2);
  const Mesh b = structured_box_mesh({e, e, e}, 2, 2, 2);
  const int off = int(a.vertices.size());
  for (Vec3 p : b.vertices) a.vertices.push_back(p + Vec3{0.25 * e / 2, 0, e + 2e-5});
  for (auto t : b.tets) a.tets.push_back({t[0] + off, t[1] + off, t[2] + off, t[3] + off});
  a.source = "two blocks";
  return a;
}

TEST_P(Reference, TwoBlocksCollideAndSlide) {
  // No CE6 and no platens: the upper block falls obliquely onto the lower one, so the contact
  // pairs' normal and friction forces (springs carried across rebuilds) move both.
  Scene s = scene(test_scene());
  s.platens.enabled = false;
  s.fracture.everywhere = false;
  s.contact.activation = Activation::full;
  s.contact.buffer = 2e-5;  // m: the moving block leaves the list's boxes, so the list is rebuilt
  Solver solver(s, build_model(two_blocks(), s));
  ReferenceStepper ref(solver.scene(), solver.model(), solver.dt());
  const int lower_vertices = 27;  // (2 + 1)^3
  for (std::size_t n = 0; n < solver.model().X.size(); ++n)
    if (solver.model().node_vertex[n] >= lower_vertices) solver.state.v[n] = ref.v[n] = Vec3{0.5, 0, -2};
  solver.host_changed();
  long touched = 0;
  real spring = 0;  // m, the longest friction spring of the run
  for (int i = 0; i < 2000; ++i) {
    solver.step(), ref.step();
    touched += ref.touching;
    for (const PairHistory& h : ref.history) spring = std::max(spring, norm(h.spring));
  }
  expect_same_nodes(solver, ref);
  expect_same_contact(solver, ref);
  EXPECT_GT(touched, 100) << "the blocks should touch over many steps";
  EXPECT_GT(ref.rebuilds, 2);
  EXPECT_GT(spring, 0) << "friction should act";
}

}  // namespace
