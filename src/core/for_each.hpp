#pragma once
// A host loop: body(i) for i in [0, n), spread over OpenMP threads (the model build and the
// host broad phase; the time loop uses core/forall.hpp).
// Bodies write only to data owned by index i (or to a colour class whose members
// share no node), so the result does not depend on the thread count.
#include <cstddef>

namespace fdem {

template <class Body>
void for_each(std::size_t n, Body&& body) {
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) body(static_cast<std::size_t>(i));
}

}  // namespace fdem
