#pragma once
// Where the time loop runs (core/device_memory.hpp says what each backend's memory is).
#include <array>

#include "core/choice.hpp"

namespace fdem {

enum class Backend { cpu, debug, cuda };
template <>
struct ChoiceNames<Backend> {
  static constexpr std::array<const char*, 3> words{"cpu", "debug", "cuda"};
};

/// "cpu", "debug" or "cuda".
inline const char* backend_name(Backend b) {
  return name_of(b);
}

}  // namespace fdem
