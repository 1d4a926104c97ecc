#pragma once
// Checkpoint files: a binary payload behind a header that names the format, its version, the
// payload size and a checksum, so that a truncated or altered file is refused rather than read.
//
//   bytes 0-7   "FDEMCKPT"
//         8-11  format version (uint32)
//        12-19  payload size in bytes (uint64)
//        20-27  FNV-1a 64 of the payload (uint64)
//        28-    payload: the values in the order they were put, native byte order
//
// A file is written to <path>.tmp, flushed to disk and renamed (io/atomic_file), so a crash
// while writing leaves the earlier checkpoints untouched.
#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/error.hpp"
#include "io/atomic_file.hpp"

namespace fdem {

// 2: CE6 state stores its mode beside the damage. 3: CE6 ids are colour order (model/build.cpp),
// so a model built now numbers its CE6s, their states and broken_ce6.csv's ids anew. 4: each
// part of the state writes its own section (Solver::save_state). 5: the ledger keeps the
// contact energy, and each contact pair its overlap zero. 6: a tet's contact flags hold its
// opened faces too (contact/bonded.hpp). 7: boundary conditions' reactions, works and face
// loads. 8: a grown rank model (saved with the state) holds each tet's material and CE6's law.
// 9: and each CE6's strength factor. 10: and each tet's factor on E. 11: and each tet's joint.
// 12: a monitor row holds the history entries' columns, and a rank model their nodes and tets.
// 13: and each tet's volume group. 14: the excavation's stages done and forces, and each tet's
// excavation stage. 15: the count of contact ghost gatherings that added no tet. 16: each rank's
// file starts with its layout in global numbering (solver/saved_layout.hpp), so that a run on
// another rank count can read it; a flag says whether the rank model grown is saved. 17: a kept
// frame's CE6s hold their damage only.
// Rank files: 4 boundary conditions, 5 materials, 6 CE6 strength factors, 7 tet factors on E,
// 8 tets' joints, 9 the nodes and tets that history entries follow, 10 tets' volume groups,
// 11 tets' excavation stages.
constexpr std::uint32_t kCheckpointVersion = 17;
constexpr std::uint32_t kRankFileVersion = 11;

/// Collects values for a checkpoint payload. It holds the payload in pieces: an array of
/// kOwnPiece bytes or more is a piece of its own, at its exact size, and the small values between
/// fill pieces of about that size. A payload held then takes about its size in memory, not
/// the up to three times one doubling string took; with a sink (CheckpointFile) it holds
/// about one piece.
class CheckpointOut {
 public:
  static constexpr std::size_t kOwnPiece = std::size_t(1) << 20;  // bytes
  /// Where finished pieces go at once, instead of being held (CheckpointFile's).
  using Sink = std::function<void(std::string_view)>;

  CheckpointOut() = default;
  explicit CheckpointOut(Sink sink) : sink_(std::move(sink)) {}
  // Not copied: a copy would give the same file bytes its own count.
  CheckpointOut(const CheckpointOut&) = delete;
  CheckpointOut& operator=(const CheckpointOut&) = delete;
  CheckpointOut(CheckpointOut&&) = default;
  CheckpointOut& operator=(CheckpointOut&&) = default;

  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>, "only plain values go into a checkpoint");
    append(&value, sizeof(T));
  }
  template <class T>
  void put(const std::vector<T>& values) {
    static_assert(std::is_trivially_copyable_v<T>, "only plain values go into a checkpoint");
    put(std::uint64_t(values.size()));
    append(values.data(), values.size() * sizeof(T));
  }
  void put(const std::string& s) {
    put(std::uint64_t(s.size()));
    append(s.data(), s.size());
  }
  void put(const std::vector<std::string>& v) {
    put(std::uint64_t(v.size()));
    for (const std::string& s : v) put(s);
  }
  /// Bytes as they are, without a length (another payload's, put whole).
  void put_bytes(std::string_view bytes) { append(bytes.data(), bytes.size()); }
  /// Bytes put so far.
  std::size_t size() const { return size_; }
  /// The payload as one string, joined (for a payload sent or read back in memory; with a
  /// sink, what it has not been given yet).
  std::string payload() const;
  /// The payload's pieces held, in order.
  const std::vector<std::string>& pieces() const { return pieces_; }
  /// Bytes the pieces hold reserved: the size plus the slack of the last piece of small values.
  std::size_t capacity() const;
  /// Gives the sink every piece held (a file about to be finished).
  void spill();

 private:
  void append(const void* data, std::size_t bytes);
  Sink sink_;
  std::vector<std::string> pieces_;
  bool last_open_ = false;  // the last piece takes small values (it is not an array's own)
  std::size_t size_ = 0;
};

/// Reads values back in the order they were put; a short or inconsistent payload throws
/// InputError naming the file.
class CheckpointIn {
 public:
  CheckpointIn(std::string payload, std::string file) : buf_(std::move(payload)), file_(std::move(file)) {}
  template <class T>
  void get(T& value) {
    static_assert(std::is_trivially_copyable_v<T>, "only plain values come from a checkpoint");
    need(sizeof(T), "a value");
    std::memcpy(&value, buf_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
  }
  template <class T>
  void get(std::vector<T>& values) {
    static_assert(std::is_trivially_copyable_v<T>, "only plain values come from a checkpoint");
    std::uint64_t n = 0;
    get(n);
    if (n > (buf_.size() - pos_) / (sizeof(T) ? sizeof(T) : 1)) fail("an array longer than the file");
    values.resize(n);
    if (n > 0)  // (an empty vector's data() may be null, which memcpy may not be given)
      std::memcpy(static_cast<void*>(values.data()), buf_.data() + pos_, n * sizeof(T));
    pos_ += n * sizeof(T);
  }
  void get(std::string& s) {
    std::uint64_t n = 0;
    get(n);
    need(n, "a string");
    s.assign(buf_.data() + pos_, n);
    pos_ += n;
  }
  void get(std::vector<std::string>& v) {
    std::uint64_t n = 0;
    get(n);
    if (n > buf_.size() - pos_) fail("a list longer than the file");
    v.resize(n);
    for (std::string& s : v) get(s);
  }
  /// Bytes not read yet.
  std::size_t remaining() const { return buf_.size() - pos_; }
  /// Throws unless every byte was read (a payload from another layout).
  void finish() const {
    if (pos_ != buf_.size()) fail(std::to_string(buf_.size() - pos_) + " bytes left over");
  }
  /// A value read that contradicts the run being continued.
  [[noreturn]] void mismatch(const std::string& what) const {
    throw InputError(file_ + ": this checkpoint belongs to another model or scene (" + what +
                     "). Fix: restart with the scene and mesh of the interrupted run, unchanged except for "
                     "solver.end and output");
  }
  const std::string& file() const { return file_; }

 private:
  void need(std::uint64_t n, const char* what) const {
    if (n > buf_.size() - pos_) fail(std::string("ends inside ") + what);
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(file_ + ": checkpoint payload does not match this version of fdem (" + what +
                     "). Fix: restart with the fdem that wrote it, or from an older checkpoint");
  }
  std::string buf_;
  std::string file_;
  std::size_t pos_ = 0;
};

constexpr std::uint64_t kFnvSeed = 1469598103934665603ull;

/// FNV-1a 64 of bytes (used for the payload checksum and run fingerprints); pass the previous
/// result as seed to hash a stream piece by piece.
std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t seed = kFnvSeed);

/// What a file in the checkpoint format holds (a run's checkpoint, or a rank file of fdem
/// partition), so that its errors name it and give its own fix, and its format version.
enum class CheckpointKind { checkpoint, rank_file };
/// Writes header and payload to path atomically; throws OutputError.
void write_checkpoint(const std::string& path, const CheckpointOut& out,
                      CheckpointKind kind = CheckpointKind::checkpoint);

/// A checkpoint file written while its values are put (out()): each finished piece of the
/// payload goes to the file at once, and an array of kOwnPiece bytes or more straight from
/// the caller's memory, so that the writer holds about one piece, not the whole payload.
/// commit() writes the header and renames the file over path atomically (io/atomic_file),
/// throwing OutputError for any failure since the start; a file not committed is removed.
class CheckpointFile {
 public:
  explicit CheckpointFile(const std::string& path, CheckpointKind kind = CheckpointKind::checkpoint);
  CheckpointFile(const CheckpointFile&) = delete;
  CheckpointFile& operator=(const CheckpointFile&) = delete;
  CheckpointOut& out() { return out_; }
  void commit();

 private:
  void write(std::string_view bytes);
  AtomicFile file_;
  std::uint32_t version_;
  std::uint64_t sum_;  // FNV-1a of the payload so far
  CheckpointOut out_;
};

/// Reads and verifies a checkpoint file; throws InputError naming the file, what is wrong with
/// it and the fix.
/// A checkpoint or rank file that is there but cannot be opened (permissions): not damaged, so a
/// restart stops instead of falling back to (and removing) it.
struct CannotOpen : InputError {
  using InputError::InputError;
};

CheckpointIn read_checkpoint(const std::string& path, CheckpointKind kind = CheckpointKind::checkpoint);

}  // namespace fdem
