#pragma once
// Whole files written so that a reader (or a run resumed after a crash) sees either the
// old file or the new one, never half of one: written to <path>.tmp, flushed to disk, renamed.
#include <cstdio>
#include <string>
#include <string_view>

namespace fdem {

/// Writes text to path atomically; throws OutputError naming the file and the system's reason,
/// removing the temporary file.
void write_file_atomically(const std::string& path, const std::string& text);

/// A file written piece by piece to <path>.tmp and renamed over path once whole (commit). A
/// failure to open or write is kept, and commit throws it: the caller finishes what it
/// was doing (on several ranks, the same calls on every rank) before it learns of it.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path);
  ~AtomicFile();  // removes the temporary file unless committed
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  void write(std::string_view bytes);
  /// Writes bytes over those already written from byte `at` on (a header known at the end).
  void overwrite(long at, std::string_view bytes);
  /// Flushes, syncs and renames; throws OutputError naming the file and the system's reason,
  /// removing the temporary file.
  void commit();

 private:
  /// Whether the file is still open and nothing failed (a write after commit is EBADF).
  bool writable();
  std::string path_, tmp_;
  std::FILE* fp_ = nullptr;
  int error_ = 0;        // errno of the first failure
  bool opened_ = false;  // this object made <path>.tmp
  bool committed_ = false;
};

/// Why writing `path` failed with errno `err`, for messages: the system's reason and, where the
/// file system holding it has no room left, that the disk is full, how much is free and the fix.
std::string write_failure(const std::string& path, int err);

}  // namespace fdem
