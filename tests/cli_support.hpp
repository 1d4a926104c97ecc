#pragma once
// Helpers for the tests that run the real `fdem` executable (FDEM_EXE): run a command and
// capture its output and exit status, temporary folders, CSV reading.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

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

inline Outcome fdem(const std::string& args) {
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

inline std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(cell);
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

inline Csv read_csv(const fs::path& p) {
  Csv c;
  std::ifstream in(p);
  std::string line;
  if (!std::getline(in, line)) return c;
  c.header = split(line);
  while (std::getline(in, line)) {
    std::vector<double> row;
    for (const std::string& cell : split(line)) {
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
