#pragma once
// How a boundary condition's value follows time: value(t) = value x scale(t). The scale is 1
// throughout (constant), rises from 0 at t = 0 to 1 at t = duration along a line (linear) or a
// C1 smoothstep (smooth, the platens' ramp), or follows a table of (t, scale) rows, linear
// between rows and held at the first and last values outside them.
#include <array>
#include <vector>

#include "core/choice.hpp"
#include "physics/integrate.hpp"

namespace fdem {

enum class TimeShape { constant, linear, smooth, table };
template <>
struct ChoiceNames<TimeShape> {
  static constexpr std::array<const char *, 4> words{"constant", "linear", "smooth", "table"};
};

struct TimeFunction {
  TimeShape shape = TimeShape::constant;
  real duration = 0;                       // s, the linear and smooth ramps' rise
  std::vector<std::array<real, 2>> table;  // (t in s, scale), t strictly increasing

  /// The scale at time t (s).
  real at(real t) const {
    switch (shape) {
      case TimeShape::linear:
        return t >= duration ? 1 : (t <= 0 ? 0 : t / duration);
      case TimeShape::smooth:
        return t <= 0 ? 0 : ramped_speed(t, 1, duration);
      case TimeShape::table:
        return table_at(t);
      default:
        return 1;
    }
  }

 private:
  real table_at(real t) const {
    if (table.empty()) return 1;
    if (t <= table.front()[0]) return table.front()[1];
    for (std::size_t k = 1; k < table.size(); ++k)
      if (t < table[k][0]) {
        const auto &a = table[k - 1], &b = table[k];
        return a[1] + (b[1] - a[1]) * (t - a[0]) / (b[0] - a[0]);
      }
    return table.back()[1];
  }
};

}  // namespace fdem
