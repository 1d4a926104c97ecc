#pragma once
// Helpers for the tests that run the real `fdem` executable (FDEM_EXE): run a command and
// capture its output and exit status, temporary folders, CSV and HDF5 reading.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/format.hpp"

namespace cli_test {

namespace fs = std::filesystem;

inline const std::string kExe = FDEM_EXE;
inline const fs::path kData = FDEM_TEST_DATA;
// One quiet OpenMP thread per run, whatever the caller's environment.
inline const std::string kEnv = "OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE ";

struct Outcome {
  int code = -1;     // exit status, -1 if not exited normally
  std::string text;  // stdout and stderr together
};

inline std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

inline Outcome run_cmd(const std::string& cmd) {
  Outcome o;
  FILE* pipe = popen((cmd + " 2>&1").c_str(), "r");
  if (!pipe) return o;
  char buf[1024];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) o.text.append(buf, n);
  const int status = pclose(pipe);
  if (status != -1 && WIFEXITED(status)) o.code = WEXITSTATUS(status);
  return o;
}

inline Outcome run_fdem(const std::string& args) {
  return run_cmd(kEnv + quote(kExe) + " " + args);
}

inline bool has(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

/// A fresh, empty temporary folder for this test (removed when the object goes).
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) {
    path = fs::temp_directory_path() / ("fdem_test_cli_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  std::vector<std::string> bad;  // cells that are not finite numbers
};

inline Csv read_csv(const fs::path& p) {
  Csv c;
  std::ifstream in(p);
  std::string line;
  if (!std::getline(in, line)) return c;
  c.header = fdem::split_csv(line);
  while (std::getline(in, line)) {
    std::vector<double> row;
    for (const std::string& cell : fdem::split_csv(line)) {
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      if (cell.empty() || *end != '\0' || !std::isfinite(v)) c.bad.push_back(cell);
      row.push_back(v);
    }
    c.rows.push_back(row);
  }
  return c;
}

inline int column(const Csv& c, const std::string& name) {
  for (std::size_t i = 0; i < c.header.size(); ++i)
    if (c.header[i] == name) return int(i);
  return -1;
}

inline std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Raw bytes of a dataset of an open HDF5 file (read in its own type), or "" if absent.
inline std::string dataset_bytes(hid_t file, const std::string& path) {
  if (H5Lexists(file, path.c_str(), H5P_DEFAULT) <= 0) return "";
  const hid_t ds = H5Dopen2(file, path.c_str(), H5P_DEFAULT);
  const hid_t type = H5Dget_type(ds);
  const hid_t space = H5Dget_space(ds);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  std::string bytes(std::size_t(n) * H5Tget_size(type), '\0');
  if (n > 0) H5Dread(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data());
  H5Sclose(space);
  H5Tclose(type);
  H5Dclose(ds);
  return bytes;
}

/// A dataset of T (its values as stored: double or int32) of the file at `file`; empty if
/// the file or the dataset is absent.
template <class T>
std::vector<T> h5_values(const fs::path& file, const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return {};
  const std::string bytes = dataset_bytes(f, path);
  H5Fclose(f);
  std::vector<T> out(bytes.size() / sizeof(T));
  if (!out.empty()) std::memcpy(out.data(), bytes.data(), out.size() * sizeof(T));
  return out;
}

/// fields.h5's x, u, v, stress, von_mises ...
inline std::vector<double> h5_doubles(const fs::path& file, const std::string& path) {
  return h5_values<double>(file, path);
}

/// A copy of the scene `base` in `dir` with each `from` replaced by its `to` (one occurrence,
/// which must exist).
inline fs::path scene_variant(const fs::path& base, const fs::path& dir, const std::string& name,
                              const std::vector<std::pair<std::string, std::string>>& edits) {
  std::string text = slurp(base);
  for (const auto& [from, to] : edits) {
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  }
  const fs::path p = dir / (name + ".yaml");
  std::ofstream(p) << text;
  return p;
}

/// The path of mpiexec, or "" if there is none.
inline std::string find_mpiexec() {
  const Outcome o = run_cmd("command -v mpiexec");
  if (o.code != 0) return "";
  std::string p = o.text;
  while (!p.empty() && (p.back() == '\n' || p.back() == '\r')) p.pop_back();
  return p;
}

// Open MPI refuses root without these; -n 2 may exceed the slots of a small machine.
inline const std::string kMpiEnv =
    "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 "
    "OMPI_MCA_mpi_yield_when_idle=1 ";

}  // namespace cli_test
