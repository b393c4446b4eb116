// threads.cpp: see threads.hpp.
#include "ecmor/base/threads.hpp"

#include <dirent.h>
#include <dlfcn.h>
#include <omp.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <sstream>

#include "ecmor/base/error.hpp"

namespace ecmor {

namespace detail {

int quota_cores(const std::string& cpu_max) {
  std::istringstream in(cpu_max);
  std::string quota;
  double period = 0.0;
  if (!(in >> quota >> period) || quota == "max" || period <= 0.0) return 0;
  char* end = nullptr;
  const double q = std::strtod(quota.c_str(), &end);
  if (end == quota.c_str() || q <= 0.0) return 0;
  return std::max(1, static_cast<int>(std::ceil(q / period - 1e-9)));
}

int runnable_tasks(const std::string& loadavg) {
  std::istringstream in(loadavg);
  std::string a, b, c, tasks;
  if (!(in >> a >> b >> c >> tasks)) return -1;
  const auto slash = tasks.find('/');
  if (slash == std::string::npos || slash == 0) return -1;
  char* end = nullptr;
  const long n = std::strtol(tasks.c_str(), &end, 10);
  if (end != tasks.c_str() + slash || n < 0) return -1;
  return static_cast<int>(n);
}

int threads_for_load(int cores, int limit, int others) {
  return std::clamp(cores - std::max(others, 0), 1, std::max(limit, 1));
}

int parse_thread_setting(const std::string& variable, const std::string& value) {
  if (value.empty() || value == "auto") return 0;
  char* end = nullptr;
  errno = 0;
  const long n = std::strtol(value.c_str(), &end, 10);
  const bool digits_only = value.find_first_not_of("0123456789") == std::string::npos;
  if (!digits_only || end != value.c_str() + value.size() || errno != 0 || n < 1 || n > 65536)
    throw ConfigError(variable + "=\"" + value +
                      "\": the thread count must be a whole number in [1, 65536] or `auto`");
  return static_cast<int>(n);
}

}  // namespace detail

namespace {

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return in ? text.str() : std::string();
}

// The CPU quota of this process's cgroup and its parents (v2: cpu.max; v1: cfs quota / period),
// the smallest found, in cores; 0 when there is none.
int cgroup_quota_cores() {
  int best = 0;
  auto consider = [&](int cores) {
    if (cores > 0) best = best > 0 ? std::min(best, cores) : cores;
  };
  std::istringstream groups(read_file("/proc/self/cgroup"));
  for (std::string line; std::getline(groups, line);) {
    if (line.rfind("0::", 0) == 0) {  // cgroup v2: walk from the process's group to the root
      for (std::string path = line.substr(3);;) {
        consider(detail::quota_cores(read_file("/sys/fs/cgroup" + path + "/cpu.max")));
        if (path.empty() || path == "/") break;
        path = path.substr(0, path.rfind('/'));
      }
    }
  }
  const std::string v1 = "/sys/fs/cgroup/cpu,cpuacct/";
  const std::string quota = read_file(v1 + "cpu.cfs_quota_us");
  if (!quota.empty())
    consider(detail::quota_cores(quota + " " + read_file(v1 + "cpu.cfs_period_us")));
  return best;
}

int usable_cores() {
  int cores = 0;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) cores = CPU_COUNT(&set);
  if (cores <= 0) cores = static_cast<int>(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
  const int quota = cgroup_quota_cores();
  return quota > 0 ? std::min(cores, quota) : cores;
}

// Threads of this process that are runnable now (state R in /proc/self/task/*/stat).
int own_runnable_threads() {
  DIR* dir = opendir("/proc/self/task");
  if (!dir) return 1;
  int running = 0;
  while (const dirent* e = readdir(dir)) {
    if (e->d_name[0] == '.') continue;
    const std::string stat = read_file(std::string("/proc/self/task/") + e->d_name + "/stat");
    const auto paren = stat.rfind(')');
    if (paren != std::string::npos && paren + 2 < stat.size() && stat[paren + 2] == 'R') ++running;
  }
  closedir(dir);
  return std::max(running, 1);
}

using Clock = std::chrono::steady_clock;
constexpr std::chrono::milliseconds kResample{200};

// OpenBLAS's own entry points, when the BLAS is OpenBLAS (looked up, not linked: any BLAS works).
struct OpenBlas {
  char* (*get_config)() = nullptr;
  int (*get_parallel)() = nullptr;  // 0 sequential, 1 pthreads, 2 OpenMP
  void (*set_num_threads)(int) = nullptr;
  int (*get_num_threads)() = nullptr;
  OpenBlas() {
    get_num_threads = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
    get_config = reinterpret_cast<char* (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_config"));
    get_parallel = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_parallel"));
    set_num_threads =
        reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  }
  bool pthreads() const { return get_parallel && get_parallel() == 1; }
};

const OpenBlas& openblas() {
  static const OpenBlas o;
  return o;
}

class Budget {
 public:
  static Budget& instance() {
    static Budget b;
    return b;
  }

  ThreadBudget get() {
    std::lock_guard<std::mutex> lock(m_mutex);
    init();
    return m_budget;
  }

  int choose() {
    std::lock_guard<std::mutex> lock(m_mutex);
    init();
    ThreadBudget& b = m_budget;
    if (b.adaptive) {
      const auto now = Clock::now();
      if (!m_sampled || now - m_last_sample >= kResample) {
        const int others = others_runnable();
        // A busy sample lowers the count only when the one before it was busy too, so that a
        // short-lived process does not halve the threads; a free core is taken at once.
        const int counted = m_sampled ? std::min(others, m_previous_others) : others;
        m_previous_others = others;
        m_last_sample = now;
        m_sampled = true;
        b.current = detail::threads_for_load(b.cores, b.limit, counted);
      }
    } else {
      b.current = b.limit;
    }
    if (b.current < b.limit) ++b.load_reductions;
    b.fewest_used = b.fewest_used > 0 ? std::min(b.fewest_used, b.current) : b.current;
    b.most_used = std::max(b.most_used, b.current);
    omp_set_num_threads(b.current);
    if (openblas().set_num_threads && openblas().pthreads() && b.current != m_blas_threads) {
      openblas().set_num_threads(b.current);
      m_blas_threads = b.current;
    }
    return b.current;
  }

  void reinitialise() {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_initialised = false;
    m_sampled = false;
  }

  void reset_use() {
    std::lock_guard<std::mutex> lock(m_mutex);
    init();
    m_budget.fewest_used = m_budget.most_used = 0;
    m_budget.load_reductions = 0;
  }

  // Sets an explicit limit (threads > 0) or restores a saved one; returns the previous state.
  void set(int limit, bool adaptive, const std::string& source, int* old_limit, bool* old_adaptive,
           std::string* old_source) {
    std::lock_guard<std::mutex> lock(m_mutex);
    init();
    *old_limit = m_budget.limit;
    *old_adaptive = m_budget.adaptive;
    *old_source = m_budget.source;
    m_budget.limit = limit;
    m_budget.adaptive = adaptive;
    m_budget.source = source;
    m_budget.current = adaptive ? std::min(m_budget.current, limit) : limit;
    m_sampled = false;
  }

 private:
  void init() {
    if (m_initialised) return;
    ThreadBudget b;
    b.cores = usable_cores();
    const char* ecmor_threads = std::getenv("ECMOR_THREADS");
    const int from_ecmor =
        ecmor_threads ? detail::parse_thread_setting("ECMOR_THREADS", ecmor_threads) : 0;
    const char* omp_threads = std::getenv("OMP_NUM_THREADS");
    if (from_ecmor > 0) {
      b.limit = from_ecmor;
      b.adaptive = false;
      b.source = "ECMOR_THREADS";
    } else if (omp_threads && *omp_threads) {
      // OpenMP has parsed it (a list "4,2" gives its first level); an invalid value it ignored.
      b.limit = std::max(1, omp_get_max_threads());
      b.adaptive = false;
      b.source = "OMP_NUM_THREADS";
    } else {
      b.limit = b.cores;
      b.adaptive = true;
      b.source = "cores";
    }
    b.current = b.limit;
    m_online = static_cast<int>(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
    m_budget = b;
    m_initialised = true;  // after parsing: a bad ECMOR_THREADS throws again on the next call
  }

  // Runnable threads of other processes: /proc/loadavg counts them machine-wide, less this
  // process's own. Where this process may use only some of the machine's CPUs (an affinity
  // mask, a quota), the others are taken as spread evenly over all of them. -1 (unknown) counts
  // as none.
  int others_runnable() const {
    const int all = detail::runnable_tasks(read_file("/proc/loadavg"));
    if (all < 0) return 0;
    const int others = std::max(0, all - own_runnable_threads());
    if (m_budget.cores >= m_online) return others;
    return static_cast<int>(std::lround(static_cast<double>(others) * m_budget.cores / m_online));
  }

  std::mutex m_mutex;
  bool m_initialised = false;
  ThreadBudget m_budget;
  int m_online = 1;
  bool m_sampled = false;
  int m_previous_others = 0;
  Clock::time_point m_last_sample;
  int m_blas_threads = 0;
};

}  // namespace

ThreadBudget thread_budget() { return Budget::instance().get(); }

int parallel_threads() {
  if (omp_in_parallel()) return 1;
  return Budget::instance().choose();
}

void reset_thread_use() { Budget::instance().reset_use(); }

void detail::reinitialise_thread_budget() { Budget::instance().reinitialise(); }

ThreadLimitScope::ThreadLimitScope(int threads, std::string source) {
  if (threads <= 0) return;
  Budget::instance().set(threads, false, source, &m_limit, &m_adaptive, &m_source);
  m_active = true;
}

ThreadLimitScope::~ThreadLimitScope() {
  if (!m_active) return;
  int limit = 0;
  bool adaptive = false;
  std::string source;
  Budget::instance().set(m_limit, m_adaptive, m_source, &limit, &adaptive, &source);
}

SerialBlasScope::SerialBlasScope(bool active) {
  const OpenBlas& o = openblas();
  if (!active || !o.pthreads() || !o.set_num_threads || !o.get_num_threads) return;
  m_saved = o.get_num_threads();
  if (m_saved > 1)
    o.set_num_threads(1);
  else
    m_saved = 0;
}

SerialBlasScope::~SerialBlasScope() {
  if (m_saved > 0) openblas().set_num_threads(m_saved);
}

BlasInfo blas_info() {
  const OpenBlas& o = openblas();
  BlasInfo info;
  if (!o.get_config) {
    info.name = "not OpenBLAS";
    info.threading = "unknown";
    return info;
  }
  info.name = o.get_config();
  while (!info.name.empty() && info.name.back() == ' ') info.name.pop_back();
  const int parallel = o.get_parallel ? o.get_parallel() : -1;
  info.threading = parallel == 0   ? "sequential"
                   : parallel == 1 ? "pthreads"
                   : parallel == 2 ? "OpenMP"
                                   : "unknown";
  return info;
}

}  // namespace ecmor
