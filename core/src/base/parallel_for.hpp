#pragma once
// parallel_for.hpp: an OpenMP loop that carries exceptions out of the parallel region. Private to
// core (frequency_response.cpp, quadrature.cpp).
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <exception>

#include "ecmor/base/types.hpp"

namespace ecmor::detail {

/// Set once a solver exists whose factorisations and solves are collective MPI operations (the
/// PETSc backend): they must be entered by one thread per rank in the same order, so every
/// parallel_for runs serially from then on (shifted_solver.cpp).
extern std::atomic<bool> g_serial_solves;

/// Runs body(i) for i in [0, n) in parallel (OpenMP, dynamic schedule). An exception thrown by an
/// iteration never leaves the parallel region: the first one is captured, the remaining iterations
/// are skipped, and it is rethrown after the region.
template <class Body>
inline void parallel_for(Index n, int threads, Body&& body) {
  // A parallel region for one or two frequencies costs more (thread wake-up) than it saves.
  const int nt = static_cast<int>(
      std::min<Index>(threads > 0 ? threads : omp_get_max_threads(), std::max<Index>(n / 2, 1)));
  if (nt <= 1 || g_serial_solves.load(std::memory_order_relaxed)) {
    for (Index i = 0; i < n; ++i) body(i);
    return;
  }
  std::exception_ptr error;
  std::atomic<bool> failed{false};
#pragma omp parallel for schedule(dynamic) num_threads(nt)
  for (Index i = 0; i < n; ++i) {
    if (failed.load(std::memory_order_relaxed)) continue;
    try {
      body(i);
    } catch (...) {
#pragma omp critical(ecmor_frequency_response_error)
      {
        if (!error) error = std::current_exception();
      }
      failed.store(true, std::memory_order_relaxed);
    }
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace ecmor::detail
