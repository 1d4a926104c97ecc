#include "io/atomic_file.hpp"

#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "core/error.hpp"

namespace fdem {

std::string write_failure(const std::string& path, int err) {
  namespace fs = std::filesystem;
  std::string reason = err ? std::strerror(err) : "the write failed";
  // The nearest folder that exists holds the file system the file is on.
  fs::path dir = fs::path(path).parent_path();
  std::error_code ec;
  while (!dir.empty() && !fs::is_directory(dir, ec)) dir = dir.parent_path();
  struct statvfs st {};
  if (statvfs(dir.empty() ? "." : dir.c_str(), &st) != 0) return reason;
  const double free = double(st.f_bavail) * double(st.f_frsize);
  // Less than a block of HDF5 data or a checkpoint's header: no write can go on.
  if (err != ENOSPC && free >= 65536) return reason;
  return reason + ": the disk is full (" + std::to_string(long(free / 1024)) + " kB free on the file system of " +
         (dir.empty() ? std::string(".") : dir.string()) +
         "). Fix: free space there, or copy the folder to a disk with room, then continue with --restart";
}

void write_file_atomically(const std::string& path, const std::string& text) {
  write_file_atomically(path, std::vector<std::string_view>{text});
}

void write_file_atomically(const std::string& path, const std::vector<std::string_view>& pieces) {
  const std::string tmp = path + ".tmp";
  std::FILE* fp = std::fopen(tmp.c_str(), "w");
  if (!fp) throw OutputError("cannot write " + tmp + ": " + write_failure(tmp, errno));
  bool ok = true;
  for (std::string_view piece : pieces) ok = ok && std::fwrite(piece.data(), 1, piece.size(), fp) == piece.size();
  ok = ok && std::fflush(fp) == 0 && ::fsync(fileno(fp)) == 0;
  const int err = errno;
  if (std::fclose(fp) != 0 || !ok) {
    const int e = ok ? errno : err;
    std::remove(tmp.c_str());
    throw OutputError("cannot write " + tmp + ": " + write_failure(tmp, e));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    std::remove(tmp.c_str());
    throw OutputError("cannot rename " + tmp + " to " + path + ": " + std::strerror(e));
  }
}

}  // namespace fdem
