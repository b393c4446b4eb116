#pragma once
// mumps_ldlt.hpp: complex symmetric LDL^T factorisations with sequential MUMPS (SYM = 2), for the
// embedded shifted solver (shifted_solver.cpp). Private to core.
//
// Why: when M, D and K (or E and A) are symmetric, P(s) = s^2 M + s D + K is complex symmetric
// (not Hermitian) for complex s. An LDL^T factorisation with symmetric (1x1 and 2x2) pivoting
// stores and computes about half of what an LU does; on 3-D solids, where the factorisation
// dominates every run, that is the difference that matters (docs/benchmarks.md).
//
// MUMPS is not thread-safe, not even across instances (module-level state in its Fortran code;
// Ipopt serialises its calls for the same reason). Every call into MUMPS made here holds one
// process-wide mutex. The shifted solver reports itself non-concurrent when it routes
// factorisations here, so that ecmor's loops over frequencies run serially and MUMPS and the BLAS
// use the cores inside each factorisation instead.
//
// The library is opened on first use with RTLD_LOCAL, not linked (mumps_ldlt.cpp says why: the
// PETSc backend's parallel MUMPS must not see its symbols).
#include <cstdint>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"

namespace ecmor::detail {

/// The upper triangle (row <= column) of a symmetric sparsity pattern in coordinate form, 1-based
/// as MUMPS reads it. Must outlive every MumpsLdlt made on it.
struct MumpsPattern {
  int n = 0;
  std::vector<int> row, col;
};

/// What a MUMPS analysis of a pattern predicts, before any numeric factorisation.
struct MumpsPrediction {
  std::vector<int> pivot_order;    ///< as MumpsLdlt::pivot_order()
  double factor_entries = 0.0;     ///< entries of the factors (INFOG(20))
  double in_core_bytes = 0.0;      ///< MUMPS's memory with the factors in memory (INFOG(17))
  double out_of_core_bytes = 0.0;  ///< the same with the factors on disk (INFOG(27))
};

/// Analyses the pattern with representative values (the orderings as MumpsLdlt does with an empty
/// pivot order) and returns the pivot order and MUMPS's memory estimates.
/// \throws NumericalError naming MUMPS's error code.
MumpsPrediction mumps_predict(const MumpsPattern& pattern, const std::vector<Complex>& values,
                              const std::string& ordering);

/// Where out-of-core factors go: MUMPS writes them into `dir` (empty: in memory).
struct MumpsOutOfCore {
  std::string dir;
};

/// One numeric factorisation P = L D L^T of a complex symmetric matrix, with its own MUMPS
/// instance. Solves hold the process-wide MUMPS mutex (and are therefore thread-safe).
class MumpsLdlt {
 public:
  /// Analyses and factorises the matrix with upper-triangle values `values` (one per pattern
  /// entry). `pivot_order` (1-based position of each variable in the pivot order, as MUMPS's
  /// PERM_IN), when not empty, is used as the fill-reducing ordering; otherwise `ordering` ("amd",
  /// "metis", or anything else for MUMPS's own choice) makes one and pivot_order() returns it, so
  /// that the next factorisation on the same pattern skips the ordering.
  /// `null_pivot_tol`: a pivot below this times the matrix's norm makes the matrix singular;
  /// singular() then says so (no exception: the caller names the shift).
  /// \throws NumericalError naming MUMPS's error code for any other failure.
  /// `out_of_core.dir` not empty: the factors are written there (ICNTL(22) = 1) and read back by
  /// each solve; MUMPS deletes its files when the factorisation is destroyed.
  MumpsLdlt(const MumpsPattern& pattern, const std::vector<Complex>& values,
            const std::vector<int>& pivot_order, double null_pivot_tol, const std::string& ordering,
            const MumpsOutOfCore& out_of_core = {});
  ~MumpsLdlt();
  MumpsLdlt(const MumpsLdlt&) = delete;
  MumpsLdlt& operator=(const MumpsLdlt&) = delete;

  /// True when MUMPS found the matrix (numerically) singular; no solve may follow.
  bool singular() const { return m_singular; }
  /// X = P^-1 B in place (column-major n x columns).
  void solve(Complex* b, int columns) const;
  /// The pivot order the analysis used (1-based positions, as PERM_IN).
  const std::vector<int>& pivot_order() const { return m_order; }
  /// Entries of the factors (MUMPS's INFOG(29)) and the peak memory of the factorisation in bytes
  /// (INFOG(21), MiB in MUMPS).
  std::int64_t factor_entries() const { return m_factor_entries; }
  double peak_bytes() const { return m_peak_bytes; }
  /// Operations of the elimination, MUMPS's RINFOG(3).
  double flops() const { return m_flops; }

 private:
  friend MumpsPrediction mumps_predict(const MumpsPattern&, const std::vector<Complex>&,
                                       const std::string&);
  struct Instance;
  Instance* m_instance;
  std::vector<int> m_order;
  std::int64_t m_factor_entries = 0;
  double m_peak_bytes = 0.0;
  double m_flops = 0.0;
  bool m_singular = false;
};

}  // namespace ecmor::detail
