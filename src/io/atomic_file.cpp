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
  AtomicFile file(path);
  file.write(text);
  file.commit();
}

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)), tmp_(path_ + ".tmp") {
  fp_ = std::fopen(tmp_.c_str(), "w");
  opened_ = fp_ != nullptr;
  if (!fp_) error_ = errno ? errno : EIO;
}

AtomicFile::~AtomicFile() {
  if (fp_) std::fclose(fp_);
  if (opened_ && !committed_) std::remove(tmp_.c_str());  // (only a file this one made)
}

bool AtomicFile::writable() {
  if (!fp_ && !error_) error_ = EBADF;  // (committed already)
  return !error_;
}

void AtomicFile::write(std::string_view bytes) {
  if (writable() && std::fwrite(bytes.data(), 1, bytes.size(), fp_) != bytes.size()) error_ = errno ? errno : EIO;
}

void AtomicFile::overwrite(long at, std::string_view bytes) {
  if (writable() && std::fseek(fp_, at, SEEK_SET) != 0) error_ = errno ? errno : EIO;
  write(bytes);
  if (writable() && std::fseek(fp_, 0, SEEK_END) != 0) error_ = errno ? errno : EIO;
}

void AtomicFile::commit() {
  if (writable() && (std::fflush(fp_) != 0 || ::fsync(fileno(fp_)) != 0)) error_ = errno ? errno : EIO;
  if (fp_ && std::fclose(fp_) != 0 && !error_) error_ = errno ? errno : EIO;
  fp_ = nullptr;
  if (error_) {
    if (opened_) std::remove(tmp_.c_str());
    opened_ = false;
    throw OutputError("cannot write " + tmp_ + ": " + write_failure(tmp_, error_));
  }
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    const int e = errno;
    std::remove(tmp_.c_str());
    opened_ = false;
    throw OutputError("cannot rename " + tmp_ + " to " + path_ + ": " + std::strerror(e));
  }
  committed_ = true;
}

}  // namespace fdem
