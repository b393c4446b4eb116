// memory_plan.cpp: see memory_plan.hpp.
#include "ecmor/linalg/memory_plan.hpp"

#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace ecmor {

namespace {

constexpr double kGiB = 1073741824.0;
constexpr double kUnlimited = std::numeric_limits<double>::infinity();

/// The value of "Key:   123 kB" in a /proc file, in bytes (NaN when absent).
double proc_kib(const char* file, const std::string& key) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.compare(0, key.size(), key) != 0 || line.size() <= key.size() ||
        line[key.size()] != ':')
      continue;
    std::istringstream value(line.substr(key.size() + 1));
    double kib = 0.0;
    if (value >> kib) return kib * 1024.0;
  }
  return std::nan("");
}

/// A cgroup v2 interface file's number ("max" and absent files: unlimited).
double cgroup_value(const std::string& path) {
  std::ifstream in(path);
  std::string word;
  if (!(in >> word) || word == "max") return kUnlimited;
  try {
    return std::stod(word);
  } catch (...) {
    return kUnlimited;
  }
}

/// memory.max - memory.current of this process's cgroup (v2), unlimited without one.
double cgroup_headroom() {
  std::ifstream self("/proc/self/cgroup");
  std::string line, dir = "/sys/fs/cgroup";
  while (std::getline(self, line))
    if (line.rfind("0::", 0) == 0) dir += line.substr(3);
  for (const std::string& d : {dir, std::string("/sys/fs/cgroup")}) {
    const double max = cgroup_value(d + "/memory.max");
    if (std::isfinite(max)) return max - cgroup_value(d + "/memory.current");
  }
  return kUnlimited;
}

}  // namespace

MemoryHeadroom memory_headroom(double limit_gib) {
  MemoryHeadroom h;
  h.resident_bytes = proc_kib("/proc/self/status", "VmRSS");
  if (!std::isfinite(h.resident_bytes)) h.resident_bytes = 0.0;
  auto tighten = [&](double bytes, const char* limit) {
    if (std::isfinite(bytes) && (h.limit.empty() || bytes < h.bytes)) {
      h.bytes = std::max(0.0, bytes);
      h.limit = limit;
    }
  };
  tighten(proc_kib("/proc/meminfo", "MemAvailable"), "available memory");
  struct rlimit as {};
  if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY)
    tighten(static_cast<double>(as.rlim_cur) - proc_kib("/proc/self/status", "VmSize"),
            "ulimit -v");
  tighten(cgroup_headroom(), "cgroup memory.max");
  if (limit_gib > 0.0) tighten(limit_gib * kGiB - h.resident_bytes, "solver.memory_limit_gib");
  return h;
}

double MemoryPlan::added_bytes() const {
  return static_cast<double>(factors_alive()) * factor_bytes;
}

double MemoryPlan::peak_bytes() const { return headroom.resident_bytes + added_bytes(); }

bool MemoryPlan::fits() const { return !predicted || added_bytes() <= headroom.bytes; }

std::string format_bytes(double bytes) {
  if (bytes >= kGiB) return fmt::format("{:.1f} GiB", bytes / kGiB);
  if (bytes >= 1048576.0) return fmt::format("{:.0f} MiB", bytes / 1048576.0);
  return fmt::format("{:.0f} KiB", bytes / 1024.0);
}

std::string MemoryPlan::describe() const {
  if (!predicted) return "not predicted by the " + method + " backend";
  std::string s = fmt::format("predicted peak {} ({} x {} {} factor{}), ",
                              format_bytes(peak_bytes()), factors_alive(),
                              format_bytes(factor_bytes), method, factors_alive() == 1 ? "" : "s");
  if (reuse_limit > 0)
    s += fmt::format("reducers may keep {} more (+{}); ", reuse_limit,
                     format_bytes(static_cast<double>(reuse_limit) * factor_bytes));
  else
    s += "reducers keep none; ";
  s += fmt::format("{} more may be taken ({})", format_bytes(headroom.bytes), headroom.limit);
  if (!adjustments.empty()) s += "; " + adjustments;
  return s;
}

std::string MemoryPlan::refusal() const {
  std::string s = fmt::format(
      "the factorisations need more memory than the process may take: predicted from the "
      "symbolic analysis, {} factorisation{} of {} ({}, nnz(L) = {:.3g}) would add {} to the {} "
      "in use, and {} allows {} more",
      factors_alive(), factors_alive() == 1 ? "" : "s", format_bytes(factor_bytes), method,
      factor_entries, format_bytes(added_bytes()), format_bytes(headroom.resident_bytes),
      headroom.limit, format_bytes(headroom.bytes));
  if (!adjustments.empty()) s += " (already with " + adjustments + ")";
  s += ". Options: ";
  if (symmetric && method.find("out-of-core") == std::string::npos)
    s += "`solver.out_of_core: true` (MUMPS keeps the factors on disk); ";
  if (!symmetric)
    s += "symmetric M, D, K (or E, A) would allow MUMPS's LDL^T, in memory or out of core; ";
  s += "`backend: {name: petsc}` under `mpirun -n P` (the factors spread over P processes, see "
       "docs/cluster.md); a coarser mesh";
  if (headroom.limit == "solver.memory_limit_gib") s += "; a larger `solver.memory_limit_gib`";
  return s;
}

}  // namespace ecmor
