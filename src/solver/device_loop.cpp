// The host backends' device loops (cpu: CpuExec, in place; debug: HostExec) and the choice of
// backend.
#include "solver/device_loop.hpp"

#include <algorithm>
#include <cstdlib>
#include <iterator>
#include <limits>
#include <string>
#include <utility>

#include "core/error.hpp"
#include "partition/halo.hpp"
#include "solver/device_loop_impl.hpp"

namespace fdem {

// cuda/device_loop.cu where nvcc is found.
std::unique_ptr<DeviceLoop> make_cuda_device_loop(const LoopParts& parts, bool direct_mpi, FusedPlan plan);

#ifndef FDEM_HAVE_CUDA
std::unique_ptr<DeviceLoop> make_cuda_device_loop(const LoopParts&, bool, FusedPlan) {
  throw InputError(
      "solver.backend cuda: this fdem was built without CUDA (nvcc was not found at build time). Fix: build where "
      "nvcc is installed (cmake -DFDEM_ENABLE_CUDA=ON), or run with --backend cpu");
}
#endif

DeviceSchedule device_schedule(Backend b) {
  const char* e = std::getenv("FDEM_DEVICE_SCHEDULE");
  const std::string v = e ? e : "";
  // The cpu backend's default is the colour passes: measured faster on the host than the fused
  // pass (docs/benchmarks.md), which saves a GPU its launches and a second read of the nodes.
  if (v.empty() && b == Backend::cpu) return DeviceSchedule::colour;
  if (v.empty() || v == "auto") return DeviceSchedule::automatic;
  if (v == "fused") return DeviceSchedule::fused;
  if (v == "colour") return DeviceSchedule::colour;
  throw InputError("FDEM_DEVICE_SCHEDULE=" + v +
                   ": unknown schedule of the device loop's element passes. Fix: FDEM_DEVICE_SCHEDULE=auto (the "
                   "default: TET4 and CE6 in one pass where every node is one tet's, the integration in it where the "
                   "run allows), fused (that pass without the integration) or colour, or unset it");
}

int device_blocks_per_sm() {
  const char* e = std::getenv("FDEM_CUDA_BLOCKS_PER_SM");
  const std::string v = e ? e : "";
  if (v.empty() || v == "1") return 1;
  if (v == "2") return 2;
  throw InputError("FDEM_CUDA_BLOCKS_PER_SM=" + v +
                   ": not a choice of the fused pass's resident blocks per multiprocessor. Fix: "
                   "FDEM_CUDA_BLOCKS_PER_SM=1 (the default: every register the kernel wants, one block of 256 "
                   "threads per multiprocessor) or 2 (half the registers, the rest spilled), or unset it");
}

void poison_host_state(const LoopParts& s, bool scalars_waiting, bool integrates) {
  const real nan = std::numeric_limits<real>::quiet_NaN();
  const Vec3 bad{nan, nan, nan};
  for (auto* a : {&s.x, &s.v, &s.f, &s.loads.platens.anchor, &s.loads.surface.face_force})
    std::fill(a->begin(), a->end(), bad);
  for (Ce6Damage& c : s.ce6.damage) c.D[0] = c.D[1] = c.D[2] = nan, c.mode = -1;
  for (Ce6Anchors& c : s.ce6.anchors) std::fill(std::begin(c.a), std::end(c.a), bad);
  std::fill(s.ce6_broke.begin(), s.ce6_broke.end(), 0xAA);
  if (s.contacts.enabled()) {
    ContactSet& c = s.contacts;
    std::fill(c.tet_flags.begin(), c.tet_flags.end(), 0xAA);
    std::fill(c.history.begin(), c.history.end(), PairHistory{bad, nan});
    std::fill(c.pair_force.begin(), c.pair_force.end(), bad);
    std::fill(c.eval.begin(), c.eval.end(), ContactEval{bad, bad, nan, nan, nan});
  }
  // The last evaluation's scalars not yet settled: read before settle() they are NaN.
  if (!scalars_waiting) return;
  s.loads.platens.force_top = s.loads.platens.force_bottom = s.energy.p_contact = s.energy.contact_spring =
      s.energy.contact_stored = nan;
  s.energy.p_viscous = s.energy.p_cohesive = s.energy.p_friction = nan;
  if (integrates) s.loads.gravity.power = nan;  // (with the elements' sums there)
  if (s.loads.surface.enabled) s.loads.surface.pressure = s.loads.surface.power = nan;
}

std::vector<std::uint8_t> middle_third_tets(const Model& m) {
  std::vector<std::uint8_t> mid(m.tet_nodes.size());
  const real z_lo = m.box_min.z + (m.box_max.z - m.box_min.z) / 3, z_hi = m.box_max.z - (m.box_max.z - m.box_min.z) / 3;
  for (std::size_t t = 0; t < mid.size(); ++t) {
    const auto& q = m.tet_nodes[t];
    const real zc = 0.25 * (m.X[q[0]].z + m.X[q[1]].z + m.X[q[2]].z + m.X[q[3]].z);
    mid[t] = zc >= z_lo && zc <= z_hi;
  }
  return mid;
}

std::vector<std::uint8_t> tets_on_loads(const LoopParts& s, const std::vector<int>& lateral_nodes) {
  const Model& m = s.model;
  std::vector<std::uint8_t> loaded(m.X.size(), 0);
  if (s.loads.platens.enabled)
    for (int n : m.platen_nodes) loaded[n] = 1;
  if (s.loads.surface.enabled)
    for (int n : lateral_nodes) loaded[n] = 1;
  std::vector<std::uint8_t> ext(m.tet_nodes.size(), 0);
  for (std::size_t t = 0; t < ext.size(); ++t)
    for (int n : m.tet_nodes[t])
      if (loaded[n]) ext[t] = 2;
  return ext;
}

bool plan_fused_pass(const Model& m, FusedPlan& plan) {
  const auto& tets = m.tet_colours.order;
  const auto& ce6s = m.ce6_colours.order;
  const int nk = int(tets.size());
  std::vector<int> launch_of(m.tet_nodes.size(), -1);  // a computed tet's place in the pass
  std::vector<char> seen(m.X.size(), 0);
  for (int k = 0; k < nk; ++k) {
    launch_of[tets[k]] = k;
    for (int n : m.tet_nodes[tets[k]]) {
      if (seen[n]) return false;  // a node shared by two tets
      seen[n] = 1;
    }
  }
  plan.list.assign(4 * std::size_t(nk), -1);
  plan.sides.assign(ce6s.size(), 0);
  std::vector<int> fill(nk, 0);
  for (int k = 0; k < int(ce6s.size()); ++k) {
    const int e = ce6s[k];
    int writer = -1;
    for (int side = 0; side < 2; ++side) {
      const int t = m.ce6_tets[e][side], l = launch_of[t];
      if (l < 0) continue;
      const auto& q = m.tet_nodes[t];
      for (int j = 0; j < 3; ++j)
        if (std::find(q.begin(), q.end(), m.ce6_nodes[e][3 * side + j]) == q.end()) return false;
      if (fill[l] == 4) return false;
      if (writer < 0) writer = side;
      plan.list[4 * std::size_t(l) + fill[l]++] = k << 2 | side << 1 | (writer == side);
      ++plan.sides[k];
    }
    if (writer < 0) return false;  // no computed tet evaluates it
  }
  return true;
}

std::unique_ptr<DeviceLoop> make_device_loop(Backend b, const LoopParts& s) {
  // Read (and checked) here, at the start, on every rank alike.
  const bool direct_mpi = b != Backend::cpu && s.layout.distributed() && device_buffers_to_mpi(b == Backend::cuda);
  auto fused_plan = [&s, b] {
    FusedPlan plan;  // empty: the colour passes
    const DeviceSchedule schedule = device_schedule(b);
    const int blocks = device_blocks_per_sm();  // checked whatever the schedule
    if (schedule == DeviceSchedule::colour || !plan_fused_pass(s.model, plan)) return FusedPlan{};
    // The pass integrates too on one rank, where it moves every node: each in a tet.
    std::vector<char> in_tet(s.model.X.size(), 0);
    for (const auto& q : s.model.tet_nodes)
      for (int n : q) in_tet[n] = 1;
    plan.integrate = schedule == DeviceSchedule::automatic && !s.layout.distributed() &&
                     std::find(in_tet.begin(), in_tet.end(), 0) == in_tet.end();
    plan.blocks_per_sm = blocks;
    return plan;
  };
  switch (b) {
    case Backend::debug: {
      host_order();  // FDEM_DEBUG_ORDER, checked before the run starts
      FusedPlan plan = fused_plan();
      return std::make_unique<DeviceLoopImpl<HostExec>>(Backend::debug, s, direct_mpi, std::move(plan));
    }
    case Backend::cuda:
      if (cuda_built()) {
        // All ranks decide together, so that none is left waiting in the split below. A program
        // that never started MPI (tests/gpu, a library user) is one process: no collective, which
        // would abort it before MPI_Init.
        int mpi = 0;
        MPI_Initialized(&mpi);
        const int visible = cuda_device_count();
        int fewest = visible;
        if (mpi) MPI_Allreduce(&visible, &fewest, 1, MPI_INT, MPI_MIN, s.layout.comm);
        if (fewest == 0)
          throw InputError("solver.backend cuda: no CUDA device is visible" +
                           (visible == 0 ? " (" + cuda_device_count_error() + ")" : std::string(" on another rank")) +
                           ". Fix: run on a machine with an NVIDIA GPU and its driver (check nvidia-smi and "
                           "CUDA_VISIBLE_DEVICES), or run with --backend cpu");
        // Ranks sharing a node take its GPUs in turn.
        int local_rank = 0;
        if (mpi) {
          MPI_Comm node;
          MPI_Comm_split_type(s.layout.comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
          local_rank = rank_in(node);
          MPI_Comm_free(&node);
        }
        select_cuda_device(local_rank);
      }
      return make_cuda_device_loop(s, direct_mpi, fused_plan());  // after the collective above
    case Backend::cpu:
      // Host memory: the halo hands its buffers to MPI as they are.
      return std::make_unique<DeviceLoopImpl<CpuExec>>(Backend::cpu, s, s.layout.distributed(), fused_plan());
  }
  throw std::logic_error("make_device_loop: unknown backend");
}

}  // namespace fdem
