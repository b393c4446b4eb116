// shifted_solver.cpp: the embedded SuiteSparse backend of ShiftedSolver.
//
// Design (why it looks like this):
//  * The coefficient matrices T_k are never added with sparse additions per shift. Their union
//    sparsity pattern (plus the full diagonal, so that every shift has a structurally non-singular
//    diagonal to pivot on) is built once, with for each term a map from its stored entries to
//    positions in the union's value array. Assembling sum_k w_k T_k is one pass over the values.
//    For CHOLMOD the upper triangle of the union is used, with its own maps.
//  * The raw C APIs are used (not Eigen's wrappers) so that ONE symbolic object serves many
//    numeric factorisations, including concurrent ones: UMFPACK's Symbolic is only read by
//    umfpack_*_numeric, and CHOLMOD's symbolic factor is only read by cholmod_copy_factor.
//    Symbolic analyses are done lazily (on first need) under a mutex, once per arithmetic:
//    UMFPACK real (di), UMFPACK complex (zi, packed complex values), CHOLMOD (real symmetric).
//    The UMFPACK analyses get sum_k |T_k| as values: UMFPACK uses values only for statistics, but
//    with Ax = NULL its automatic strategy picked the unsymmetric strategy (COLAMD) for the rail
//    models' symmetric pattern, 40% more fill, 2x the flops and a 1e-8 pivot ratio instead of
//    0.7. With the values it picks the symmetric strategy (AMD on A + A', diagonal pivots
//    preferred) when the pattern and the diagonal support it, and the unsymmetric one otherwise
//    (e.g. DAEs with structurally zero diagonals). The ordering depends only on the pattern and
//    is valid for every combination; numeric factorisations still pivot for stability.
//  * CHOLMOD thread safety: cholmod_common holds workspace and statistics and is not thread-safe.
//    We use one cholmod_common per numeric factorisation (created, used and finished inside
//    factorize) and one per solve call, instead of a global mutex, so that Cholesky
//    factorisations and solves at different shifts run concurrently. The shared common that did
//    the analysis is only used under the analysis mutex and to free the symbolic factor.
//    (cholmod_start allocates nothing; the workspace of a factorisation is O(N), negligible next
//    to the factor.)
//  * Complex symmetric combinations of large models go to MUMPS's LDL^T (mumps_ldlt.hpp): one
//    MUMPS instance per factorisation, the fill-reducing ordering found by the first one handed to
//    the next ones (the analysis of a given ordering is only symbolic). MUMPS calls are serialised,
//    so a solver that routes factorisations there reports itself non-concurrent.
//  * Counters live in a mutex-protected block shared (via shared_ptr) by the solver and every
//    factorisation it made, so solves are counted on the solver even after it is destroyed.
#include "ecmor/linalg/shifted_solver.hpp"

#include <cholmod.h>
#include <umfpack.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "base/parallel_for.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/threads.hpp"
#include "linalg/mumps_ldlt.hpp"
#include "linalg/petsc_solver.hpp"
#include "linalg/term_products.hpp"

namespace ecmor {

// ---------------------------------------------------------------------------------------------
// Counters and the abstract bases.

SolverCounters& SolverCounters::operator+=(const SolverCounters& other) {
  symbolic_analyses += other.symbolic_analyses;
  factorizations += other.factorizations;
  cholesky_factorizations += other.cholesky_factorizations;
  lu_factorizations += other.lu_factorizations;
  ldlt_factorizations += other.ldlt_factorizations;
  complex_factorizations += other.complex_factorizations;
  failed_cholesky += other.failed_cholesky;
  solves += other.solves;
  analysis_seconds += other.analysis_seconds;
  factorization_seconds += other.factorization_seconds;
  solve_seconds += other.solve_seconds;
  factorization_flops += other.factorization_flops;
  factor_entries += other.factor_entries;
  return *this;
}

SolverCounters operator-(SolverCounters a, const SolverCounters& b) {
  a.symbolic_analyses -= b.symbolic_analyses;
  a.factorizations -= b.factorizations;
  a.cholesky_factorizations -= b.cholesky_factorizations;
  a.lu_factorizations -= b.lu_factorizations;
  a.ldlt_factorizations -= b.ldlt_factorizations;
  a.complex_factorizations -= b.complex_factorizations;
  a.failed_cholesky -= b.failed_cholesky;
  a.solves -= b.solves;
  a.analysis_seconds -= b.analysis_seconds;
  a.factorization_seconds -= b.factorization_seconds;
  a.solve_seconds -= b.solve_seconds;
  a.factorization_flops -= b.factorization_flops;
  a.factor_entries -= b.factor_entries;
  return a;
}

Factorization::~Factorization() = default;
ShiftedSolver::~ShiftedSolver() = default;

MemoryPlan ShiftedSolver::plan_memory(Index kept) {
  MemoryPlan plan;
  plan.method = backend();
  plan.kept = kept;
  return plan;
}

std::shared_ptr<const Factorization> ShiftedSolver::factorize(Complex s) {
  parallel_threads();  // the BLAS threads of a factorisation made outside a parallel region
  std::vector<Complex> w(static_cast<std::size_t>(terms()));
  Complex p(1.0, 0.0);
  for (auto& wk : w) {
    wk = p;
    p *= s;
  }
  return factorize_combination(w);
}

namespace {

/// Bytes of a complex LU (UMFPACK's symmetric strategy) per entry of the Cholesky factor of the
/// pattern: about 2 nnz(L) complex entries with their indices (docs/benchmarks.md: 755 MiB for
/// nnz(L) = 1.8e7 on the 50 400-DOF solid).
constexpr double kLuBytesPerEntry = 44.0;

/// The most factorisations a memory plan lets callers keep for reuse (MemoryPlan::reuse_limit):
/// krylov's default cache of expansion points.
constexpr double kReuseCap = 64.0;

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string format_complex(Complex z) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g%+.6gi", z.real(), z.imag());
  return buf;
}

std::string format_double(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

/// True when the weights are the powers 1, s, s^2 of one s (as ShiftedSolver::factorize makes
/// them).
bool are_powers(std::span<const Complex> w) {
  bool powers = w.size() >= 2 && w[0] == Complex(1.0, 0.0);
  for (std::size_t k = 2; powers && k < w.size(); ++k) powers = (w[k] == w[k - 1] * w[1]);
  return powers;
}

std::string format_weights(std::span<const Complex> w) {
  std::string s = "(";
  for (std::size_t k = 0; k < w.size(); ++k) s += (k ? ", " : "") + format_complex(w[k]);
  return s + ")";
}

/// "P(s) is singular at s = 0+1.2i (rcond 3e-17): s is an eigenvalue of the pencil?" or, for a
/// general combination, "sum_k w_k T_k with weights (...) is singular (rcond ...)".
[[noreturn]] void throw_singular(std::span<const Complex> w, double rcond, const char* method) {
  std::string msg;
  if (are_powers(w))
    msg = "P(s) is singular at s = " + format_complex(w[1]) + " (rcond " + format_double(rcond) +
          ", " + method + "): s is an eigenvalue of the pencil?";
  else
    msg = "the combination sum_k w_k T_k with weights " + format_weights(w) +
          " is singular (rcond " + format_double(rcond) + ", " + method + ")";
  throw NumericalError(msg);
}

/// Relative asymmetry ||A - A'||_F / ||A||_F (0 for an all-zero matrix). Local so that the solver
/// depends on nothing else in core.
double asymmetry(const SparseMatrix& A) {
  const double nrm = A.norm();
  if (nrm == 0.0) return 0.0;
  SparseMatrix At = A.transpose();
  return (A - At).norm() / nrm;
}

/// Counters shared by a solver and its factorisations.
struct CounterBlock {
  std::mutex mutex;
  SolverCounters c;
  template <class F>
  void update(F&& f) {
    std::lock_guard<std::mutex> lock(mutex);
    f(c);
  }
};

/// Everything that does not depend on the weights: pattern, maps, symbolic objects. Shared (read
/// only after construction, except the lazily built symbolic objects guarded by the mutex) by the
/// solver and every factorisation, so factorisations stay valid if the solver is destroyed.
struct SharedState {
  int n = 0;
  std::vector<SparseMatrix> owned;        // compressed copies of non-compressed inputs
  std::vector<const SparseMatrix*> term;  // T_k (before sign)
  std::vector<double> sign;               // T_k = sign_k * term_k (descriptor: T_0 = -A)
  std::vector<bool> symmetric;            // per term, per SolverOptions::symmetry_tol
  // Union pattern (CSC, sorted, full diagonal).
  std::vector<int> Ap, Ai;
  std::vector<std::vector<int>> map;  // map[k][e]: position of term k's entry e in Ai
  std::vector<double> abs_sum;        // sum_k |T_k| on the union (for the analyses)
  // Upper triangle of the union (CSC, sorted), for CHOLMOD (stype = 1).
  std::vector<int> Up, Ui;
  std::vector<std::vector<int>> umap;  // umap[k][e]: position in Ui, or -1 (lower entry)
  SolverOptions options;
  double umf_control[UMFPACK_CONTROL];

  std::mutex analysis_mutex;
  std::atomic<void*> umf_real{nullptr};
  std::atomic<void*> umf_complex{nullptr};
  std::atomic<cholmod_factor*> chol_symbolic{nullptr};
  double chol_lnz = 0.0;  // nnz(L) predicted by the CHOLMOD analysis
  double chol_fl = 0.0;   // flops of a numeric factorisation, predicted by the same analysis
  // MUMPS LDL^T: the upper pattern in 1-based coordinates and the pivot order of the first
  // factorisation (both under analysis_mutex until set; read-only afterwards).
  detail::MumpsPattern mumps_pattern;
  std::vector<int> mumps_order;
  bool chol_started = false;
  cholmod_common chol_common;
  std::shared_ptr<CounterBlock> counters;

  ~SharedState() {
    if (void* s = umf_real.load()) umfpack_di_free_symbolic(&s);
    if (void* s = umf_complex.load()) umfpack_zi_free_symbolic(&s);
    if (chol_started) {
      if (cholmod_factor* L = chol_symbolic.load()) cholmod_free_factor(&L, &chol_common);
      cholmod_finish(&chol_common);
    }
  }

  std::size_t nnz() const { return Ai.size(); }
  std::size_t unnz() const { return Ui.size(); }

  /// The upper pattern in MUMPS's 1-based coordinates, made once (the caller holds
  /// analysis_mutex).
  void fill_mumps_pattern() {
    if (mumps_pattern.n != 0) return;
    mumps_pattern.n = n;
    mumps_pattern.row.reserve(unnz());
    mumps_pattern.col.reserve(unnz());
    for (int j = 0; j < n; ++j)
      for (int p = Up[j]; p < Up[j + 1]; ++p) {
        mumps_pattern.row.push_back(Ui[p] + 1);
        mumps_pattern.col.push_back(j + 1);
      }
  }

  /// Real union values of sum_k w_k T_k (weights real).
  void assemble_real(std::span<const Complex> w, std::vector<double>& x) const {
    x.assign(nnz(), 0.0);
    for (std::size_t k = 0; k < term.size(); ++k) {
      const double wk = w[k].real() * sign[k];
      if (wk == 0.0) continue;
      const double* v = term[k]->valuePtr();
      const int* m = map[k].data();
      const std::size_t ne = map[k].size();
      for (std::size_t e = 0; e < ne; ++e) x[m[e]] += wk * v[e];
    }
  }
  /// Real upper-triangle values of sum_k w_k T_k.
  void assemble_upper(std::span<const Complex> w, std::vector<double>& x) const {
    x.assign(unnz(), 0.0);
    for (std::size_t k = 0; k < term.size(); ++k) {
      const double wk = w[k].real() * sign[k];
      if (wk == 0.0) continue;
      const double* v = term[k]->valuePtr();
      const int* m = umap[k].data();
      const std::size_t ne = umap[k].size();
      for (std::size_t e = 0; e < ne; ++e)
        if (m[e] >= 0) x[m[e]] += wk * v[e];
    }
  }
  /// Complex upper-triangle values of sum_k w_k T_k.
  void assemble_upper_complex(std::span<const Complex> w, std::vector<Complex>& x) const {
    x.assign(unnz(), Complex(0.0, 0.0));
    for (std::size_t k = 0; k < term.size(); ++k) {
      const Complex wk = w[k] * sign[k];
      if (wk == Complex(0.0, 0.0)) continue;
      const double* v = term[k]->valuePtr();
      const int* m = umap[k].data();
      const std::size_t ne = umap[k].size();
      for (std::size_t e = 0; e < ne; ++e)
        if (m[e] >= 0) x[m[e]] += wk * v[e];
    }
  }
  /// Packed complex union values (re, im interleaved) of sum_k w_k T_k.
  void assemble_complex(std::span<const Complex> w, std::vector<double>& x) const {
    x.assign(2 * nnz(), 0.0);
    for (std::size_t k = 0; k < term.size(); ++k) {
      const double wr = w[k].real() * sign[k], wi = w[k].imag() * sign[k];
      if (wr == 0.0 && wi == 0.0) continue;
      const double* v = term[k]->valuePtr();
      const int* m = map[k].data();
      const std::size_t ne = map[k].size();
      for (std::size_t e = 0; e < ne; ++e) {
        double* p = &x[2 * static_cast<std::size_t>(m[e])];
        p[0] += wr * v[e];
        p[1] += wi * v[e];
      }
    }
  }

  void* umfpack_real_symbolic() {
    if (void* s = umf_real.load(std::memory_order_acquire)) return s;
    std::lock_guard<std::mutex> lock(analysis_mutex);
    if (void* s = umf_real.load()) return s;
    const auto t0 = Clock::now();
    void* s = nullptr;
    double info[UMFPACK_INFO];
    const int status =
        umfpack_di_symbolic(n, n, Ap.data(), Ai.data(), abs_sum.data(), &s, umf_control, info);
    if (status != UMFPACK_OK)
      throw NumericalError("UMFPACK symbolic analysis (real) failed with status " +
                           std::to_string(status));
    const double dt = seconds_since(t0);
    counters->update([&](SolverCounters& c) {
      ++c.symbolic_analyses;
      c.analysis_seconds += dt;
    });
    umf_real.store(s, std::memory_order_release);
    return s;
  }

  void* umfpack_complex_symbolic() {
    if (void* s = umf_complex.load(std::memory_order_acquire)) return s;
    std::lock_guard<std::mutex> lock(analysis_mutex);
    if (void* s = umf_complex.load()) return s;
    const auto t0 = Clock::now();
    void* s = nullptr;
    double info[UMFPACK_INFO];
    // Imaginary parts are zero (Az given separately): only the statistics matter.
    std::vector<double> zeros(abs_sum.size(), 0.0);
    const int status = umfpack_zi_symbolic(n, n, Ap.data(), Ai.data(), abs_sum.data(), zeros.data(),
                                           &s, umf_control, info);
    if (status != UMFPACK_OK)
      throw NumericalError("UMFPACK symbolic analysis (complex) failed with status " +
                           std::to_string(status));
    const double dt = seconds_since(t0);
    counters->update([&](SolverCounters& c) {
      ++c.symbolic_analyses;
      c.analysis_seconds += dt;
    });
    umf_complex.store(s, std::memory_order_release);
    return s;
  }

  /// A cholmod_sparse view of the upper union pattern with values x (or pattern only).
  cholmod_sparse upper_view(double* x) const {
    cholmod_sparse A{};
    A.nrow = A.ncol = static_cast<std::size_t>(n);
    A.nzmax = unnz();
    A.p = const_cast<int*>(Up.data());
    A.i = const_cast<int*>(Ui.data());
    A.nz = nullptr;
    A.x = x;
    A.z = nullptr;
    A.stype = 1;
    A.itype = CHOLMOD_INT;
    A.xtype = x ? CHOLMOD_REAL : CHOLMOD_PATTERN;
    A.dtype = CHOLMOD_DOUBLE;
    A.sorted = 1;
    A.packed = 1;
    return A;
  }

  /// Entries of the Cholesky factor of the union pattern (CHOLMOD's analysis, made once).
  double cholmod_symbolic_nnz() {
    cholmod_symbolic();
    return chol_lnz;
  }

  const cholmod_factor* cholmod_symbolic() {
    if (cholmod_factor* L = chol_symbolic.load(std::memory_order_acquire)) return L;
    std::lock_guard<std::mutex> lock(analysis_mutex);
    if (cholmod_factor* L = chol_symbolic.load()) return L;
    const auto t0 = Clock::now();
    if (!chol_started) {
      cholmod_start(&chol_common);
      chol_common.print = 0;
      chol_common.final_ll = 1;
      // "auto" keeps CHOLMOD's default: AMD, then METIS when AMD's fill is large; take the better.
      if (options.ordering != "auto") {
        chol_common.nmethods = 1;
        chol_common.method[0].ordering = options.ordering == "metis" ? CHOLMOD_METIS : CHOLMOD_AMD;
        chol_common.postorder = 1;
      }
      chol_started = true;
    }
    cholmod_sparse A = upper_view(nullptr);
    cholmod_factor* L = cholmod_analyze(&A, &chol_common);
    if (!L || chol_common.status < CHOLMOD_OK)
      throw NumericalError("CHOLMOD symbolic analysis failed with status " +
                           std::to_string(chol_common.status));
    chol_lnz = chol_common.lnz;
    chol_fl = chol_common.fl;
    const double dt = seconds_since(t0);
    counters->update([&](SolverCounters& c) {
      ++c.symbolic_analyses;
      c.analysis_seconds += dt;
    });
    chol_symbolic.store(L, std::memory_order_release);
    return L;
  }
};

/// RAII cholmod_common, one per factorisation or solve call (see the file comment).
struct LocalCommon {
  cholmod_common c;
  LocalCommon() {
    cholmod_start(&c);
    c.print = 0;
    c.quick_return_if_not_posdef = 1;
    // LL' also for simplicial factors: a simplicial LDL' would succeed on indefinite matrices,
    // and we want "not positive definite" to route the combination to UMFPACK.
    c.final_ll = 1;
  }
  ~LocalCommon() { cholmod_finish(&c); }
  LocalCommon(const LocalCommon&) = delete;
  LocalCommon& operator=(const LocalCommon&) = delete;
};

/// Solve a complex right-hand side with a real factorisation: real and imaginary parts as one real
/// block [Re B, Im B].
template <class RealSolve>
ComplexMatrix solve_split(const ComplexMatrix& B, RealSolve&& real_solve) {
  const Index n = B.rows(), c = B.cols();
  Matrix R(n, 2 * c);
  R.leftCols(c) = B.real();
  R.rightCols(c) = B.imag();
  Matrix X = real_solve(R);
  ComplexMatrix out(n, c);
  out.real() = X.leftCols(c);
  out.imag() = X.rightCols(c);
  return out;
}

class FactorizationBase : public Factorization {
 public:
  FactorizationBase(std::shared_ptr<SharedState> shared, std::vector<Complex> w, double rcond)
      : m_shared(std::move(shared)), m_weights(std::move(w)), m_rcond(rcond) {}
  Index size() const override { return m_shared->n; }
  const std::vector<Complex>& weights() const override { return m_weights; }
  double rcond() const override { return m_rcond; }

 protected:
  void check_rows(Index rows) const {
    if (rows != m_shared->n)
      throw InputError("Factorization::solve: right-hand side has " + std::to_string(rows) +
                       " rows, expected " + std::to_string(m_shared->n));
  }
  void count_solves(Index columns, Clock::time_point t0) const {
    const double dt = seconds_since(t0);
    m_shared->counters->update([&](SolverCounters& c) {
      c.solves += columns;
      c.solve_seconds += dt;
    });
  }
  std::shared_ptr<SharedState> m_shared;
  std::vector<Complex> m_weights;
  double m_rcond;
};

/// UMFPACK LU, real (di) or complex (zi, packed). Keeps the assembled values: UMFPACK's iterative
/// refinement (SolverOptions::refinement_steps) needs A in the solves.
class UmfpackFactorization final : public FactorizationBase {
 public:
  UmfpackFactorization(std::shared_ptr<SharedState> shared, std::vector<Complex> w,
                       std::vector<double> values, void* numeric, bool is_cplx, double rcond)
      : FactorizationBase(std::move(shared), std::move(w), rcond),
        m_values(std::move(values)),
        m_numeric(numeric),
        m_complex(is_cplx) {}
  ~UmfpackFactorization() override {
    if (m_complex)
      umfpack_zi_free_numeric(&m_numeric);
    else
      umfpack_di_free_numeric(&m_numeric);
  }
  bool is_complex() const override { return m_complex; }
  std::string method() const override { return "umfpack"; }

  Matrix solve(const Matrix& B) const override { return solve_real(B, UMFPACK_A); }
  Matrix solve_transposed(const Matrix& B) const override { return solve_real(B, UMFPACK_Aat); }
  ComplexMatrix solve(const ComplexMatrix& B) const override { return solve_complex(B, UMFPACK_A); }
  ComplexMatrix solve_transposed(const ComplexMatrix& B) const override {
    return solve_complex(B, UMFPACK_Aat);
  }

 private:
  Matrix solve_real(const Matrix& B, int sys) const {
    if (m_complex)
      throw NumericalError("solve of a real right-hand side requested on a complex factorisation");
    check_rows(B.rows());
    const auto t0 = Clock::now();
    const SharedState& S = *m_shared;
    const int n = S.n;
    Matrix X(n, B.cols());
    std::vector<int> Wi(static_cast<std::size_t>(n));
    std::vector<double> W(5 * static_cast<std::size_t>(n));
    double info[UMFPACK_INFO];
    for (Index j = 0; j < B.cols(); ++j) {
      const int status = umfpack_di_wsolve(
          sys, S.Ap.data(), S.Ai.data(), (m_values.empty() ? nullptr : m_values.data()),
          X.col(j).data(), B.col(j).data(), m_numeric, S.umf_control, info, Wi.data(), W.data());
      if (status < 0)
        throw NumericalError("UMFPACK solve failed with status " + std::to_string(status));
    }
    count_solves(B.cols(), t0);
    return X;
  }

  ComplexMatrix solve_complex(const ComplexMatrix& B, int sys) const {
    if (!m_complex) return solve_split(B, [&](const Matrix& R) { return solve_real(R, sys); });
    check_rows(B.rows());
    const auto t0 = Clock::now();
    const SharedState& S = *m_shared;
    const int n = S.n;
    ComplexMatrix X(n, B.cols());
    std::vector<int> Wi(static_cast<std::size_t>(n));
    std::vector<double> W(10 * static_cast<std::size_t>(n));
    double info[UMFPACK_INFO];
    for (Index j = 0; j < B.cols(); ++j) {
      auto* x = reinterpret_cast<double*>(X.col(j).data());
      const auto* b = reinterpret_cast<const double*>(B.col(j).data());
      const int status = umfpack_zi_wsolve(
          sys, S.Ap.data(), S.Ai.data(), m_values.empty() ? nullptr : m_values.data(), nullptr, x,
          nullptr, b, nullptr, m_numeric, S.umf_control, info, Wi.data(), W.data());
      if (status < 0)
        throw NumericalError("UMFPACK solve failed with status " + std::to_string(status));
    }
    count_solves(B.cols(), t0);
    return X;
  }

  std::vector<double> m_values;
  void* m_numeric;
  bool m_complex;
};

/// CHOLMOD LL' of a real symmetric positive definite combination. The factor is owned with the
/// default allocator; a fresh cholmod_common per solve call keeps solves thread-safe.
class CholmodFactorization final : public FactorizationBase {
 public:
  CholmodFactorization(std::shared_ptr<SharedState> shared, std::vector<Complex> w,
                       cholmod_factor* L, double rcond)
      : FactorizationBase(std::move(shared), std::move(w), rcond), m_L(L) {}
  ~CholmodFactorization() override {
    LocalCommon cc;
    cholmod_free_factor(&m_L, &cc.c);
  }
  bool is_complex() const override { return false; }
  std::string method() const override { return "cholmod"; }

  // Symmetric: P^-T = P^-1.
  Matrix solve(const Matrix& B) const override { return solve_real(B); }
  Matrix solve_transposed(const Matrix& B) const override { return solve_real(B); }
  ComplexMatrix solve(const ComplexMatrix& B) const override {
    return solve_split(B, [&](const Matrix& R) { return solve_real(R); });
  }
  ComplexMatrix solve_transposed(const ComplexMatrix& B) const override { return solve(B); }

 private:
  Matrix solve_real(const Matrix& B) const {
    check_rows(B.rows());
    const auto t0 = Clock::now();
    Matrix X(B.rows(), B.cols());
    if (B.cols() > 0) {
      LocalCommon cc;
      cholmod_dense b{};
      b.nrow = static_cast<std::size_t>(B.rows());
      b.ncol = static_cast<std::size_t>(B.cols());
      b.nzmax = b.nrow * b.ncol;
      b.d = b.nrow;
      b.x = const_cast<double*>(B.data());
      b.z = nullptr;
      b.xtype = CHOLMOD_REAL;
      b.dtype = CHOLMOD_DOUBLE;
      cholmod_dense* x = cholmod_solve(CHOLMOD_A, m_L, &b, &cc.c);
      if (!x)
        throw NumericalError("CHOLMOD solve failed with status " + std::to_string(cc.c.status));
      std::copy_n(static_cast<const double*>(x->x), X.size(), X.data());
      cholmod_free_dense(&x, &cc.c);
    }
    count_solves(B.cols(), t0);
    return X;
  }

  cholmod_factor* m_L;
};

/// MUMPS LDL^T of a complex symmetric combination (P^T = P: transposed solves are solves).
class MumpsFactorization final : public FactorizationBase {
 public:
  MumpsFactorization(std::shared_ptr<SharedState> shared, std::vector<Complex> w,
                     std::unique_ptr<detail::MumpsLdlt> f)
      : FactorizationBase(std::move(shared), std::move(w),
                          std::numeric_limits<double>::quiet_NaN()),
        m_f(std::move(f)) {}
  bool is_complex() const override { return true; }
  std::string method() const override { return "mumps-ldlt"; }

  Matrix solve(const Matrix&) const override {
    throw NumericalError("solve of a real right-hand side requested on a complex factorisation");
  }
  Matrix solve_transposed(const Matrix& B) const override { return solve(B); }
  ComplexMatrix solve(const ComplexMatrix& B) const override {
    check_rows(B.rows());
    const auto t0 = Clock::now();
    ComplexMatrix X = B;
    m_f->solve(X.data(), static_cast<int>(X.cols()));
    count_solves(B.cols(), t0);
    return X;
  }
  ComplexMatrix solve_transposed(const ComplexMatrix& B) const override { return solve(B); }

 private:
  std::unique_ptr<detail::MumpsLdlt> m_f;
};

class SuiteSparseSolver final : public detail::TermProducts<SuiteSparseSolver> {
  friend class detail::TermProducts<SuiteSparseSolver>;

 public:
  SuiteSparseSolver(const SecondOrderModel& so, const SolverOptions& options)
      : SuiteSparseSolver({&so.K, &so.D, &so.M}, {1.0, 1.0, 1.0}, {"K", "D", "M"}, options) {}
  SuiteSparseSolver(const DescriptorModel& ds, const SolverOptions& options)
      : SuiteSparseSolver({&ds.A, &ds.E}, {-1.0, 1.0}, {"A", "E"}, options) {}

  /// P(s) = sum_k w_k sign_k T_k over the terms `in` (kept by pointer when compressed).
  SuiteSparseSolver(std::vector<const SparseMatrix*> in, std::vector<double> sign,
                    std::vector<std::string> names, const SolverOptions& options)
      : m_shared(std::make_shared<SharedState>()), m_names(std::move(names)) {
    options.validate();
    SharedState& S = *m_shared;
    S.options = options;
    S.counters = std::make_shared<CounterBlock>();
    S.sign = std::move(sign);
    const Index n = in[0]->rows();
    if (n > std::numeric_limits<int>::max() / 2)
      throw InputError("shifted solver: N = " + std::to_string(n) + " exceeds 32-bit indices");
    for (std::size_t k = 0; k < in.size(); ++k)
      if (in[k]->rows() != n || in[k]->cols() != n)
        throw InputError("shifted solver: " + m_names[k] + " is " + std::to_string(in[k]->rows()) +
                         " x " + std::to_string(in[k]->cols()) + ", expected " + std::to_string(n) +
                         " x " + std::to_string(n));
    S.n = static_cast<int>(n);
    // Keep pointers to compressed matrices (copy the rare non-compressed input).
    S.owned.reserve(in.size());
    for (const SparseMatrix* T : in) {
      if (T->isCompressed()) {
        S.term.push_back(T);
      } else {
        S.owned.emplace_back(*T);
        S.owned.back().makeCompressed();
        S.term.push_back(nullptr);
      }
    }
    for (std::size_t k = 0, o = 0; k < S.term.size(); ++k)
      if (!S.term[k]) S.term[k] = &S.owned[o++];
    for (const SparseMatrix* T : S.term)
      S.symmetric.push_back(asymmetry(*T) <= options.symmetry_tol);
    build_pattern();
    umfpack_di_defaults(S.umf_control);
    S.umf_control[UMFPACK_IRSTEP] = options.refinement_steps;
    // "auto": CHOLMOD's rule (AMD, or METIS when AMD's fill is large) on the pattern UMFPACK's
    // strategy orders. On the 50 400-DOF solid of docs/benchmarks.md METIS saves a quarter of the
    // flops of AMD; on the small shipped models the rule keeps AMD.
    S.umf_control[UMFPACK_ORDERING] = options.ordering == "amd"     ? UMFPACK_ORDERING_AMD
                                      : options.ordering == "metis" ? UMFPACK_ORDERING_METIS
                                                                    : UMFPACK_ORDERING_CHOLMOD;
    m_all_symmetric = std::all_of(S.symmetric.begin(), S.symmetric.end(), [](bool b) { return b; });
    if (options.out_of_core && !m_all_symmetric) {
      const std::size_t k = static_cast<std::size_t>(
          std::find(S.symmetric.begin(), S.symmetric.end(), false) - S.symmetric.begin());
      std::string message =
          "solver.out_of_core = true: needs symmetric coefficient matrices (MUMPS's LDL^T keeps "
          "the factors out of core), but ";
      message.append(m_names[k]).append(" is not symmetric within solver.symmetry_tol = ");
      message.append(format_double(options.symmetry_tol));
      throw ConfigError(message);
    }
  }

  Index size() const override { return m_shared->n; }
  Index terms() const override { return static_cast<Index>(m_shared->term.size()); }
  std::string backend() const override { return "suitesparse"; }

  std::shared_ptr<const Factorization> factorize_combination(
      std::span<const Complex> weights) override {
    SharedState& S = *m_shared;
    if (weights.size() != S.term.size())
      throw InputError("factorize_combination: " + std::to_string(weights.size()) +
                       " weights for " + std::to_string(S.term.size()) + " terms");
    bool is_cplx = false, symmetric = true;
    for (std::size_t k = 0; k < weights.size(); ++k) {
      const Complex w = weights[k];
      if (!std::isfinite(w.real()) || !std::isfinite(w.imag())) {
        throw NumericalError("factorize: non-finite weight w_" + std::to_string(k) + " = " +
                             format_complex(w) + " in " + format_weights(weights));
      }
    }
    std::vector<Complex> w(weights.begin(), weights.end());
    for (std::size_t k = 0; k < w.size(); ++k) {
      // A weight on an all-zero term (D = 0 of an undamped model) changes nothing: it must not
      // turn the real K - omega^2 M into a complex factorisation. (The weights are kept as given,
      // for messages; the real assembly uses only their real parts.)
      if (S.term[k]->nonZeros() == 0) continue;
      if (w[k].imag() != 0.0) is_cplx = true;
      if (w[k] != Complex(0.0, 0.0) && !S.symmetric[k]) symmetric = false;
    }
    if (!is_cplx && symmetric && S.options.use_cholesky) {
      if (auto f = try_cholesky(w)) return f;
    }
    if (is_cplx && symmetric && use_ldlt()) return mumps_ldlt(std::move(w));
    return umfpack_lu(std::move(w), is_cplx);
  }

  /// MUMPS calls are serialised (mumps_ldlt.hpp): a solver that can route a factorisation there
  /// lets MUMPS and the BLAS use the cores, not ecmor's loops over frequencies. A memory plan
  /// that allows one factorisation at a time does the same.
  bool concurrent() const override {
    return !m_one_at_a_time.load() && !(m_all_symmetric && use_ldlt());
  }

  Index reuse_limit() const override { return m_reuse_limit.load(); }

  MemoryPlan plan_memory(Index kept) override {
    const SharedState& S = *m_shared;
    MemoryPlan plan;
    plan.predicted = true;
    plan.headroom = memory_headroom(S.options.memory_limit_gib);
    plan.factor_entries = m_shared->cholmod_symbolic_nnz();
    const Index threads = std::max(1, thread_budget().limit);
    // Each candidate in order of preference; the first that fits is taken. The LU's size comes
    // from CHOLMOD's analysis (kLuBytesPerEntry), the LDL^T's from MUMPS's own analysis.
    struct Candidate {
      bool ldlt;
      Index concurrent, kept;
      const char* adjustment;
    };
    const bool ldlt_first = m_all_symmetric && use_ldlt_by_options();
    std::vector<Candidate> candidates;
    const Index lu_concurrent = ldlt_first ? 1 : threads;
    candidates.push_back({ldlt_first, lu_concurrent, kept, ""});
    if (kept > 0) candidates.push_back({ldlt_first, lu_concurrent, 0, "no factorisation kept"});
    if (!ldlt_first && m_all_symmetric && S.options.complex_symmetric == "auto") {
      candidates.push_back({true, 1, kept, "LDL^T instead of LU"});
      if (kept > 0)
        candidates.push_back({true, 1, 0, "LDL^T instead of LU, no factorisation kept"});
    }
    if (!ldlt_first && lu_concurrent > 1)
      candidates.push_back({false, 1, 0, "one factorisation at a time, none kept"});
    plan.symmetric = m_all_symmetric;
    auto take = [&](const Candidate& k) {
      plan.method =
          k.ldlt ? (S.options.out_of_core ? "mumps-ldlt out-of-core" : "mumps-ldlt") : "umfpack";
      plan.factor_bytes = k.ldlt ? ldlt_bytes() : kLuBytesPerEntry * plan.factor_entries;
      plan.concurrent = k.concurrent;
      plan.kept = k.kept;
      plan.adjustments = k.adjustment;
    };
    // The first that fits; when none does, the one that needs least (reported in the refusal).
    const Candidate* smallest = nullptr;
    double least = std::numeric_limits<double>::infinity();
    for (const Candidate& k : candidates) {
      take(k);
      if (plan.fits()) break;
      if (plan.added_bytes() < least) {
        least = plan.added_bytes();
        smallest = &k;
      }
    }
    if (!plan.fits()) take(*smallest);
    if (plan.fits()) {
      const bool ldlt = plan.method != "umfpack";
      std::call_once(m_ldlt_decided, [&] { m_ldlt = ldlt; });
      if (m_ldlt != ldlt) {
        plan.adjustments += std::string(plan.adjustments.empty() ? "" : "; ") +
                            "decided before the plan: " + (m_ldlt ? "LDL^T" : "LU");
      }
      if (plan.concurrent == 1) m_one_at_a_time.store(true);
      // Half of what is left to callers' caches, the other half to everything else (bases,
      // reference model, solve workspace, the allocator's slack); at most kReuseCap.
      const double left = plan.headroom.bytes - plan.added_bytes();
      plan.reuse_limit = static_cast<Index>(
          std::clamp(std::floor(0.5 * left / std::max(plan.factor_bytes, 1.0)), 0.0, kReuseCap));
      m_reuse_limit.store(plan.reuse_limit);
    }
    return plan;
  }

  SolverCounters counters() const override {
    std::lock_guard<std::mutex> lock(m_shared->counters->mutex);
    return m_shared->counters->c;
  }

 private:
  ComplexMatrix apply(std::span<const Complex> weights, const ComplexMatrix& x,
                      bool transposed) const {
    const SharedState& S = *m_shared;
    const char* what = transposed ? "apply_combination_transposed" : "apply_combination";
    if (weights.size() != S.term.size())
      throw InputError(std::string(what) + ": " + std::to_string(weights.size()) + " weights for " +
                       std::to_string(S.term.size()) + " terms");
    if (x.rows() != S.n)
      throw InputError(std::string(what) + ": x has " + std::to_string(x.rows()) +
                       " rows, expected " + std::to_string(S.n));
    std::vector<double> v;
    S.assemble_complex(weights, v);
    const Eigen::Map<const ComplexSparseMatrix> P(S.n, S.n, static_cast<Index>(S.nnz()),
                                                  S.Ap.data(), S.Ai.data(),
                                                  reinterpret_cast<const Complex*>(v.data()));
    if (transposed) return P.transpose() * x;
    return P * x;
  }

  void build_pattern() {
    SharedState& S = *m_shared;
    const int n = S.n;
    const std::size_t nt = S.term.size();
    // Column by column: merge the sorted row lists of all terms plus the diagonal.
    S.Ap.assign(static_cast<std::size_t>(n) + 1, 0);
    std::size_t bound = static_cast<std::size_t>(n);
    for (const SparseMatrix* T : S.term) bound += static_cast<std::size_t>(T->nonZeros());
    S.Ai.reserve(bound);
    std::vector<int> rows;
    for (int j = 0; j < n; ++j) {
      rows.clear();
      rows.push_back(j);
      for (const SparseMatrix* T : S.term) {
        const int* oi = T->outerIndexPtr();
        const int* ii = T->innerIndexPtr();
        rows.insert(rows.end(), ii + oi[j], ii + oi[j + 1]);
      }
      std::sort(rows.begin(), rows.end());
      rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
      S.Ai.insert(S.Ai.end(), rows.begin(), rows.end());
      S.Ap[static_cast<std::size_t>(j) + 1] = static_cast<int>(S.Ai.size());
    }
    S.Ai.shrink_to_fit();
    // Upper triangle (row <= column) and the union -> upper position map.
    std::vector<int> to_upper(S.Ai.size(), -1);
    S.Up.assign(static_cast<std::size_t>(n) + 1, 0);
    for (int j = 0; j < n; ++j) {
      for (int p = S.Ap[j]; p < S.Ap[j + 1]; ++p) {
        if (S.Ai[p] <= j) {
          to_upper[p] = static_cast<int>(S.Ui.size());
          S.Ui.push_back(S.Ai[p]);
        }
      }
      S.Up[static_cast<std::size_t>(j) + 1] = static_cast<int>(S.Ui.size());
    }
    // Per term: positions of its entries in the union (binary search within the column).
    S.map.resize(nt);
    S.umap.resize(nt);
    for (std::size_t k = 0; k < nt; ++k) {
      const SparseMatrix& T = *S.term[k];
      const int* oi = T.outerIndexPtr();
      const int* ii = T.innerIndexPtr();
      auto& m = S.map[k];
      auto& um = S.umap[k];
      m.resize(static_cast<std::size_t>(T.nonZeros()));
      um.resize(m.size());
      for (int j = 0; j < n; ++j) {
        const int* first = S.Ai.data() + S.Ap[j];
        const int* last = S.Ai.data() + S.Ap[j + 1];
        for (int e = oi[j]; e < oi[j + 1]; ++e) {
          const int p = static_cast<int>(std::lower_bound(first, last, ii[e]) - S.Ai.data());
          m[static_cast<std::size_t>(e)] = p;
          um[static_cast<std::size_t>(e)] = to_upper[p];
        }
      }
    }
    S.abs_sum.assign(S.nnz(), 0.0);
    for (std::size_t k = 0; k < nt; ++k) {
      const double* v = S.term[k]->valuePtr();
      for (std::size_t e = 0; e < S.map[k].size(); ++e) S.abs_sum[S.map[k][e]] += std::abs(v[e]);
    }
  }

  /// CHOLMOD LL' from a copy of the shared symbolic factor. Returns nullptr when the matrix is
  /// not positive definite (counted in failed_cholesky); the caller falls back to LU.
  std::shared_ptr<const Factorization> try_cholesky(std::vector<Complex>& w) {
    SharedState& S = *m_shared;
    const cholmod_factor* Lsym = S.cholmod_symbolic();
    const auto t0 = Clock::now();
    std::vector<double> x;
    S.assemble_upper(w, x);
    cholmod_sparse A = S.upper_view(x.data());
    LocalCommon cc;
    cholmod_factor* L = cholmod_copy_factor(const_cast<cholmod_factor*>(Lsym), &cc.c);
    if (!L) throw NumericalError("CHOLMOD: copying the symbolic factor failed (out of memory?)");
    const int ok = cholmod_factorize(&A, L, &cc.c);
    if (!ok || cc.c.status == CHOLMOD_NOT_POSDEF || L->minor < L->n) {
      const int status = cc.c.status;
      cholmod_free_factor(&L, &cc.c);
      if (status != CHOLMOD_NOT_POSDEF && status < CHOLMOD_OK)
        throw NumericalError("CHOLMOD factorisation failed with status " + std::to_string(status));
      const double dt = seconds_since(t0);
      S.counters->update([&](SolverCounters& c) {
        ++c.failed_cholesky;
        c.factorization_seconds += dt;
      });
      return nullptr;
    }
    const double rc = cholmod_rcond(L, &cc.c);
    if (!(rc >= S.options.singular_rcond)) {
      cholmod_free_factor(&L, &cc.c);
      throw_singular(w, rc, "CHOLMOD");
    }
    const double dt = seconds_since(t0);
    S.counters->update([&](SolverCounters& c) {
      ++c.factorizations;
      ++c.cholesky_factorizations;
      c.factorization_seconds += dt;
      c.factorization_flops += S.chol_fl;
      c.factor_entries += S.chol_lnz;
    });
    // The factor was allocated through cc; CHOLMOD's memory accounting is per common only, so
    // freeing it later through another common is fine.
    try {
      return std::make_shared<CholmodFactorization>(m_shared, std::move(w), L, rc);
    } catch (...) {  // bad_alloc: do not leak the factor
      cholmod_free_factor(&L, &cc.c);
      throw;
    }
  }

  std::shared_ptr<const Factorization> umfpack_lu(std::vector<Complex> w, bool is_cplx) {
    SharedState& S = *m_shared;
    void* symbolic = is_cplx ? S.umfpack_complex_symbolic() : S.umfpack_real_symbolic();
    const auto t0 = Clock::now();
    std::vector<double> x;
    void* numeric = nullptr;
    double info[UMFPACK_INFO];
    int status;
    if (is_cplx) {
      S.assemble_complex(w, x);
      status = umfpack_zi_numeric(S.Ap.data(), S.Ai.data(), x.data(), nullptr, symbolic, &numeric,
                                  S.umf_control, info);
    } else {
      S.assemble_real(w, x);
      status = umfpack_di_numeric(S.Ap.data(), S.Ai.data(), x.data(), symbolic, &numeric,
                                  S.umf_control, info);
    }
    auto free_numeric = [&] {
      if (!numeric) return;
      if (is_cplx)
        umfpack_zi_free_numeric(&numeric);
      else
        umfpack_di_free_numeric(&numeric);
    };
    // Negative status: error. Positive: warnings; of those only "singular" matters (determinant
    // under/overflow warnings are harmless for solves).
    if (status < 0) {
      free_numeric();
      throw NumericalError("UMFPACK numeric factorisation failed with status " +
                           std::to_string(status) +
                           (status == UMFPACK_ERROR_out_of_memory ? " (out of memory)" : ""));
    }
    const double rc = status == UMFPACK_WARNING_singular_matrix ? 0.0 : info[UMFPACK_RCOND];
    if (!(rc >= S.options.singular_rcond)) {
      free_numeric();
      throw_singular(w, rc, "UMFPACK");
    }
    const double dt = seconds_since(t0);
    S.counters->update([&](SolverCounters& c) {
      ++c.factorizations;
      ++c.lu_factorizations;
      if (is_cplx) ++c.complex_factorizations;
      c.factorization_seconds += dt;
      // UMFPACK counts real flops (a complex multiply-subtract as 8).
      c.factorization_flops += std::max(0.0, info[UMFPACK_FLOPS]);
      c.factor_entries += std::max(0.0, info[UMFPACK_LNZ]) + std::max(0.0, info[UMFPACK_UNZ]);
    });
    // The values are needed in the solves only for iterative refinement.
    if (S.options.refinement_steps == 0) std::vector<double>().swap(x);
    try {
      return std::make_shared<UmfpackFactorization>(m_shared, std::move(w), std::move(x), numeric,
                                                    is_cplx, rc);
    } catch (...) {  // bad_alloc: do not leak the LU factors
      free_numeric();
      throw;
    }
  }

  /// Complex symmetric LDL^T with MUMPS; the first one's ordering serves the next ones.
  std::shared_ptr<const Factorization> mumps_ldlt(std::vector<Complex> w) {
    SharedState& S = *m_shared;
    std::vector<int> order;
    {
      std::lock_guard<std::mutex> lock(S.analysis_mutex);
      S.fill_mumps_pattern();
      order = S.mumps_order;
    }
    const auto t0 = Clock::now();
    std::vector<Complex> x;
    S.assemble_upper_complex(w, x);
    detail::MumpsOutOfCore out_of_core;
    if (S.options.out_of_core) {
      const char* tmp = std::getenv("TMPDIR");
      out_of_core.dir = tmp != nullptr && *tmp != '\0' ? tmp : "/tmp";
    }
    auto f = std::make_unique<detail::MumpsLdlt>(
        S.mumps_pattern, x, order, S.options.singular_rcond, S.options.ordering, out_of_core);
    if (f->singular()) throw_singular(w, 0.0, "MUMPS LDL^T");
    const bool analysed = order.empty();
    if (analysed) {
      std::lock_guard<std::mutex> lock(S.analysis_mutex);
      if (S.mumps_order.empty()) S.mumps_order = f->pivot_order();
    }
    const double dt = seconds_since(t0);
    S.counters->update([&](SolverCounters& c) {
      if (analysed) ++c.symbolic_analyses;
      ++c.factorizations;
      ++c.ldlt_factorizations;
      ++c.complex_factorizations;
      c.factorization_seconds += dt;
      c.factorization_flops += f->flops();
      c.factor_entries += static_cast<double>(f->factor_entries());
    });
    return std::make_shared<MumpsFactorization>(m_shared, std::move(w), std::move(f));
  }

  /// Whether complex symmetric combinations go to MUMPS (decided once; see
  /// SolverOptions::complex_symmetric). "auto" predicts an LU's memory from CHOLMOD's analysis of
  /// the pattern: UMFPACK's symmetric strategy stores about 2 nnz(L) complex entries with their
  /// indices, some 40 bytes per entry of L (the 50 400-DOF solid of docs/benchmarks.md: 730 MB
  /// predicted from nnz(L) = 1.8e7, 750 MB measured).
  bool use_ldlt() const {
    std::call_once(m_ldlt_decided, [&] { m_ldlt = use_ldlt_by_options(); });
    return m_ldlt;
  }

  /// The choice by the options alone (before any memory plan): complex_symmetric and out_of_core,
  /// and under "auto" the LUs of all threads against ldlt_memory_fraction of the physical memory.
  bool use_ldlt_by_options() const {
    const SharedState& S = *m_shared;
    if (S.options.out_of_core) return true;
    if (S.options.complex_symmetric != "auto") return S.options.complex_symmetric == "ldlt";
    const double threads = std::max(1, thread_budget().limit);
    const double physical =
        static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGESIZE));
    const double budget = S.options.ldlt_memory_fraction * physical;
    auto too_large = [&](double lnz) { return threads * kLuBytesPerEntry * lnz > budget; };
    // A dense factor bounds nnz(L): small models need no analysis to stay with LU.
    const double n = S.n;
    return physical > 0.0 && too_large(0.5 * n * (n + 1.0)) &&
           too_large(m_shared->cholmod_symbolic_nnz());
  }

  /// One LDL^T factorisation's memory, MUMPS's estimate from its analysis (in core or out of
  /// core, as the options say); the analysis's pivot order serves the first factorisation.
  double ldlt_bytes() {
    if (m_ldlt_bytes > 0.0) return m_ldlt_bytes;
    SharedState& S = *m_shared;
    std::lock_guard<std::mutex> lock(S.analysis_mutex);
    S.fill_mumps_pattern();
    // Representative values for the analysis (its scaling and matching read them): sum_k T_k.
    std::vector<Complex> values;
    const std::vector<Complex> ones(S.term.size(), Complex(1.0, 0.0));
    S.assemble_upper_complex(ones, values);
    const detail::MumpsPrediction prediction =
        detail::mumps_predict(S.mumps_pattern, values, S.options.ordering);
    if (S.mumps_order.empty()) S.mumps_order = prediction.pivot_order;
    S.counters->update([&](SolverCounters& c) { ++c.symbolic_analyses; });
    m_ldlt_bytes = S.options.out_of_core ? prediction.out_of_core_bytes : prediction.in_core_bytes;
    return m_ldlt_bytes;
  }

  std::shared_ptr<SharedState> m_shared;
  std::vector<std::string> m_names;
  bool m_all_symmetric = false;  // every coefficient is symmetric
  mutable std::once_flag m_ldlt_decided;
  mutable bool m_ldlt = false;               // complex symmetric combinations go to MUMPS
  std::atomic<bool> m_one_at_a_time{false};  // the memory plan allows one factorisation at once
  double m_ldlt_bytes = 0.0;                 // MUMPS's estimate, once analysed
  std::atomic<Index> m_reuse_limit{kUnlimitedReuse};  // by the memory plan
};

}  // namespace

namespace detail {
std::atomic<bool> g_serial_solves{false};
}  // namespace detail

namespace {

template <class System>
std::unique_ptr<ShiftedSolver> make_for(const System& sys, const Model* as_model,
                                        const SolverOptions& options) {
  if (options.backend == "petsc") {
    options.validate();
    // The PETSc backend copies the coefficients into its distributed matrices.
    std::unique_ptr<ShiftedSolver> solver = as_model != nullptr
                                                ? detail::make_petsc_solver(*as_model)
                                                : detail::make_petsc_solver(Model(sys));
    detail::g_serial_solves.store(true);
    return solver;
  }
  return std::make_unique<SuiteSparseSolver>(sys, options);
}

}  // namespace

std::unique_ptr<ShiftedSolver> make_shifted_solver(const Model& model,
                                                   const SolverOptions& options) {
  return std::visit([&](const auto& sys) { return make_for(sys, &model, options); }, model);
}

std::unique_ptr<ShiftedSolver> make_shifted_solver(const SecondOrderModel& model,
                                                   const SolverOptions& options) {
  return make_for(model, nullptr, options);
}

std::unique_ptr<ShiftedSolver> make_shifted_solver(const DescriptorModel& model,
                                                   const SolverOptions& options) {
  return make_for(model, nullptr, options);
}

}  // namespace ecmor
