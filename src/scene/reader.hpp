#pragma once
// The scene reader's tools: a YAML walker that checks keys, numbers, words and vectors and
// collects every error as "<file>: <key.path>: <what is wrong>; <the fix>". parse.cpp reads
// the sections with it, conditions.cpp the boundary conditions.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "core/choice.hpp"
#include "core/format.hpp"
#include "core/vec.hpp"

namespace fdem::scene_reading {

constexpr double kInf = std::numeric_limits<double>::infinity();

inline std::string join_path(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

inline std::string last_key(const std::string& path) {
  const auto dot = path.find_last_of('.');
  return dot == std::string::npos ? path : path.substr(dot + 1);
}

/// At most n bytes of s, not cutting a UTF-8 character.
inline std::string utf8_prefix(const std::string& s, std::size_t n) {
  if (s.size() <= n) return s;
  while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xC0) == 0x80) --n;
  return s.substr(0, n);
}

inline std::string describe(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Null:
      return "nothing";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
    case YAML::NodeType::Scalar:  // the start of a long one (a whole file read as one value)
      return "'" + (n.Scalar().size() > 60
                        ? utf8_prefix(n.Scalar(), 60) + "...' (" + std::to_string(n.Scalar().size()) + " bytes)"
                        : n.Scalar() + "'");
    default:
      return "an undefined value";
  }
}

// Edit distance, for "did you mean" hints on misspelled keys.
inline size_t distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      const bool same = std::tolower(a[i - 1]) == std::tolower(b[j - 1]);
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (same ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

/// Allowed interval of a number; open or closed at each end; optionally integers only.
struct Range {
  double lo = -kInf, hi = kInf;
  bool lo_open = false, hi_open = false;
  bool integer = false;

  bool contains(double v) const {
    if (lo_open ? !(v > lo) : !(v >= lo)) return false;
    if (hi_open ? !(v < hi) : !(v <= hi)) return false;
    return true;
  }
  std::string text(const std::string& name) const {
    std::string s;
    const bool has_lo = lo > -kInf, has_hi = hi < kInf;
    if (has_lo && has_hi)
      s = fmt(lo) + (lo_open ? " < " : " <= ") + name + (hi_open ? " < " : " <= ") + fmt(hi);
    else if (has_lo)
      s = name + (lo_open ? " > " : " >= ") + fmt(lo);
    else if (has_hi)
      s = name + (hi_open ? " < " : " <= ") + fmt(hi);
    else
      s = "any finite " + name;
    return "allowed " + s + (integer ? " (a whole number)" : "");
  }
};
inline Range positive() {
  return {0, kInf, true, false};
}
inline Range at_least(double lo) {
  return {lo, kInf, false, false};
}
inline Range closed(double lo, double hi) {
  return {lo, hi, false, false};
}
inline Range count_at_least(double lo, double hi = kInf) {
  return {lo, hi, false, false, true};
}

/// Walks a YAML tree and collects every error; the scene's sections derive from it.
class YamlReader {
 public:
  explicit YamlReader(std::string file) : file_(std::move(file)) {}

  const std::vector<std::string>& errors() const { return errors_; }

  void error(const std::string& path, const std::string& what, const std::string& fix) {
    std::string msg = file_ + ": ";
    if (!path.empty()) msg += path + ": ";
    msg += what;
    if (!fix.empty()) msg += "; " + fix;
    errors_.push_back(msg);
  }

  /// True if `n` is a map whose keys are all in `allowed` (unknown/duplicate keys are reported).
  bool check_map(const YAML::Node& n, const std::string& path, const std::vector<std::string>& allowed) {
    std::string list;
    for (const auto& k : allowed) list += (list.empty() ? "" : ", ") + k;
    if (!n.IsMap()) {
      error(path, "expected a map of keys, got " + describe(n), "allowed keys: " + list);
      return false;
    }
    std::set<std::string> seen;  // not a vector: a file with 10^5 keys must not take minutes
    for (const auto& kv : n) {
      if (!kv.first.IsScalar()) {
        error(path, "a key is " + describe(kv.first) + ", not a plain name", "allowed keys: " + list);
        continue;
      }
      const std::string key = kv.first.Scalar();
      if (!seen.insert(key).second) error(join_path(path, key), "key given twice", "give each key once");
      if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
      std::string hint;
      size_t best = 3;
      for (const auto& a : allowed) {
        const size_t d = distance(key, a);
        if (d < best) best = d, hint = "did you mean '" + a + "'? ";
      }
      if (hint.empty() && key.size() >= 3)
        for (const auto& a : allowed)
          if (a.find(key) != std::string::npos || key.find(a) != std::string::npos) {
            hint = "did you mean '" + a + "'? ";
            break;
          }
      error(join_path(path, key), "unknown key",
            hint + "allowed keys in " + (path.empty() ? "the top level" : path) + ": " + list);
    }
    return true;
  }

  /// Reads number `key` of map `n` into `out` if present and inside `r`. Returns true if assigned.
  template <class T>
  bool number(const YAML::Node& n, const std::string& path, const std::string& key, const Range& r, T& out) {
    const YAML::Node v = n[key];
    if (!v) return false;
    const std::string p = join_path(path, key);
    double x = 0;
    if (!scalar_number(v, p, r, x)) return false;
    out = static_cast<T>(x);
    return true;
  }

  /// A number given directly (list entries). Returns false (and reports) if bad.
  bool scalar_number(const YAML::Node& v, const std::string& p, const Range& r, double& x) {
    const std::string name = last_key(p);
    if (!v.IsScalar()) {
      error(p, "expected a number, got " + describe(v), r.text(name));
      return false;
    }
    try {
      x = v.as<double>();
    } catch (const YAML::Exception&) {
      error(p, "'" + v.Scalar() + "' is not a number", r.text(name));
      return false;
    }
    if (!std::isfinite(x)) {
      error(p, "'" + v.Scalar() + "' is not a finite number", r.text(name));
      return false;
    }
    if (!r.contains(x)) {
      error(p, v.Scalar() + " is out of range", r.text(name));
      return false;
    }
    if (r.integer && std::fabs(x) > 1e15) {
      error(p, v.Scalar() + " is too large", r.text(name) + ", at most 1e15");
      return false;
    }
    if (r.integer && x != std::floor(x)) {
      error(p, v.Scalar() + " is not a whole number", r.text(name));
      return false;
    }
    return true;
  }

  /// Reads a non-empty string. Returns true if assigned.
  bool text(const YAML::Node& n, const std::string& path, const std::string& key, std::string& out,
            const std::string& allowed) {
    const YAML::Node v = n[key];
    if (!v) return false;
    const std::string p = join_path(path, key);
    if (!v.IsScalar() || v.Scalar().empty()) {
      error(p, "expected a text value, got " + describe(v), allowed);
      return false;
    }
    out = v.Scalar();
    return true;
  }

  /// Reads one of a fixed set of words. Returns true if assigned.
  bool choice(const YAML::Node& n, const std::string& path, const std::string& key,
              const std::vector<std::string>& options, std::string& out) {
    std::string list;
    for (const auto& o : options) list += (list.empty() ? "" : " | ") + o;
    std::string s;
    if (!text(n, path, key, s, "allowed: " + list)) return false;
    if (std::find(options.begin(), options.end(), s) == options.end()) {
      error(join_path(path, key), "'" + s + "' is not recognised", "allowed: " + list);
      return false;
    }
    out = s;
    return true;
  }

  /// Reads one of the words of E (ChoiceNames). Returns true if assigned.
  template <class E>
  bool choice(const YAML::Node& n, const std::string& path, const std::string& key, E& out) {
    const auto& words = ChoiceNames<E>::words;
    std::string s;
    return choice(n, path, key, std::vector<std::string>(words.begin(), words.end()), s) && choice_named(s, out);
  }

  bool boolean(const YAML::Node& n, const std::string& path, const std::string& key, bool& out) {
    const YAML::Node v = n[key];
    if (!v) return false;
    try {
      if (v.IsScalar()) {
        out = v.as<bool>();
        return true;
      }
    } catch (const YAML::Exception&) {
    }
    error(join_path(path, key), "expected true or false, got " + describe(v), "allowed: true | false");
    return false;
  }

  /// A list of three numbers [x, y, z].
  bool vec3(const YAML::Node& v, const std::string& p, const Range& r, Vec3& out) {
    if (!v.IsSequence() || v.size() != 3) {
      error(p,
            "expected a list of three numbers [x, y, z], got " + describe(v) +
                (v.IsSequence() ? " of " + std::to_string(v.size()) : ""),
            "write e.g. " + p.substr(p.find_last_of('.') + 1) + ": [0.01, 0.01, 0.02]");
      return false;
    }
    Vec3 x{0, 0, 0};
    bool ok = true;
    for (int i = 0; i < 3; ++i) {
      double c = 0;
      if (scalar_number(v[i], p + "[" + std::to_string(i) + "]", r, c))
        x[i] = c;
      else
        ok = false;
    }
    if (ok) out = x;
    return ok;
  }

 protected:
  std::string file_;
  std::vector<std::string> errors_;
};

}  // namespace fdem::scene_reading
