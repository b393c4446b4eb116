// mumps_ldlt.cpp: see mumps_ldlt.hpp.
#include "linalg/mumps_ldlt.hpp"

#include <dlfcn.h>
#include <zmumps_c.h>

#include <cstdio>
#include <mutex>
#include <string>

#include "ecmor/base/error.hpp"

namespace ecmor::detail {

namespace {

// MUMPS's job codes and the communicator value that means "MPI_COMM_WORLD" (the sequential
// library's stub MPI has only that one).
constexpr int kJobInit = -1, kJobEnd = -2, kJobAnalyse = 1, kJobFactorize = 2, kJobSolve = 3;
constexpr int kUseCommWorld = -987654;

std::mutex& mumps_mutex() {
  static std::mutex m;
  return m;
}

// zmumps_c from the sequential MUMPS, opened on first use with RTLD_LOCAL. Linked into
// libecmor_core, its zmumps_c and stub MPI would sit in the process's global symbol scope, where
// the PETSc backend's parallel MUMPS (its own module, petsc_solver.hpp) would bind to them and
// fail on two ranks ("could not be solved at any of the seed frequencies"). Opened locally, they
// are seen only through this pointer.
using ZmumpsEntry = void (*)(ZMUMPS_STRUC_C*);

ZmumpsEntry zmumps_entry() {
  static ZmumpsEntry entry = nullptr;  // guarded by mumps_mutex, held by every caller
  if (entry) return entry;
  void* lib = dlopen(ECMOR_ZMUMPS_SONAME, RTLD_NOW | RTLD_LOCAL);
  if (!lib)
    throw NumericalError(std::string("complex symmetric LDL^T: cannot open the sequential MUMPS "
                                     "library (") +
                         dlerror() +
                         "); install Debian's libmumps-seq-5.5, or set solver.complex_symmetric: "
                         "lu");
  entry = reinterpret_cast<ZmumpsEntry>(dlsym(lib, "zmumps_c"));
  if (!entry)
    throw NumericalError(std::string("complex symmetric LDL^T: no zmumps_c in ") +
                         ECMOR_ZMUMPS_SONAME);
  return entry;
}

// ICNTL(k) and INFO(k) with MUMPS's 1-based numbering.
int& icntl(ZMUMPS_STRUC_C& p, int k) { return p.icntl[k - 1]; }
int info(const ZMUMPS_STRUC_C& p, int k) { return p.info[k - 1]; }
int infog(const ZMUMPS_STRUC_C& p, int k) { return p.infog[k - 1]; }

/// MUMPS's negative INFO(1) codes that a user can act on, in words.
std::string error_text(int code, int detail) {
  switch (code) {
    case -5:
    case -7:
    case -13:
      return "out of memory (MUMPS INFO(1) = " + std::to_string(code) +
             ", INFO(2) = " + std::to_string(detail) + ")";
    case -8:
    case -9:
    case -14:
    case -15:
      return "internal workspace too small (MUMPS INFO(1) = " + std::to_string(code) + ")";
    case -10:
      return "numerically singular matrix (MUMPS INFO(1) = -10)";
    default:
      return "MUMPS INFO(1) = " + std::to_string(code) + ", INFO(2) = " + std::to_string(detail);
  }
}

/// MUMPS's large counts: negative values are millions.
std::int64_t count(int value) {
  return value >= 0 ? value : static_cast<std::int64_t>(-static_cast<double>(value) * 1e6);
}

bool workspace_too_small(int code) {
  return code == -8 || code == -9 || code == -14 || code == -15;
}

}  // namespace

struct MumpsLdlt::Instance {
  ZMUMPS_STRUC_C p{};

  void call(int job) {
    p.job = job;
    zmumps_entry()(&p);
  }

  /// Opens the library, initialises the instance and gives it the matrix (the caller holds the
  /// MUMPS mutex). On failure nothing is left to end.
  void start(const MumpsPattern& pattern, const std::vector<Complex>& values,
             double null_pivot_tol) {
    if (values.size() != pattern.row.size())
      throw InputError("MUMPS LDL^T: " + std::to_string(values.size()) + " values for " +
                       std::to_string(pattern.row.size()) + " pattern entries");
    p.sym = 2;  // general symmetric (complex symmetric, not Hermitian): LDL^T with 2x2 pivots
    p.par = 1;  // the host works too (one process)
    p.comm_fortran = kUseCommWorld;
    zmumps_entry();  // the library opens, or nothing was made
    call(kJobInit);
    if (info(p, 1) < 0)
      throw NumericalError("MUMPS initialisation failed: " + error_text(info(p, 1), info(p, 2)));
    // Silent: no messages on MUMPS's streams; errors come back through INFO.
    icntl(p, 1) = -1;
    icntl(p, 2) = -1;
    icntl(p, 3) = -1;
    icntl(p, 4) = 0;
    // Null pivot detection: a pivot below null_pivot_tol * ||A|| makes the matrix singular.
    icntl(p, 24) = 1;
    p.cntl[2] = null_pivot_tol;  // CNTL(3)
    p.n = pattern.n;
    p.nnz = static_cast<MUMPS_INT8>(pattern.row.size());
    p.irn = const_cast<int*>(pattern.row.data());
    p.jcn = const_cast<int*>(pattern.col.data());
    p.a = reinterpret_cast<ZMUMPS_COMPLEX*>(const_cast<Complex*>(values.data()));
  }

  /// Analyses with the given pivot order or, without one, with `ordering` ("amd", "metis", or
  /// both with the smaller predicted factor kept); returns the order used.
  std::vector<int> analyse(const std::vector<int>& pivot_order, const std::string& ordering) {
    // ICNTL(7), the ordering: 1 given, 0 AMD, 5 METIS.
    constexpr int kGiven = 1, kAmd = 0, kMetis = 5;
    auto run = [&](int method) {
      icntl(p, 7) = method;
      call(kJobAnalyse);
      if (info(p, 1) < 0)
        throw NumericalError("MUMPS analysis failed: " + error_text(info(p, 1), info(p, 2)));
      return count(infog(p, 20));  // predicted entries in the factors
    };
    std::vector<int> order;
    if (!pivot_order.empty()) {
      order = pivot_order;
      p.perm_in = order.data();
      run(kGiven);
    } else if (ordering == "amd" || ordering == "metis") {
      run(ordering == "amd" ? kAmd : kMetis);
      order.assign(p.sym_perm, p.sym_perm + p.n);
    } else {
      // Both orderings, the one with the smaller predicted factor kept: METIS's nested dissection
      // wins on 3-D solids, AMD on chains and thin structures. An analysis costs a fraction of a
      // factorisation, and only the first factorisation on a pattern makes them.
      const std::int64_t amd_entries = run(kAmd);
      std::vector<int> amd_order(p.sym_perm, p.sym_perm + p.n);
      const std::int64_t metis_entries = run(kMetis);
      if (metis_entries <= amd_entries) {
        order.assign(p.sym_perm, p.sym_perm + p.n);
      } else {
        order = std::move(amd_order);
        p.perm_in = order.data();
        run(kGiven);
      }
    }
    p.perm_in = nullptr;
    return order;
  }
};

MumpsPrediction mumps_predict(const MumpsPattern& pattern, const std::vector<Complex>& values,
                              const std::string& ordering) {
  std::lock_guard<std::mutex> lock(mumps_mutex());
  MumpsLdlt::Instance instance;
  instance.start(pattern, values, 0.0);
  MumpsPrediction out;
  try {
    out.pivot_order = instance.analyse({}, ordering);
  } catch (...) {
    instance.call(kJobEnd);
    throw;
  }
  constexpr double kMiB = 1048576.0;
  out.factor_entries = static_cast<double>(count(infog(instance.p, 20)));
  out.in_core_bytes = static_cast<double>(infog(instance.p, 17)) * kMiB;
  out.out_of_core_bytes = static_cast<double>(infog(instance.p, 27)) * kMiB;
  instance.call(kJobEnd);
  return out;
}

MumpsLdlt::MumpsLdlt(const MumpsPattern& pattern, const std::vector<Complex>& values,
                     const std::vector<int>& pivot_order, double null_pivot_tol,
                     const std::string& ordering, const MumpsOutOfCore& out_of_core)
    : m_instance(new Instance) {
  std::lock_guard<std::mutex> lock(mumps_mutex());
  ZMUMPS_STRUC_C& p = m_instance->p;
  try {
    m_instance->start(pattern, values, null_pivot_tol);
  } catch (...) {
    delete m_instance;
    throw;
  }
  try {
    if (!out_of_core.dir.empty()) {
      if (out_of_core.dir.size() >= sizeof(p.ooc_tmpdir))
        throw InputError("MUMPS out-of-core: the directory name " + out_of_core.dir +
                         " is longer than MUMPS's " + std::to_string(sizeof(p.ooc_tmpdir) - 1) +
                         " characters");
      icntl(p, 22) = 1;
      std::snprintf(p.ooc_tmpdir, sizeof(p.ooc_tmpdir), "%s", out_of_core.dir.c_str());
      std::snprintf(p.ooc_prefix, sizeof(p.ooc_prefix), "%s", "ecmor_ldlt_");
    }
    m_order = m_instance->analyse(pivot_order, ordering);
    // Factorise; when MUMPS's workspace estimate was too small, retry with more room.
    for (int attempt = 0;; ++attempt) {
      m_instance->call(kJobFactorize);
      const int code = info(p, 1);
      if (code == -10 || (code >= 0 && infog(p, 28) > 0)) {
        m_singular = true;
        break;
      }
      if (code >= 0) break;
      if (workspace_too_small(code) && attempt < 4) {
        icntl(p, 14) = 2 * (icntl(p, 14) > 0 ? icntl(p, 14) : 20);
        continue;
      }
      throw NumericalError(
          "MUMPS factorisation failed: " + error_text(code, info(p, 2)) +
          (out_of_core.dir.empty() ? "" : " (factors out of core in " + out_of_core.dir + ")"));
    }
    // INFOG(29): entries in the factors; INFOG(22): peak MiB.
    m_factor_entries = count(infog(p, 29));
    m_peak_bytes = static_cast<double>(infog(p, 22)) * 1048576.0;
    // RINFOG(3) counts operations in the factorisation's arithmetic, a complex multiply-add as
    // 2 like a real one (measured: 7.4e4 for a dense 60 x 60, n^3 / 3); in real flops, 4x that.
    m_flops = 4.0 * static_cast<double>(p.rinfog[2]);
  } catch (...) {
    m_instance->call(kJobEnd);
    delete m_instance;
    throw;
  }
  // The values are not needed after the factorisation (no refinement, no error analysis).
  p.a = nullptr;
}

MumpsLdlt::~MumpsLdlt() {
  std::lock_guard<std::mutex> lock(mumps_mutex());
  m_instance->call(kJobEnd);
  delete m_instance;
}

void MumpsLdlt::solve(Complex* b, int columns) const {
  if (columns <= 0) return;
  if (m_singular) throw NumericalError("MUMPS solve on a singular factorisation");
  std::lock_guard<std::mutex> lock(mumps_mutex());
  ZMUMPS_STRUC_C& p = m_instance->p;
  p.rhs = reinterpret_cast<ZMUMPS_COMPLEX*>(b);
  p.nrhs = columns;
  p.lrhs = p.n;
  m_instance->call(kJobSolve);
  p.rhs = nullptr;
  if (info(p, 1) < 0)
    throw NumericalError("MUMPS solve failed: " + error_text(info(p, 1), info(p, 2)));
}

}  // namespace ecmor::detail
