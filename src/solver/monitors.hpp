#pragma once
// One row of monitors.csv, and its columns: each field once, with its name and unit. The header
// and the rows are written from the one table, kMonitorColumns, in its order. The loads fill
// their own fields (src/loads: each load's monitor()); the Solver fills the sums over the model
// and the energies.
#include <array>

#include "core/vec.hpp"

namespace fdem {

/// One row of the monitor CSV (SI units; stresses and strains compression positive).
struct Monitors {
  long step = 0;
  real time = 0;
  real axial_strain = 0, axial_stress = 0, lateral_strain = 0, volumetric_strain = 0;
  real force_top = 0, force_bottom = 0;  // N, platen reactions along the axis (compression positive)
  long damaged = 0, broken = 0, broken_I = 0, broken_II = 0, broken_mixed = 0;  // rock CE6s (not joints)
  long joint_damaged = 0, joint_broken = 0;  // joint CE6s (a frictional joint's count as broken from the start)
  real kinetic = 0, strain = 0, cohesive_stored = 0, cohesive_dissipated = 0, friction = 0, viscous = 0;
  real platen_stored = 0, platen_friction = 0, external_work = 0;
  real contact = 0, contact_friction = 0;                 // J, work into tet-tet contact (normal) and its friction
  real contact_stored = 0;                                // J, the contact energy held now (the volume law's W)
  long active_tets = 0, contact_pairs = 0, contacts = 0;  // activated tets, candidate pairs, touching pairs
  real confining_pressure = 0;                            // Pa, applied on the lateral surface
  // Pa, -(s_xx + s_yy)/2 with the viscous part, averaged over the tets of the middle third of the height
  real lateral_stress = 0;
  real indirect_tensile = 0;  // Pa, 2 P / (pi D t) of a line-loaded disc (Brazilian test), else 0
  real energy_error = 0;      // |external - (everything else)| / max(external, floor)
  // Per scene boundary condition, 4 columns after kMonitorColumns: its reaction on the rock
  // (x, y, z, N) and the work it did (J). (An array: a row is checkpointed as plain bytes.)
  static constexpr int kMaxConditionColumns = 128;
  int condition_columns = 0;
  std::array<real, kMaxConditionColumns> conditions{};
  // Per history point, 12 columns after those: its displacement (m), velocity (m/s) and the
  // Cauchy stress of its tet (Pa: xx, yy, zz, xy, yz, xz).
  static constexpr int kMaxHistoryColumns = 16 * 12;
  int history_columns = 0;
  std::array<real, kMaxHistoryColumns> history{};
};

/// A column of monitors.csv: its name (with the unit) and the field it shows, a count or a real.
struct MonitorColumn {
  const char* name;
  long Monitors::*count;
  real Monitors::*value;
};

constexpr MonitorColumn count_column(const char* name, long Monitors::*f) {
  return {name, f, nullptr};
}
constexpr MonitorColumn real_column(const char* name, real Monitors::*f) {
  return {name, nullptr, f};
}

/// The columns of monitors.csv, in file order.
inline constexpr std::array<MonitorColumn, 34> kMonitorColumns{
    count_column("step", &Monitors::step),
    real_column("time_s", &Monitors::time),
    real_column("axial_strain", &Monitors::axial_strain),
    real_column("axial_stress_Pa", &Monitors::axial_stress),
    real_column("lateral_strain", &Monitors::lateral_strain),
    real_column("volumetric_strain", &Monitors::volumetric_strain),
    real_column("force_top_N", &Monitors::force_top),
    real_column("force_bottom_N", &Monitors::force_bottom),
    count_column("damaged_ce6", &Monitors::damaged),
    count_column("broken_ce6", &Monitors::broken),
    count_column("broken_mode_I", &Monitors::broken_I),
    count_column("broken_mode_II", &Monitors::broken_II),
    count_column("broken_mixed", &Monitors::broken_mixed),
    count_column("joint_damaged_ce6", &Monitors::joint_damaged),
    count_column("joint_broken_ce6", &Monitors::joint_broken),
    real_column("kinetic_J", &Monitors::kinetic),
    real_column("strain_J", &Monitors::strain),
    real_column("cohesive_stored_J", &Monitors::cohesive_stored),
    real_column("cohesive_dissipated_J", &Monitors::cohesive_dissipated),
    real_column("friction_J", &Monitors::friction),
    real_column("viscous_J", &Monitors::viscous),
    real_column("platen_stored_J", &Monitors::platen_stored),
    real_column("platen_friction_J", &Monitors::platen_friction),
    real_column("external_work_J", &Monitors::external_work),
    real_column("energy_error", &Monitors::energy_error),
    real_column("contact_J", &Monitors::contact),
    real_column("contact_friction_J", &Monitors::contact_friction),
    real_column("contact_stored_J", &Monitors::contact_stored),
    count_column("active_tets", &Monitors::active_tets),
    count_column("contact_pairs", &Monitors::contact_pairs),
    count_column("contacts", &Monitors::contacts),
    real_column("confining_pressure_Pa", &Monitors::confining_pressure),
    real_column("indirect_tensile_Pa", &Monitors::indirect_tensile),
    real_column("lateral_stress_Pa", &Monitors::lateral_stress),
};

}  // namespace fdem
