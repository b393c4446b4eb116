#pragma once
/// \file shifted_solver.hpp
/// Factorisations of the model's matrix polynomial at shifts:
///     P(s) = s^2 M + s D + K          (second order)
///     P(s) = s E - A                  (descriptor)
/// and of general combinations  sum_k w_k T_k  of the same coefficient matrices (T_0 = K, T_1 = D,
/// T_2 = M; or T_0 = -A, T_1 = E), e.g. K - sigma M for shift-invert eigensolvers.
///
/// Reducers use only this interface, never a sparse library directly, so that another backend
/// (e.g. a distributed PETSc/MUMPS one) can be plugged in without touching any reducer. The
/// embedded backend (make_shifted_solver) uses SuiteSparse:
///  * the union sparsity pattern of all coefficients is built once, and symbolic analysis is done
///    once per pattern and arithmetic (real/complex), then reused by every numeric factorisation;
///  * real symmetric combinations try CHOLMOD (LL'), falling back to UMFPACK (LU) when the matrix
///  is
///    not positive definite; complex symmetric combinations of large models use MUMPS (LDL^T, about
///    half the work of an LU); other complex or unsymmetric combinations use UMFPACK;
///  * fill-reducing orderings: AMD, or METIS nested dissection where AMD's predicted fill is large
///    (3-D solids), chosen from the symbolic analysis (SolverOptions::ordering);
///  * factorisations are immutable after construction and solves are thread-safe, so the band
///    response can be computed in parallel across frequencies (factorize_combination may be called
///    from many threads at once: UMFPACK's Symbolic object is shared read-only; CHOLMOD gets one
///    cholmod_common per factorisation and per solve call, since cholmod_common is not
///    thread-safe);
///  * a factorisation keeps what it needs alive (pattern, options, counters): it stays valid after
///    its solver is destroyed, but the model's matrices must outlive the solver;
///  * factorisations, solves (counted per right-hand-side column) and their times are counted.

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"
#include "ecmor/linalg/memory_plan.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

template <class O>
class OptionSpecs;

/// Cumulative work counters of a ShiftedSolver (a snapshot; see ShiftedSolver::counters()).
struct ECMOR_API SolverCounters {
  Index symbolic_analyses = 0;  ///< symbolic (pattern) analyses
  Index factorizations = 0;     ///< numeric factorisations of any kind
  Index cholesky_factorizations = 0;
  Index lu_factorizations = 0;
  Index ldlt_factorizations = 0;  ///< complex symmetric LDL^T (MUMPS)
  Index complex_factorizations = 0;
  Index failed_cholesky = 0;  ///< Cholesky attempts that found the matrix indefinite
  Index solves = 0;           ///< right-hand-side columns solved
  double analysis_seconds = 0.0;
  double factorization_seconds = 0.0;
  double solve_seconds = 0.0;
  /// Floating-point operations of the numeric factorisations as the backend reports them
  /// (UMFPACK's and CHOLMOD's counts, MUMPS's RINFOG(3)), and the entries of their factors (a
  /// solve reads each entry once per right-hand-side column). Unlike the times, both are the same
  /// on every run and every machine: decisions between full solves and other work are made on
  /// them (band_error.hpp, verify: auto). 0 where a backend does not report them.
  double factorization_flops = 0.0;
  double factor_entries = 0.0;

  SolverCounters& operator+=(const SolverCounters& other);
  friend ECMOR_API SolverCounters operator-(SolverCounters a, const SolverCounters& b);
};

/// A numeric factorisation of one combination sum_k w_k T_k. Immutable; solves are thread-safe.
class ECMOR_API Factorization {
 public:
  virtual ~Factorization();
  /// Dimension N.
  virtual Index size() const = 0;
  /// True when the factorised matrix is complex (some weight had a non-zero imaginary part).
  virtual bool is_complex() const = 0;
  /// "cholmod", "umfpack" or "mumps-ldlt" (or another backend's name).
  virtual std::string method() const = 0;
  /// The weights w_k that were factorised.
  virtual const std::vector<Complex>& weights() const = 0;
  /// Reciprocal condition number estimate (UMFPACK's rcond; NaN when unavailable).
  virtual double rcond() const = 0;

  /// X = P^-1 B for real P. \throws NumericalError if the factorisation is complex.
  virtual Matrix solve(const Matrix& B) const = 0;
  /// X = P^-1 B (real or complex P).
  virtual ComplexMatrix solve(const ComplexMatrix& B) const = 0;
  /// X = P^-T B (transpose, not conjugate transpose) for real P.
  virtual Matrix solve_transposed(const Matrix& B) const = 0;
  /// X = P^-T B (transpose, not conjugate transpose).
  virtual ComplexMatrix solve_transposed(const ComplexMatrix& B) const = 0;
};

/// Backend-neutral shifted solver bound to one model's coefficient matrices (which must outlive
/// it).
class ECMOR_API ShiftedSolver {
 public:
  virtual ~ShiftedSolver();
  /// Dimension N.
  virtual Index size() const = 0;
  /// Number of coefficient matrices T_k (3 for second order, 2 for descriptor models).
  virtual Index terms() const = 0;
  /// Backend name ("suitesparse", ...).
  virtual std::string backend() const = 0;

  /// Factorise sum_k w_k T_k (weights.size() == terms()). Thread-safe.
  /// \throws NumericalError naming the weights when the matrix is (numerically) singular.
  virtual std::shared_ptr<const Factorization> factorize_combination(
      std::span<const Complex> weights) = 0;

  /// Factorise P(s): weights s^k. Thread-safe.
  std::shared_ptr<const Factorization> factorize(Complex s);

  /// y = (sum_k w_k T_k) x, a sparse product (no factorisation).
  virtual ComplexMatrix apply_combination(std::span<const Complex> weights,
                                          const ComplexMatrix& x) const = 0;
  /// y = (sum_k w_k T_k)^T x (transpose, not conjugate transpose), e.g. for output-side Krylov
  /// recurrences of unsymmetric models.
  virtual ComplexMatrix apply_combination_transposed(std::span<const Complex> weights,
                                                     const ComplexMatrix& x) const = 0;

  /// Snapshot of the cumulative counters.
  virtual SolverCounters counters() const = 0;

  /// Plans the memory of the factorisations before the first numeric one, from the symbolic
  /// analysis: the method of the complex factorisations, their predicted size, how many run at
  /// once (ecmor's loops over frequencies) and whether `kept` of them may be kept for reuse
  /// (RecentFactorizations). Where the first choice does not fit the headroom, the plan takes the
  /// next: LDL^T instead of LU (symmetric coefficients, complex_symmetric: auto), no kept
  /// factorisation, one factorisation at a time; the solver then follows it. MemoryPlan::fits()
  /// false: nothing fits, and the caller should refuse with MemoryPlan::refusal(). The default
  /// predicts nothing (MemoryPlan::predicted false).
  virtual MemoryPlan plan_memory(Index kept);

  /// False when factorisations and solves are collective operations of several MPI ranks (the
  /// PETSc backend): then they must not be called from several threads at once, and ecmor's own
  /// parallel loops over frequencies run serially.
  virtual bool concurrent() const { return true; }

  /// How many factorisations a caller may keep for later reuse beyond the one it is using (a
  /// reducer's cache of its expansion points' factorisations), by the memory plan
  /// (MemoryPlan::reuse_limit); unlimited before a plan and for backends without one.
  virtual Index reuse_limit() const { return kUnlimitedReuse; }
  static constexpr Index kUnlimitedReuse = 1 << 30;
};

/// Options of the embedded SuiteSparse backend.
struct ECMOR_API SolverOptions {
  /// Try CHOLMOD for real combinations whose matrices are all symmetric (default true).
  bool use_cholesky = true;
  /// Relative asymmetry ||T - T'||_F / ||T||_F below which a coefficient counts as symmetric.
  double symmetry_tol = 1e-12;
  /// A factorisation whose reciprocal condition estimate falls below this is reported singular.
  /// (UMFPACK's estimate is min/max |diag(U)| of the scaled matrix; CHOLMOD's (min/max diag L)^2.)
  double singular_rcond = 1e-14;
  /// UMFPACK iterative refinement steps per solve, in [0, 10] (default 0). Each step costs a
  /// residual and a solve; UMFPACK's check alone made a solve 5-8x slower on the rail models while
  /// no shared reference model gained accuracy (all within 1e-12 without it). Raise it for badly
  /// scaled or nearly singular shifts when the accuracy of the solves matters more than speed.
  int refinement_steps = 0;
  /// "suitesparse" (embedded: CHOLMOD, UMFPACK, sequential MUMPS) or "petsc" (distributed: PETSc
  /// with MUMPS, over the MPI ranks; only in builds with ECMOR_WITH_PETSC, see parallel.hpp).
  /// YAML backend.name.
  std::string backend = "suitesparse";
  /// Fill-reducing ordering of the embedded backend: "auto" (AMD; METIS nested dissection instead
  /// when AMD's predicted fill is large, as on 3-D solids: CHOLMOD's rule, also used for UMFPACK),
  /// "amd" or "metis". YAML backend.ordering.
  std::string ordering = "auto";
  /// Complex combinations of symmetric coefficients (s^2 M + s D + K with M, D, K symmetric):
  /// "ldlt" (MUMPS's LDL^T: about half the memory and flops of an LU, one factorisation at a
  /// time, using the cores inside it), "lu" (UMFPACK, several at once: ecmor's loops over
  /// frequencies run in parallel) or "auto": LU while the LUs of all threads at once fit in
  /// ldlt_memory_fraction of the physical memory, predicted from the symbolic analysis; LDL^T
  /// above. Measured on 2 cores (docs/benchmarks.md): parallel LUs sweep a 50 400-DOF solid 1.3x
  /// faster than serial LDL^T, with 2.5x its memory. YAML solver.complex_symmetric.
  std::string complex_symmetric = "auto";
  /// See complex_symmetric, in [0, 1]. YAML solver.ldlt_memory_fraction.
  double ldlt_memory_fraction = 0.25;
  /// The most memory the process may take, in GiB (2^30 bytes), >= 0; 0: no limit of its own
  /// (the available memory, `ulimit -v` and the cgroup's memory.max hold always). The memory plan
  /// (plan_memory) fits the factorisations under it. YAML solver.memory_limit_gib.
  double memory_limit_gib = 0.0;
  /// Complex symmetric combinations are factorised by MUMPS's LDL^T with the factors on disk, in
  /// $TMPDIR (else /tmp), read back by every solve (ICNTL(22) = 1): memory for the largest
  /// frontal matrices only, at the cost of disk traffic. Implies complex_symmetric: ldlt; needs
  /// symmetric coefficients. YAML solver.out_of_core.
  bool out_of_core = false;
  /// The options of YAML section `solver` (every field but `backend`), with their ranges and
  /// documentation: the rules validate() and the configuration reader both apply.
  static const OptionSpecs<SolverOptions>& specs();
  /// The options of YAML section `backend`: `name` (the field `backend`).
  static const OptionSpecs<SolverOptions>& backend_specs();
  /// Throws ConfigError naming the field, value and rule (by specs() and backend_specs()).
  void validate() const;
};

/// The backend options.backend on the model's matrices. The model must outlive the solver.
/// \throws ConfigError for invalid options (including backend "petsc" in a build without it);
///         InputError if the coefficients are not all N x N.
ECMOR_API std::unique_ptr<ShiftedSolver> make_shifted_solver(const Model& model,
                                                             const SolverOptions& options = {});
/// The same on one kind of model, kept by reference too (without these, a SecondOrderModel
/// would be converted to a temporary Model that dies before the solver).
ECMOR_API std::unique_ptr<ShiftedSolver> make_shifted_solver(const SecondOrderModel& model,
                                                             const SolverOptions& options = {});
ECMOR_API std::unique_ptr<ShiftedSolver> make_shifted_solver(const DescriptorModel& model,
                                                             const SolverOptions& options = {});
/// A temporary model would die before the solver that keeps its matrices: not allowed.
std::unique_ptr<ShiftedSolver> make_shifted_solver(Model&&, const SolverOptions& = {}) = delete;
std::unique_ptr<ShiftedSolver> make_shifted_solver(SecondOrderModel&&,
                                                   const SolverOptions& = {}) = delete;
std::unique_ptr<ShiftedSolver> make_shifted_solver(DescriptorModel&&,
                                                   const SolverOptions& = {}) = delete;

}  // namespace ecmor
