#pragma once
// parallel_for.hpp: an OpenMP loop that carries exceptions out of the parallel region. Private to
// core (frequency_response.cpp, quadrature.cpp, band_error_estimate.cpp).
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>

#include "base/loop_threads.hpp"
#include "ecmor/base/types.hpp"

namespace ecmor::detail {

/// Set once a solver exists whose factorisations and solves are collective MPI operations (the
/// PETSc backend): they must be entered by one thread per rank in the same order, so every
/// parallel_for runs serially from then on (shifted_solver.cpp).
extern std::atomic<bool> g_serial_solves;

/// Runs body(i) for i in [0, n) in parallel (OpenMP, dynamic schedule) with `threads` threads, or
/// for threads <= 0 as many as the process's budget gives this loop (LoopThreads: one per call
/// site, since each call site's lambda is its own Body type). An exception thrown by an iteration
/// never leaves the parallel region: the first one is captured, the remaining iterations are
/// skipped, and it is rethrown after the region.
template <class Body>
inline void parallel_for(Index n, int threads, Body&& body) {
  static LoopThreads loop;
  const int chosen = threads > 0 ? threads : loop.choose();
  // A parallel region for one or two frequencies costs more (thread wake-up) than it saves.
  const int nt = static_cast<int>(std::min<Index>(chosen, std::max<Index>(n / 2, 1)));
  const bool measured = threads <= 0 && nt == chosen;
  const auto start = std::chrono::steady_clock::now();
  auto record = [&] {
    if (measured)
      loop.record(chosen, n,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  };
  if (nt <= 1 || g_serial_solves.load(std::memory_order_relaxed)) {
    for (Index i = 0; i < n; ++i) body(i);
    record();
    return;
  }
  std::exception_ptr error;
  std::atomic<bool> failed{false};
  const SerialBlasScope serial_blas(true);
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
  record();
}

}  // namespace ecmor::detail
