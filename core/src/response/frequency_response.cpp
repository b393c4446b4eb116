// frequency_response.cpp: transfer matrices of full and reduced models, the band response in
// parallel across frequencies, poles of reduced models, and the full model's response cache.
#include "ecmor/response/frequency_response.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <list>
#include <mutex>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>

#include "base/number_text.hpp"
#include "base/parallel_for.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "linalg/dense_lapack.hpp"
#include "linalg/power_of_two_scaling.hpp"
#include "linalg/qz_solver.hpp"

namespace ecmor {

namespace {

/// Output matrix at s as a complex p x N matrix: C + s Cv (second order) or C.
template <class Sys>
ComplexMatrix output_matrix(const Sys& sys, Complex s) {
  ComplexMatrix Cs = sys.C.template cast<Complex>();
  if constexpr (requires { sys.Cv; }) {
    if (sys.has_velocity_output()) Cs += s * sys.Cv.template cast<Complex>();
  }
  return Cs;
}

/// H = Cs P^-1 B with the cheaper of m solves (X = P^-1 B) or p transposed solves
/// (Y = P^-T Cs^T, H = Y^T B: transpose, not conjugate).
/// The solves are returned in *solved when it is given (the columns of X or Y).
template <class Sys>
ComplexMatrix full_transfer(const Sys& sys, const Factorization& P, Complex s,
                            ComplexMatrix* solved = nullptr) {
  const Index m = sys.B.cols(), p = sys.C.rows();
  const bool real_path = !P.is_complex() && s.imag() == 0.0;
  if (p < m) {
    ComplexMatrix Cs = output_matrix(sys, s);
    if (real_path) {
      Matrix Y = P.solve_transposed(Matrix(Cs.real().transpose()));
      if (solved) *solved = Y.cast<Complex>();
      return (Y.transpose() * sys.B).template cast<Complex>();
    }
    ComplexMatrix Y = P.solve_transposed(ComplexMatrix(Cs.transpose()));
    ComplexMatrix H = Y.transpose() * sys.B;
    if (solved) *solved = std::move(Y);
    return H;
  }
  if (real_path) {
    Matrix X = P.solve(sys.B);
    ComplexMatrix H = (sys.C * X).template cast<Complex>();
    if constexpr (requires { sys.Cv; }) {
      if (sys.has_velocity_output()) H += s * (sys.Cv * X).template cast<Complex>();
    }
    if (solved) *solved = X.cast<Complex>();
    return H;
  }
  ComplexMatrix X = P.solve(ComplexMatrix(sys.B.template cast<Complex>()));
  ComplexMatrix H = output_matrix(sys, s) * X;
  if (solved) *solved = std::move(X);
  return H;
}

void check_frequencies(const std::vector<double>& f_hz) {
  for (std::size_t i = 0; i < f_hz.size(); ++i)
    if (!std::isfinite(f_hz[i]))
      throw NumericalError("frequency_response: frequency " + std::to_string(i) + " is " +
                           detail::number_text(f_hz[i]) + " Hz: must be finite");
}

/// Reciprocal condition estimate of an LU, 0 for an exactly singular one (Eigen's estimator
/// returns meaningless values when a pivot is zero, e.g. 0.5 for diag(1, 2, 0)).
template <class LU>
double safe_rcond(const LU& lu) {
  const auto d = lu.matrixLU().diagonal().cwiseAbs();
  if (d.size() == 0) return 1.0;
  if (!(d.minCoeff() > 0.0) || !d.allFinite()) return 0.0;
  const double rc = lu.rcond();
  return std::isfinite(rc) ? rc : 0.0;
}

/// Drop eigenvalues alpha/beta with beta numerically zero (infinite eigenvalues of a singular E).
ComplexVector finite_eigenvalues(const ComplexVector& alpha, const Vector& beta, double e_norm) {
  const double tol = static_cast<double>(beta.size()) * std::numeric_limits<double>::epsilon() *
                     (e_norm > 0.0 ? e_norm : 1.0);
  ComplexVector out(alpha.size());
  Index k = 0;
  for (Index i = 0; i < alpha.size(); ++i) {
    if (std::abs(beta(i)) <= tol) continue;
    const Complex lambda = alpha(i) / beta(i);
    if (!std::isfinite(lambda.real()) || !std::isfinite(lambda.imag())) continue;
    out(k++) = lambda;
  }
  out.conservativeResize(k);
  return out;
}

/// Eigenvalues of the pencil (A, E): of E^-1 A when E is well conditioned (rcond >= 1e-8: then
/// inverting E loses at most ~8 digits against the eigenvalues' own conditioning, and the standard
/// QR algorithm is several times faster than QZ), else of the generalized problem by QZ, which
/// also handles singular E (infinite eigenvalues, dropped). A QZ that does not converge is
/// repeated once on the equilibrated pencil.
ComplexVector pencil_eigenvalues(const Matrix& A, const Matrix& E) {
  if (A.rows() == 0) return ComplexVector();
  Eigen::PartialPivLU<Matrix> lu(E);
  if (safe_rcond(lu) >= 1e-8) {
    Matrix EA = lu.solve(A);
    if (EA.allFinite()) {
      ComplexVector lambda;
      if (!detail::eigenvalues(EA, lambda))
        throw NumericalError("poles: eigenvalue iteration (QR) did not converge");
      return lambda;
    }
  }
  detail::QzSolver ges(A, E, /*computeEigenvectors=*/false);
  if (ges.converged()) return finite_eigenvalues(ges.alphas(), ges.betas(), E.norm());
  // Eigen's QZ has no balancing of its own and stalls on badly scaled pencils (peec: no
  // convergence in 400 iterations for one eigenvalue), which converge once equilibrated.
  Matrix As = A, Es = E;
  detail::scale_by_powers_of_two(As, &Es);
  ges.compute(As, Es, /*computeEigenvectors=*/false);
  if (!ges.converged())
    throw NumericalError(
        "poles: generalized eigenvalue iteration (QZ) did not converge, also "
        "after equilibrating the pencil");
  return finite_eigenvalues(ges.alphas(), ges.betas(), Es.norm());
}

}  // namespace

std::vector<double> log_grid(double f_min_hz, double f_max_hz, Index n) {
  if (n < 2) throw ConfigError("log_grid: n = " + std::to_string(n) + ": must be >= 2");
  if (!std::isfinite(f_min_hz) || !(f_min_hz > 0.0))
    throw ConfigError("log_grid: f_min_hz = " + detail::number_text(f_min_hz) +
                      ": must be finite and > 0");
  if (!std::isfinite(f_max_hz) || !(f_max_hz > f_min_hz))
    throw ConfigError("log_grid: f_max_hz = " + detail::number_text(f_max_hz) +
                      ": must be finite and > f_min_hz = " + detail::number_text(f_min_hz));
  std::vector<double> f(static_cast<std::size_t>(n));
  const double a = std::log10(f_min_hz), b = std::log10(f_max_hz);
  for (Index i = 0; i < n; ++i)
    f[static_cast<std::size_t>(i)] =
        std::pow(10.0, a + (b - a) * static_cast<double>(i) / static_cast<double>(n - 1));
  f.front() = f_min_hz;  // exact end points
  f.back() = f_max_hz;
  return f;
}

ComplexMatrix transfer_function(const Model& model, const Factorization& p_of_s, Complex s) {
  return std::visit([&](const auto& sys) { return full_transfer(sys, p_of_s, s); }, model);
}

ComplexMatrix transfer_function(const Model& model, ShiftedSolver& solver, Complex s) {
  auto P = solver.factorize(s);
  return transfer_function(model, *P, s);
}

ComplexMatrix transfer_function(const ReducedModel& model, Complex s) {
  return std::visit(
      [&](const auto& sys) -> ComplexMatrix {
        using Sys = std::decay_t<decltype(sys)>;
        const Index n = sys.size();
        ComplexMatrix P;
        if constexpr (std::is_same_v<Sys, ReducedSecondOrderModel>)
          P = (s * s) * sys.M.template cast<Complex>() + s * sys.D.template cast<Complex>() +
              sys.K.template cast<Complex>();
        else
          P = s * sys.E.template cast<Complex>() - sys.A.template cast<Complex>();
        if (n == 0) return ComplexMatrix::Zero(sys.C.rows(), sys.B.cols());
        // Row equilibration: the reduced matrices inherit the full model's scaling (lf10: M's
        // eigenvalues 3e-11..7e-5 next to a large K); scaling rows makes the LU's condition
        // estimate meaningful as a singularity test and does not change the solution.
        // Row sizes by max(|re|, |im|) (within sqrt(2) of the modulus; the modulus is a hypot per
        // entry, measured a sixth of the evaluation at n = 278).
        Vector r = P.real().cwiseAbs().cwiseMax(P.imag().cwiseAbs()).rowwise().maxCoeff();
        for (Index i = 0; i < n; ++i) r(i) = r(i) > 0.0 ? 1.0 / r(i) : 1.0;
        P = r.asDiagonal() * P;
        ComplexMatrix X = r.asDiagonal() * sys.B.template cast<Complex>();
        double rc = 0.0;
        const bool solved = detail::lu_solve(P, X, rc);
        // Condition below machine precision: the solution has no correct digit; s is (at) a pole.
        if (!solved || !(rc >= std::numeric_limits<double>::epsilon()))
          throw NumericalError("reduced P_r(s) is singular at s = " + detail::number_text(s) +
                               " (rcond " + detail::number_text(rc) +
                               "): s is a pole of the reduced model?");
        ComplexMatrix H = output_matrix(sys, s) * X;
        if (!H.allFinite())
          throw NumericalError("reduced P_r(s) is singular at s = " + detail::number_text(s) +
                               " (non-finite solution, rcond " + detail::number_text(rc) + ")");
        return H;
      },
      model);
}

std::vector<ComplexMatrix> frequency_response(const Model& model, ShiftedSolver& solver,
                                              const std::vector<double>& f_hz, int threads) {
  check_frequencies(f_hz);
  std::vector<ComplexMatrix> H(f_hz.size());
  // A non-concurrent solver (MUMPS, PETSc) uses the cores inside each factorisation instead.
  detail::parallel_for(static_cast<Index>(f_hz.size()), solver.concurrent() ? threads : 1,
                       [&](Index i) {
                         const auto k = static_cast<std::size_t>(i);
                         H[k] = transfer_function(model, solver, s_from_hz(f_hz[k]));
                       });
  return H;
}

std::vector<ComplexMatrix> frequency_response(const ReducedModel& model,
                                              const std::vector<double>& f_hz) {
  check_frequencies(f_hz);
  std::vector<ComplexMatrix> H;
  H.reserve(f_hz.size());
  for (double f : f_hz) H.push_back(transfer_function(model, s_from_hz(f)));
  return H;
}

namespace {

// The pencil (A, E) of a reduced model's poles: companion form for second order.
std::pair<Matrix, Matrix> pole_pencil(const ReducedModel& model) {
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model)) {
    // Companion linearisation: [[0, I], [-K, -D]] z = lambda diag(I, M) z.
    const Index n = so->size();
    Matrix A = Matrix::Zero(2 * n, 2 * n), E = Matrix::Identity(2 * n, 2 * n);
    A.topRightCorner(n, n).setIdentity();
    A.bottomLeftCorner(n, n) = -so->K;
    A.bottomRightCorner(n, n) = -so->D;
    E.bottomRightCorner(n, n) = so->M;
    return {std::move(A), std::move(E)};
  }
  const auto& ds = std::get<ReducedDescriptorModel>(model);
  return {ds.A, ds.E};
}

// The matrices the poles depend on: (M, D, K) or (A, E).
std::vector<const Matrix*> pole_key(const ReducedModel& model) {
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model))
    return {&so->M, &so->D, &so->K};
  const auto& ds = std::get<ReducedDescriptorModel>(model);
  return {&ds.A, &ds.E};
}

// One model's poles are asked for several times in a row (the reducer's stability diagnostic, the
// band estimator's pole samples, the strategy's stability check): the last few models' matrices
// are kept with their poles and compared exactly, O(n^2) against the O(n^3) eigenvalue problem.
// NaN entries compare unequal, so such a model is never matched.
class PoleMemo {
 public:
  std::optional<ComplexVector> find(const std::vector<const Matrix*>& key) {
    std::lock_guard<std::mutex> lock(m_mutex);
    for (auto it = m_entries.begin(); it != m_entries.end(); ++it) {
      if (same(it->key, key)) {
        m_entries.splice(m_entries.begin(), m_entries, it);  // most recent first
        return m_entries.front().poles;
      }
    }
    return std::nullopt;
  }
  void store(const std::vector<const Matrix*>& key, ComplexVector poles) {
    Index entries = 0;
    for (const Matrix* m : key) entries += m->size();
    if (entries > kMaxEntries) return;  // memory: a few models of order <= ~1000
    Entry e;
    for (const Matrix* m : key) e.key.push_back(*m);
    e.poles = std::move(poles);
    std::lock_guard<std::mutex> lock(m_mutex);
    m_entries.push_front(std::move(e));
    if (m_entries.size() > kCapacity) m_entries.pop_back();
  }

 private:
  static constexpr std::size_t kCapacity = 4;
  static constexpr Index kMaxEntries = 3 * 1000 * 1000;
  struct Entry {
    std::vector<Matrix> key;
    ComplexVector poles;
  };
  static bool same(const std::vector<Matrix>& a, const std::vector<const Matrix*>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (a[i].rows() != b[i]->rows() || a[i].cols() != b[i]->cols() || a[i] != *b[i]) {
        return false;
      }
    }
    return true;
  }
  std::mutex m_mutex;
  std::list<Entry> m_entries;
};

PoleMemo& pole_memo() {
  static PoleMemo memo;
  return memo;
}

}  // namespace

ComplexVector poles(const ReducedModel& model) {
  const std::vector<const Matrix*> key = pole_key(model);
  if (auto hit = pole_memo().find(key)) return *hit;
  const auto [A, E] = pole_pencil(model);
  ComplexVector p = pencil_eigenvalues(A, E);
  pole_memo().store(key, p);
  return p;
}

// ---------------------------------------------------------------------------------------------

namespace {

double work_flops(const SolverCounters& work) {
  // A solve reads each factor entry once per right-hand-side column: a complex multiply-add, 8
  // flops (an upper bound for real factors, which solve a complex column as two real ones).
  const double entries_per_factorization =
      work.factorizations > 0 ? work.factor_entries / static_cast<double>(work.factorizations)
                              : 0.0;
  return work.factorization_flops +
         8.0 * entries_per_factorization * static_cast<double>(work.solves);
}

}  // namespace

ResponseCache::ResponseCache(const Model& model, ShiftedSolver& solver, int threads)
    : m_model(model), m_solver(solver), m_threads(threads) {}

std::vector<ComplexMatrix> ResponseCache::evaluate(const std::vector<double>& f_hz) {
  check_frequencies(f_hz);
  // The lock is held while the missing frequencies are computed: a concurrent caller asking for
  // the same frequencies waits instead of factorising them a second time (each frequency is
  // factorised at most once); the computation itself is parallel inside.
  std::lock_guard<std::mutex> lock(m_mutex);
  std::vector<double> missing;
  for (double f : f_hz)
    if (!m_cache.count(f)) missing.push_back(f);
  std::sort(missing.begin(), missing.end());
  missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
  if (!missing.empty()) {
    const auto start = std::chrono::steady_clock::now();
    auto since = [&] {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    // Rounds of two frequencies per thread: large enough to keep the threads busy, small enough
    // that a stop request is seen within about one factorisation per thread (the issue this
    // answers: a SIGTERM during the first sweep of a 59 400-DOF model went unheard for minutes).
    const int threads = m_threads > 0 ? m_threads : thread_budget().limit;
    const auto round = static_cast<std::size_t>(2 * std::max(threads, 1));
    const auto total = static_cast<Index>(missing.size());
    for (std::size_t first = 0; first < missing.size(); first += round) {
      check_interrupt("the full-model response sweep (" + std::to_string(first) + " of " +
                      std::to_string(missing.size()) + " frequencies done)");
      const double round_start = since();
      const SolverCounters counters_before = m_solver.counters();
      const std::size_t count = std::min(round, missing.size() - first);
      std::vector<ComplexMatrix> H(count), Z(m_keep_solutions ? count : 0);
      detail::parallel_for(
          static_cast<Index>(count), m_solver.concurrent() ? m_threads : 1, [&](Index i) {
            const auto k = static_cast<std::size_t>(i);
            const Complex s = s_from_hz(missing[first + k]);
            auto P = m_solver.factorize(s);
            H[k] = std::visit(
                [&](const auto& sys) {
                  return full_transfer(sys, *P, s, m_keep_solutions ? &Z[k] : nullptr);
                },
                m_model);
          });
      for (std::size_t k = 0; k < count; ++k) {
        m_cache.emplace(missing[first + k], std::move(H[k]));
        if (m_keep_solutions)
          m_solutions.push_back(
              {missing[first + k], outputs_of(m_model) < inputs_of(m_model), std::move(Z[k])});
      }
      m_seconds += since() - round_start;
      m_flops += work_flops(m_solver.counters() - counters_before);
      if (m_progress && total > static_cast<Index>(round))
        m_progress(SweepProgress{static_cast<Index>(first + count), total, since()});
    }
  }
  std::vector<ComplexMatrix> out;
  out.reserve(f_hz.size());
  for (double f : f_hz) out.push_back(m_cache.at(f));
  return out;
}

ComplexMatrix ResponseCache::evaluate(double f_hz) {
  return evaluate(std::vector<double>{f_hz})[0];
}

void ResponseCache::keep_solutions(bool keep) {
  std::lock_guard<std::mutex> lock(m_mutex);
  m_keep_solutions = keep;
  if (!keep) m_solutions.clear();
}

std::vector<FullSolution> ResponseCache::take_solutions() {
  std::lock_guard<std::mutex> lock(m_mutex);
  return std::exchange(m_solutions, {});
}

void ResponseCache::set_progress(std::function<void(const SweepProgress&)> progress) {
  std::lock_guard<std::mutex> lock(m_mutex);
  m_progress = std::move(progress);
}

std::vector<double> ResponseCache::frequencies() const {
  std::lock_guard<std::mutex> lock(m_mutex);
  std::vector<double> f;
  f.reserve(m_cache.size());
  for (const auto& entry : m_cache) f.push_back(entry.first);
  return f;
}

bool ResponseCache::contains(double f_hz) const {
  std::lock_guard<std::mutex> lock(m_mutex);
  return m_cache.count(f_hz) > 0;
}

std::optional<double> ResponseCache::nearest_cached(double f_hz, double rel_tol) const {
  std::lock_guard<std::mutex> lock(m_mutex);
  if (m_cache.empty() || !(rel_tol >= 0.0)) return std::nullopt;
  auto hi = m_cache.lower_bound(f_hz);
  std::optional<double> best;
  auto consider = [&](double f) {
    if (std::abs(f - f_hz) <= rel_tol * f_hz &&
        (!best || std::abs(f - f_hz) < std::abs(*best - f_hz))) {
      best = f;
    }
  };
  if (hi != m_cache.end()) consider(hi->first);
  if (hi != m_cache.begin()) consider(std::prev(hi)->first);
  return best;
}

double ResponseCache::seconds() const {
  std::lock_guard<std::mutex> lock(m_mutex);
  return m_seconds;
}

double ResponseCache::flops() const {
  std::lock_guard<std::mutex> lock(m_mutex);
  return m_flops;
}

Index ResponseCache::size() const {
  std::lock_guard<std::mutex> lock(m_mutex);
  return static_cast<Index>(m_cache.size());
}

}  // namespace ecmor
