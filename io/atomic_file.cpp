#include "io/atomic_file.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "core/error.hpp"

namespace fdem {

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  std::FILE* fp = std::fopen(tmp.c_str(), "w");
  if (!fp) throw OutputError("cannot write " + tmp + ": " + std::strerror(errno));
  const bool ok =
      std::fwrite(text.data(), 1, text.size(), fp) == text.size() && std::fflush(fp) == 0 && ::fsync(fileno(fp)) == 0;
  const int err = errno;
  if (std::fclose(fp) != 0 || !ok) {
    const int e = ok ? errno : err;
    std::remove(tmp.c_str());
    throw OutputError("cannot write " + tmp + ": " + std::strerror(e));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    std::remove(tmp.c_str());
    throw OutputError("cannot rename " + tmp + " to " + path + ": " + std::strerror(e));
  }
}

}  // namespace fdem
