#pragma once
// Numbers in messages: short, with a chosen number of significant digits. CSV fields.
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

namespace fdem {

inline std::string fmt(double v, int digits = 6) {
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

/// The value of s if all of it is one finite decimal number (what users give on command lines);
/// NaN for "", "2%", "1e400", "nan" and hexadecimal ("0x10", which strtod reads as 16).
inline double decimal(const std::string& s) {
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  const bool whole = !s.empty() && *end == '\0' && s.find_first_of("xX") == std::string::npos;
  return whole && std::isfinite(x) ? x : std::nan("");
}

/// One CSV field (RFC 4180): quoted when it holds a comma, a quote, a space or a line break,
/// with its quotes doubled, so that a run name such as `Berea, dry` stays one field.
inline std::string csv_field(const std::string& v) {
  if (v.find_first_of(",\" \r\n") == std::string::npos) return v;
  std::string q = "\"";
  for (char c : v) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

/// The fields of one CSV line, quoted ones (RFC 4180) unquoted again.
inline std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (c == '"' && quoted && i + 1 < line.size() && line[i + 1] == '"')
      out.back() += c, ++i;  // a doubled quote inside a quoted field
    else if (c == '"')
      quoted = !quoted;
    else if (c == ',' && !quoted)
      out.emplace_back();
    else if (c != '\r')
      out.back() += c;
  }
  return out;
}

}  // namespace fdem
