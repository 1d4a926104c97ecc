#include "io/checkpoint.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string_view>

#include "io/atomic_file.hpp"

namespace fdem {

namespace {
constexpr char kMagic[8] = {'F', 'D', 'E', 'M', 'C', 'K', 'P', 'T'};
constexpr std::size_t kHeader = 8 + 4 + 8 + 8;
}  // namespace

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t h) {
  const unsigned char* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

void CheckpointOut::append(const void* data, std::size_t bytes) {
  if (bytes == 0) return;
  const char* p = static_cast<const char*>(data);
  size_ += bytes;
  if (bytes >= kOwnPiece) {  // an array of its own, at its size
    if (sink_) {
      spill();
      sink_(std::string_view(p, bytes));  // (not copied at all)
      return;
    }
    pieces_.emplace_back(p, bytes);
    last_open_ = false;
    return;
  }
  // Small values fill a piece until it holds kOwnPiece bytes; the next starts a new one. A
  // piece grows as a string does while it is small (an array's length alone between two
  // arrays), and to its full size at once from 64 kB on, so that none doubles past it.
  if (!last_open_ || pieces_.back().size() >= kOwnPiece) {
    if (sink_) spill();
    pieces_.emplace_back(), last_open_ = true;
  }
  std::string& piece = pieces_.back();
  constexpr std::size_t kGrown = kOwnPiece / 16;
  if (piece.size() + bytes > piece.capacity() && piece.size() + bytes > kGrown)
    piece.reserve(std::max(piece.size() + bytes, kOwnPiece + kOwnPiece / 8));
  piece.append(p, bytes);
}

std::string CheckpointOut::payload() const {
  std::string all;
  std::size_t held = 0;
  for (const std::string& piece : pieces_) held += piece.size();
  all.reserve(held);
  for (const std::string& piece : pieces_) all += piece;
  return all;
}

std::size_t CheckpointOut::capacity() const {
  std::size_t bytes = 0;
  for (const std::string& piece : pieces_) bytes += piece.capacity();
  return bytes;
}

void CheckpointOut::spill() {
  for (const std::string& piece : pieces_) sink_(piece);
  pieces_.clear();
  last_open_ = false;
}

CheckpointFile::CheckpointFile(const std::string& path, CheckpointKind kind)
    : file_(path),
      version_(kind == CheckpointKind::rank_file ? kRankFileVersion : kCheckpointVersion),
      sum_(kFnvSeed),
      out_([this](std::string_view bytes) { write(bytes); }) {
  file_.write(std::string(kHeader, '\0'));  // (its size and sum once the payload is written)
}

void CheckpointFile::write(std::string_view bytes) {
  sum_ = fnv1a64(bytes.data(), bytes.size(), sum_);
  file_.write(bytes);
}

void CheckpointFile::commit() {
  out_.spill();
  std::string header(kHeader, '\0');
  const std::uint64_t size = out_.size();
  std::memcpy(&header[0], kMagic, 8);
  std::memcpy(&header[8], &version_, 4);
  std::memcpy(&header[12], &size, 8);
  std::memcpy(&header[20], &sum_, 8);
  file_.overwrite(0, header);
  file_.commit();
}

void write_checkpoint(const std::string& path, const CheckpointOut& out, CheckpointKind kind) {
  CheckpointFile file(path, kind);
  for (const std::string& piece : out.pieces()) file.out().put_bytes(piece);
  file.commit();
}

CheckpointIn read_checkpoint(const std::string& path, CheckpointKind kind) {
  const bool rank_file = kind == CheckpointKind::rank_file;
  const std::string name = rank_file ? "rank file" : "checkpoint";
  const std::string again = "write the rank files again with fdem partition";
  const std::string where = rank_file
                                ? "give --partitioned the folder fdem partition -o wrote (rank_<r>.fdp for every rank)"
                                : "give a checkpoint file or the run's folder";
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path + ": is a folder, not a " + name + ". Fix: " + where);
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    if (std::filesystem::exists(path, ec))
      throw CannotOpen(path + ": cannot open the " + name + " (" + std::strerror(err) +
                       "). Fix: make it readable (chmod u+r) for the user who runs fdem");
    throw InputError(path + ": cannot open the " + name + " (" + std::strerror(err) + "). Fix: " + where);
  }
  auto bad = [&](const std::string& what) {
    throw InputError(path + ": not a usable fdem " + name + " (" + what + "). Fix: " +
                     (rank_file ? again : "restart from the other checkpoint in its folder (fdem keeps two)"));
  };
  // The header, then the payload straight into a string of its size: the file is held once.
  char header[kHeader];
  in.seekg(0, std::ios::end);
  const std::streamoff file_size = in.tellg();
  in.seekg(0, std::ios::beg);
  if (!in || file_size < std::streamoff(kHeader) || !in.read(header, kHeader) || std::memcmp(header, kMagic, 8) != 0)
    bad("no FDEMCKPT header");
  std::uint32_t version = 0;
  std::uint64_t size = 0, sum = 0;
  std::memcpy(&version, &header[8], 4);
  std::memcpy(&size, &header[12], 8);
  std::memcpy(&sum, &header[20], 8);
  const std::uint32_t expected = rank_file ? kRankFileVersion : kCheckpointVersion;
  if (version != expected)
    throw InputError(path + ": " + name + " format version " + std::to_string(version) + ", this fdem reads version " +
                     std::to_string(expected) +
                     ". Fix: " + (rank_file ? again + " (this version's)" : "continue with the fdem that wrote it"));
  const std::uint64_t held = std::uint64_t(file_size) - kHeader;
  if (size != held)
    bad("payload of " + std::to_string(held) + " bytes, the header says " + std::to_string(size) + ": truncated?");
  std::string payload(held, '\0');
  if (!in.read(payload.data(), std::streamsize(held))) bad("the payload could not be read whole");
  if (fnv1a64(payload.data(), held) != sum) bad("checksum mismatch: the file was altered or damaged");
  return CheckpointIn(std::move(payload), path);
}

}  // namespace fdem
