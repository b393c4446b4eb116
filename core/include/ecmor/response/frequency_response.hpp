#pragma once
/// \file frequency_response.hpp
/// Transfer matrices H(s) = (C + s Cv) (s^2 M + s D + K)^-1 B  or  H(s) = C (s E - A)^-1 B
/// of full (sparse) and reduced (dense) models, and a thread-safe cache of the full model's
/// response: it never changes during a run, so every frequency is factorised at most once.

#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <vector>

#include "ecmor/export.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// n log-spaced frequencies from f_min_hz to f_max_hz inclusive (n >= 2, 0 < f_min < f_max).
ECMOR_API std::vector<double> log_grid(double f_min_hz, double f_max_hz, Index n);

/// H(s) of a full model from a factorisation of P(s): min(m, p) solves (p < m: transposed solves
/// Y = P^-T (C + s Cv)^T, H = Y^T B). A real factorisation at real s gives a real-arithmetic H.
ECMOR_API ComplexMatrix transfer_function(const Model& model, const Factorization& p_of_s,
                                          Complex s);
/// H(s) of a full model (factorises P(s)).
ECMOR_API ComplexMatrix transfer_function(const Model& model, ShiftedSolver& solver, Complex s);
/// H(s) of a reduced model by a dense LU (partial pivoting) of the row-equilibrated P_r(s).
/// \throws NumericalError "... singular ..." if the LU's reciprocal condition estimate is below
///         machine epsilon or the result is not finite (s is a pole of the reduced model).
ECMOR_API ComplexMatrix transfer_function(const ReducedModel& model, Complex s);

/// H(i 2 pi f) at each frequency (Hz) of a full model, in parallel over frequencies
/// (threads <= 0: OpenMP's default). The result does not depend on the thread count (bitwise).
/// \throws NumericalError for a non-finite frequency or a singular P(s) (the first error raised
///         in the parallel loop is rethrown after it; the remaining frequencies are skipped).
ECMOR_API std::vector<ComplexMatrix> frequency_response(const Model& model, ShiftedSolver& solver,
                                                        const std::vector<double>& f_hz,
                                                        int threads = 0);
/// H(i 2 pi f) at each frequency of a reduced model.
ECMOR_API std::vector<ComplexMatrix> frequency_response(const ReducedModel& model,
                                                        const std::vector<double>& f_hz);

/// Poles of a reduced model: eigenvalues of the 2n x 2n linearisation [[0, I], [-K, -D]] z =
/// lambda diag(I, M) z (second order) or of the pencil (A, E) (descriptor). When M (E) is well
/// conditioned (LU rcond >= 1e-8) the standard eigenproblem of E^-1 A is solved (QR, faster);
/// otherwise QZ on the pencil, and infinite eigenvalues (|beta| <= dim eps ||E||_F) are dropped.
ECMOR_API ComplexVector poles(const ReducedModel& model);

/// One full-model solve kept for reuse: Z = P(s)^-1 B (N x m) or, when the model has fewer outputs
/// than inputs, Z = P(s)^-T (C + s Cv)^T (N x p; `transposed`), at s = i 2 pi f_hz. It is the
/// solve that gave H(s), offered to whoever can use its directions (the error estimator's
/// reference model, docs/error-measures.md).
struct ECMOR_API FullSolution {
  double f_hz = 0.0;
  bool transposed = false;
  ComplexMatrix Z;
};

/// Where a sweep of full-model responses stands, for a progress display.
struct ECMOR_API SweepProgress {
  Index done = 0;        ///< frequencies computed so far in this sweep
  Index total = 0;       ///< frequencies this sweep computes
  double seconds = 0.0;  ///< wall time since the sweep started
};

/// Memo of the full model's response H(i 2 pi f), keyed by the exact frequency value.
class ECMOR_API ResponseCache {
 public:
  /// model and solver must outlive the cache.
  ResponseCache(const Model& model, ShiftedSolver& solver, int threads = 0);
  /// The cache keeps the model by reference: a temporary (or a converted alternative) would dangle.
  ResponseCache(Model&&, ShiftedSolver&, int = 0) = delete;

  /// H at each frequency; computes the missing ones in parallel and stores them. Holds the lock
  /// while computing, so concurrent callers never factorise a frequency twice.
  std::vector<ComplexMatrix> evaluate(const std::vector<double>& f_hz);
  /// H at one frequency.
  ComplexMatrix evaluate(double f_hz);
  /// The missing frequencies are computed in rounds of a few per thread; between rounds the
  /// calling thread polls check_interrupt() (interrupt.hpp), so a stop request ends a long sweep
  /// within about one factorisation per thread, and every frequency finished before it stays
  /// cached (nothing is lost). 	hrows Interrupted then.

  /// Keep the solves behind every newly computed response (FullSolution) until take_solutions().
  void keep_solutions(bool keep);
  /// The solves kept since the last call, in ascending frequency within each sweep.
  std::vector<FullSolution> take_solutions();
  /// Called from the calling thread after each round of a sweep of more than one round (no call
  /// for a sweep that fits one round). Must not call back into the cache.
  void set_progress(std::function<void(const SweepProgress&)> progress);
  /// The stored frequencies, ascending.
  std::vector<double> frequencies() const;
  /// True if H at exactly f_hz is stored.
  bool contains(double f_hz) const;

  /// The stored frequency nearest to f_hz if it lies within relative distance rel_tol of it
  /// (|f - f_hz| <= rel_tol f_hz), else nothing. Lets callers that only need "a sample near f"
  /// reuse a factorisation already paid for.
  std::optional<double> nearest_cached(double f_hz, double rel_tol) const;
  /// Number of stored frequencies (= full-model factorisations done through this cache).
  Index size() const;
  /// Wall time spent computing full-model responses (the cost a reducer's run adds to the full
  /// model's band sampling).
  double seconds() const;
  /// Floating-point operations of those responses: the factorisations' as the solver reports them
  /// (SolverCounters::factorization_flops) and the solves' from the factors' entries. The same on
  /// every run, unlike seconds(); 0 when the backend reports no counts.
  double flops() const;
  const Model& model() const { return m_model; }
  ShiftedSolver& solver() { return m_solver; }
  /// Threads of the parallel evaluations as given to the constructor (<= 0: OpenMP's default), for
  /// callers that parallelise their own per-frequency work over the same frequencies alike.
  int threads() const { return m_threads; }

 private:
  const Model& m_model;
  ShiftedSolver& m_solver;
  int m_threads;
  mutable std::mutex m_mutex;
  std::map<double, ComplexMatrix> m_cache;
  double m_seconds = 0.0;
  double m_flops = 0.0;
  bool m_keep_solutions = false;
  std::vector<FullSolution> m_solutions;
  std::function<void(const SweepProgress&)> m_progress;
};

}  // namespace ecmor
