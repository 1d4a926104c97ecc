#pragma once
// The .msh reader's line reader over a whole file's text: lines, tokens, numbers and counts, each
// checked, and messages that name the file and line. Shared by io/msh_reader.cpp and
// io/msh_groups.cpp; not part of the library's interface.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "core/error.hpp"
#include "io/mesh_detail.hpp"

namespace fdem::mesh_detail {

/// Line-oriented reader over the whole file text. Blank lines are skipped.
class Reader {
 public:
  Reader(const std::string& path, const std::string& text) : path_(path), text_(text) {}

  /// Next non-blank line (without the line break and surrounding blanks); false at end of file.
  bool next(std::string_view& line) {
    while (pos_ < text_.size()) {
      const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
      std::string_view l(text_.data() + pos_, end - pos_);
      pos_ = end + 1;
      ++line_no_;
      const std::size_t a = l.find_first_not_of(" \t\r\v\f");
      if (a == std::string_view::npos) continue;
      const std::size_t b = l.find_last_not_of(" \t\r\v\f");
      line = l.substr(a, b - a + 1);
      return true;
    }
    line_no_ = last_line();
    return false;
  }

  /// Next line, which must exist; `inside` says where we are for the end-of-file message.
  std::string_view need(const std::string& inside) {
    std::string_view l;
    if (!next(l))
      fail("the file ends " + inside + "; it is truncated",
           "write the file again completely (or re-export it from gmsh)");
    return l;
  }

  /// Split a line into whitespace-separated tokens (reusing `out`).
  static void split(std::string_view l, std::vector<std::string_view>& out) {
    out.clear();
    std::size_t i = 0;
    while (i < l.size()) {
      while (i < l.size() && std::isspace(static_cast<unsigned char>(l[i]))) ++i;
      std::size_t j = i;
      while (j < l.size() && !std::isspace(static_cast<unsigned char>(l[j]))) ++j;
      if (j > i) out.emplace_back(l.substr(i, j - i));
      i = j;
    }
  }

  [[noreturn]] void fail(const std::string& what, const std::string& fix) const { fail_at(line_no_, what, fix); }
  [[noreturn]] void fail_at(long line, const std::string& what, const std::string& fix) const {
    throw InputError(path_ + ":" + std::to_string(line) + ": " + what + "; " + fix);
  }

  /// Unsigned integer token (tags, counts, types).
  std::uint64_t u64(std::string_view t, const char* what) const {
    std::uint64_t v = 0;
    const char* b = t.data();
    const char* e = t.data() + t.size();
    if (b != e && *b == '+') ++b;
    const auto r = std::from_chars(b, e, v);
    if (r.ec != std::errc() || r.ptr != e || b == e)
      fail(std::string("expected ") + what + " (a non-negative integer), found " + quote(t),
           "fix this line or re-export the mesh from gmsh");
    return v;
  }
  /// Integer token that may be negative (entity tags in v4 blocks).
  std::int64_t i64(std::string_view t, const char* what) const {
    std::int64_t v = 0;
    const char* b = t.data();
    const char* e = t.data() + t.size();
    if (b != e && *b == '+') ++b;
    const auto r = std::from_chars(b, e, v);
    if (r.ec != std::errc() || r.ptr != e || b == e)
      fail(std::string("expected ") + what + " (an integer), found " + quote(t),
           "fix this line or re-export the mesh from gmsh");
    return v;
  }
  /// Finite floating-point token (coordinates).
  double number(std::string_view t, const char* what) const {
    double v = 0;
    const char* b = t.data();
    const char* e = t.data() + t.size();
    if (b != e && *b == '+') ++b;
    const auto r = std::from_chars(b, e, v);
    if (r.ec == std::errc::result_out_of_range)
      fail(std::string(what) + " " + quote(t) + " is out of the range of a double",
           "fix the coordinates (are they in the intended unit?)");
    if (r.ec != std::errc() || r.ptr != e || b == e)
      fail(std::string("expected ") + what + " (a number), found " + quote(t),
           "fix this line or re-export the mesh from gmsh");
    if (!std::isfinite(v))
      fail(std::string(what) + " is " + quote(t) + ", not a finite number",
           "fix the node coordinates where the mesh was made");
    return v;
  }
  /// A count from a section header: it cannot exceed the size of the file (each entry takes at
  /// least two bytes), so absurd values are rejected before anything is allocated.
  std::uint64_t count(std::string_view t, const char* what) const {
    const std::uint64_t n = u64(t, what);
    if (n > text_.size())
      fail(std::string(what) + " is " + std::to_string(n) + ", more than a file of " + std::to_string(text_.size()) +
               " bytes can hold",
           "the count is corrupt; re-export the mesh from gmsh");
    return n;
  }
  /// How many entries to reserve for a count: no more than the file could hold.
  std::size_t reserve_for(std::uint64_t n, std::size_t min_bytes_per_entry) const {
    return static_cast<std::size_t>(std::min<std::uint64_t>(n, text_.size() / min_bytes_per_entry + 1));
  }

  long line_no() const { return line_no_; }
  const std::string& path() const { return path_; }

 private:
  long last_line() const {
    // Number of the last line of the file (for messages at end of file).
    long n = 0;
    for (char c : text_) n += (c == '\n');
    if (!text_.empty() && text_.back() != '\n') ++n;
    return std::max(n, 1L);
  }

  const std::string& path_;
  const std::string& text_;
  std::size_t pos_ = 0;
  long line_no_ = 0;
};

/// Expect the line that closes a section whose entries have been read.
inline void expect_end(Reader& r, const char* end, const std::string& section_what, long header_line) {
  const std::string_view l = r.need("before " + std::string(end));
  if (l != end)
    r.fail(std::string("expected ") + end + " after the " + section_what + " announced on line " +
               std::to_string(header_line) + ", found " + quote(l),
           "the count on line " + std::to_string(header_line) +
               " does not match the number of entries; correct it or re-export the mesh");
}

/// A data line inside a section with a known count; a '$' line here means the count is too big.
inline std::string_view data_line(Reader& r, const char* section, std::uint64_t k, std::uint64_t n, const char* what,
                                  long header_line) {
  const std::string_view l = r.need("inside " + std::string(section) + " (after " + std::to_string(k) + " of " +
                                    std::to_string(n) + " " + what + ")");
  if (l[0] == '$')
    r.fail("found " + quote(l) + " after " + std::to_string(k) + " " + what + " but line " +
               std::to_string(header_line) + " announced " + std::to_string(n),
           "the count does not match the number of entries; correct it or re-export the mesh");
  return l;
}

}  // namespace fdem::mesh_detail
