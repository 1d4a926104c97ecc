#pragma once
// Errors a user can act on: what went wrong, where (file, key, element), and the fix.
#include <stdexcept>
#include <string>

namespace fdem {

/// Bad input: scene file, mesh file or command line. Exit code 2.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The run itself failed (instability, inverted element). Exit code 3.
struct RunError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The run was stopped by a signal (SIGTERM, SIGINT) after writing a checkpoint; continue it
/// with `fdem run scene --restart <folder>`. Exit code 5.
struct Interrupted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Writing results failed (disk full, permissions, a broken file). Exit code 4.
struct OutputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace fdem
