// libFuzzer target: the bytes are a whole .msh file, read by fdem::read_msh as `fdem run` does
// (load_mesh -> read_msh, which validates the mesh). The documented outcome for bad input is
// fdem::InputError; anything else (another exception, a crash, a sanitizer report, a hang, a huge
// allocation) is a bug. A mesh that is accepted must also pass validate_mesh again and use
// every vertex it keeps; an InputError must name the file.
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/mesh_io.hpp"

namespace {

/// read_msh takes a path: the input goes into an in-memory file (memfd) named by its
/// /proc/self/fd path, or, where memfd is missing, into a per-process file under /tmp.
struct InputFile {
  int fd = -1;
  std::string path;
  InputFile() {
    fd = memfd_create("fdem_fuzz_mesh", 0);
    if (fd >= 0) {
      path = "/proc/self/fd/" + std::to_string(fd);
    } else {
      path = "/tmp/fdem_fuzz_mesh_" + std::to_string(getpid()) + ".msh";
    }
  }
  ~InputFile() {
    if (fd >= 0)
      close(fd);
    else
      std::remove(path.c_str());
  }
  void write(const std::uint8_t* data, std::size_t size) {
    if (fd >= 0) {
      if (ftruncate(fd, 0) != 0) std::abort();
      std::size_t done = 0;
      while (done < size) {
        const ssize_t w = pwrite(fd, data + done, size - done, static_cast<off_t>(done));
        if (w <= 0) std::abort();
        done += static_cast<std::size_t>(w);
      }
      return;
    }
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f || (size && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) std::abort();
  }
};

[[noreturn]] void invariant_broken(const char* what) {
  std::fprintf(stderr, "fuzz_mesh: read_msh accepted a mesh that %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static InputFile file;
  file.write(data, size);
  fdem::Mesh mesh;
  try {
    mesh = fdem::read_msh(file.path, 1.0);
  } catch (const fdem::InputError& e) {
    // The documented answer to bad input; it must name the file.
    if (std::string(e.what()).find(file.path) == std::string::npos) {
      std::fprintf(stderr, "fuzz_mesh: an InputError does not name the file: %s\n", e.what());
      std::abort();
    }
    return 0;
  }
  // Accepted: the checks the solver relies on must hold.
  try {
    fdem::validate_mesh(mesh);
  } catch (const fdem::InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    invariant_broken("validate_mesh rejects");
  }
  if (mesh.tets.empty()) invariant_broken("has no tetrahedra");
  std::vector<char> used(mesh.vertices.size(), 0);
  for (const auto& t : mesh.tets)
    for (int v : t) {
      if (v < 0 || static_cast<std::size_t>(v) >= mesh.vertices.size()) invariant_broken("has a vertex out of range");
      used[static_cast<std::size_t>(v)] = 1;
    }
  for (char u : used)
    if (!u) invariant_broken("keeps a vertex no tetrahedron uses");
  if (mesh.source != file.path) invariant_broken("does not name its file in mesh.source");
  return 0;
}
