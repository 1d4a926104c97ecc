#include "io/checkpoint.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

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

void write_checkpoint(const std::string& path, const CheckpointOut& out, CheckpointKind kind) {
  const std::string& payload = out.payload();
  std::string text(kHeader, '\0');
  const std::uint32_t version = kind == CheckpointKind::rank_file ? kRankFileVersion : kCheckpointVersion;
  const std::uint64_t size = payload.size(), sum = fnv1a64(payload.data(), payload.size());
  std::memcpy(&text[0], kMagic, 8);
  std::memcpy(&text[8], &version, 4);
  std::memcpy(&text[12], &size, 8);
  std::memcpy(&text[20], &sum, 8);
  text += payload;
  write_file_atomically(path, text);
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
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto bad = [&](const std::string& what) {
    throw InputError(path + ": not a usable fdem " + name + " (" + what + "). Fix: " +
                     (rank_file ? again : "restart from the other checkpoint in its folder (fdem keeps two)"));
  };
  if (text.size() < kHeader || std::memcmp(text.data(), kMagic, 8) != 0) bad("no FDEMCKPT header");
  std::uint32_t version = 0;
  std::uint64_t size = 0, sum = 0;
  std::memcpy(&version, &text[8], 4);
  std::memcpy(&size, &text[12], 8);
  std::memcpy(&sum, &text[20], 8);
  const std::uint32_t expected = rank_file ? kRankFileVersion : kCheckpointVersion;
  if (version != expected)
    throw InputError(path + ": " + name + " format version " + std::to_string(version) + ", this fdem reads version " +
                     std::to_string(expected) +
                     ". Fix: " + (rank_file ? again + " (this version's)" : "continue with the fdem that wrote it"));
  if (size != text.size() - kHeader)
    bad("payload of " + std::to_string(text.size() - kHeader) + " bytes, the header says " + std::to_string(size) +
        ": truncated?");
  if (fnv1a64(text.data() + kHeader, size) != sum) bad("checksum mismatch: the file was altered or damaged");
  return CheckpointIn(text.substr(kHeader), path);
}

}  // namespace fdem
