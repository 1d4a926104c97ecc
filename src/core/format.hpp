#pragma once
// Numbers in messages: short, with a chosen number of significant digits.
#include <sstream>
#include <string>

namespace fdem {

inline std::string fmt(double v, int digits = 6) {
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

}  // namespace fdem
