#pragma once
/// \file threads.hpp
/// How many threads ecmor runs: one budget per process, shared by ecmor's own parallel loops and
/// the BLAS (docs/user-guide.md, "Threads").
///
/// The limit comes, first found first, from solver.threads (a run's ThreadLimitScope),
/// ECMOR_THREADS, OMP_NUM_THREADS, or else the cores this process may use (its CPU affinity
/// mask, capped by a cgroup CPU quota). A limit from the cores is adaptive: before each parallel
/// region ecmor counts the runnable threads of other processes (at most every 0.2 s, from
/// /proc) and uses only the cores they leave free, at least one, for the BLAS; its own loops
/// choose between that and the limit by measuring (loop_threads.hpp). Why: on a 2-core machine
/// beside two busy processes, a parallel region of two threads waits at every join for the thread
/// the scheduler has just taken off a core; the shipped configs took up to 45x their idle time, and
/// 1.9x at the median with the budget (docs/benchmarks.md, "Under load (issue 50)"). A limit set
/// explicitly is kept as given.
///
/// Nested parallelism: ecmor's regions do not nest, and BLAS calls made inside them run on
/// the calling thread (OpenBLAS's OpenMP build does so inside any active region; Eigen's own
/// parallel products are off, EIGEN_DONT_PARALLELIZE).

#include <string>

#include "ecmor/export.hpp"

namespace ecmor {

/// The process's thread budget and how it was used (thread_budget()).
struct ThreadBudget {
  int cores = 1;  ///< CPUs this process may run on: its affinity mask, capped by a CPU quota
  int limit = 1;  ///< the most threads ecmor runs at once, its loops and the BLAS together
  /// True when the count follows the machine's load (the limit came from the cores).
  bool adaptive = true;
  /// Where the limit came from: "cores", "ECMOR_THREADS", "OMP_NUM_THREADS" or "solver.threads".
  std::string source = "cores";
  int current = 1;           ///< the count chosen most recently
  int fewest_used = 0;       ///< the smallest count chosen since reset_thread_use() (0: none yet)
  int most_used = 0;         ///< the largest
  long load_reductions = 0;  ///< choices below the limit because other processes kept cores busy
};

/// The budget as it stands. The first call reads the environment.
/// \throws ConfigError when ECMOR_THREADS is neither a positive integer nor `auto`.
ECMOR_API ThreadBudget thread_budget();

/// The thread count for a parallel region (or a BLAS call) started now on the calling thread,
/// and sets it as that thread's OpenMP count (which OpenBLAS's OpenMP build follows). Inside a
/// parallel region: 1.
ECMOR_API int parallel_threads();

/// Forgets the counts chosen so far (the start of a run).
ECMOR_API void reset_thread_use();

/// An explicit limit of `threads` for the scope's lifetime (0: the scope changes nothing), taking
/// precedence over the environment; the previous budget is restored after it. `source` names it.
class ECMOR_API ThreadLimitScope {
 public:
  ThreadLimitScope(int threads, std::string source);
  ~ThreadLimitScope();
  ThreadLimitScope(const ThreadLimitScope&) = delete;
  ThreadLimitScope& operator=(const ThreadLimitScope&) = delete;

 private:
  bool m_active = false;
  int m_limit = 0;
  bool m_adaptive = true;
  std::string m_source;
};

/// Around a parallel region of ecmor's own (active = true): BLAS calls made inside it run on their
/// calling thread. OpenBLAS's OpenMP build does so by itself inside an active region; its pthreads
/// build has one thread count for the whole process, which the scope sets to 1 and restores.
class ECMOR_API SerialBlasScope {
 public:
  explicit SerialBlasScope(bool active);
  ~SerialBlasScope();
  SerialBlasScope(const SerialBlasScope&) = delete;
  SerialBlasScope& operator=(const SerialBlasScope&) = delete;

 private:
  int m_saved = 0;  // the pthreads build's count before the scope; 0: nothing to restore
};

/// The BLAS this process runs on, as it reports itself.
struct BlasInfo {
  /// OpenBLAS's configuration string ("OpenBLAS 0.3.21 DYNAMIC_ARCH NO_AFFINITY ..."), or
  /// "not OpenBLAS" when the library does not say.
  std::string name;
  std::string threading;  ///< "OpenMP", "pthreads", "sequential" or "unknown"
};
ECMOR_API BlasInfo blas_info();

namespace detail {

/// The pieces of the budget, exposed for tests.
/// Cores of a cgroup v2 `cpu.max` ("max 100000" -> 0: no quota; "150000 100000" -> 2) or of
/// cgroup v1's quota and period (quota <= 0: no quota); rounded up.
ECMOR_API int quota_cores(const std::string& cpu_max);
/// The runnable tasks of /proc/loadavg's fourth field ("0.64 1.61 1.86 3/79 8540" -> 3); -1 when
/// the text is not of that form.
ECMOR_API int runnable_tasks(const std::string& loadavg);
/// The count for `others` runnable threads of other processes: the cores they leave, in [1, limit].
ECMOR_API int threads_for_load(int cores, int limit, int others);
/// An environment setting of the thread count: a positive integer, or 0 for `auto`/empty.
/// \throws ConfigError naming `variable` and the rule otherwise.
ECMOR_API int parse_thread_setting(const std::string& variable, const std::string& value);
/// Reads the environment again on the next call (tests that change it).
ECMOR_API void reinitialise_thread_budget();

}  // namespace detail

}  // namespace ecmor
