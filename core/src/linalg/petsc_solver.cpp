// The PETSc backend of the shifted solver (issue 9): the combinations sum_k w_k T_k are assembled
// as distributed PETSc matrices (rows split over the MPI ranks) and factorised by MUMPS, PETSc's
// distributed sparse direct solver, in the complex-scalar build of PETSc.
//
// Execution model. Every rank runs the whole ecmor driver on the same configuration; the model
// and the reduced quantities (bases of N x r, reduced matrices) are replicated, and every
// factorisation and solve is a collective operation that all ranks enter in the same order. The
// memory that grows fastest with N, the sparse LU factors, is distributed by MUMPS. A right-hand
// side arrives replicated; each rank contributes its rows, and the solution is gathered on every
// rank. Decisions that could differ between ranks (time limits, signals) are made collective by
// any_process() (parallel.hpp).
#include "linalg/petsc_solver.hpp"

#include <fmt/format.h>
#include <petscksp.h>

#include "linalg/term_products.hpp"
#ifdef ECMOR_HAVE_SLEPC
#include <slepceps.h>
#endif

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"

namespace ecmor::detail {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// PETSc's own error text for a return code, as an ecmor::NumericalError naming the call.
void check(PetscErrorCode code, const char* call) {
  if (code == 0) return;
  const char* text = nullptr;
  PetscErrorMessage(code, &text, nullptr);
  throw NumericalError(fmt::format("PETSc backend: {} failed (PETSc error {}: {})", call,
                                   static_cast<int>(code), text ? text : "unknown"));
}
#define ECMOR_PETSC(call) check((call), #call)

std::once_flag g_init_once;

// With SLEPc, SLEPc starts and ends PETSc (and MPI) when they have not started yet.
#ifdef ECMOR_HAVE_SLEPC
constexpr auto kLibraryInitialized = &SlepcInitialized;
constexpr auto kInitializeLibrary = &SlepcInitializeNoArguments;
constexpr auto kFinalizeLibrary = &SlepcFinalize;
#else
constexpr auto kLibraryInitialized = &PetscInitialized;
constexpr auto kInitializeLibrary = &PetscInitializeNoArguments;
constexpr auto kFinalizeLibrary = &PetscFinalize;
#endif

void finalize_petsc() {
  PetscBool finalized = PETSC_FALSE;
  PetscFinalized(&finalized);
  if (!finalized) kFinalizeLibrary();
}

// PETSc (and MPI) start on first use: every rank creates the solver at the same point of the run.
void ensure_petsc() {
  std::call_once(g_init_once, [] {
    PetscBool initialized = PETSC_FALSE;
    kLibraryInitialized(&initialized);
    if (!initialized) {
      ECMOR_PETSC(kInitializeLibrary());
      std::atexit(finalize_petsc);
    }
    // Errors come back as return codes (turned into exceptions here), not printed tracebacks.
    // ECMOR_PETSC_TRACEBACK=1 also prints PETSc's own traceback (where in PETSc or SLEPc, and
    // its detailed message), for debugging the backend.
    const char* traceback = std::getenv("ECMOR_PETSC_TRACEBACK");
    if (traceback != nullptr && std::string(traceback) == "1") {
      PetscPushErrorHandler(PetscTraceBackErrorHandler, nullptr);
    } else {
      PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
    }
  });
}

struct Terms {
  Index n = 0;
  std::vector<SparseMatrix> t;  // T_k, compressed (descriptor: T_0 = -A, T_1 = E)
};

// The owned rows' combined pattern (sorted column indices per row) and each term's value
// positions in it, so that a combination is assembled row by row without searching.
struct RowPattern {
  PetscInt row_begin = 0, row_end = 0;
  std::vector<PetscInt> offset;  // size rows + 1
  std::vector<PetscInt> cols;
  std::vector<PetscInt> diag_nnz, off_nnz;                          // for preallocation
  std::vector<std::vector<std::pair<PetscInt, PetscInt>>> scatter;  // per term: (value idx, pos)
};

// The PETSc objects of one MUMPS factorisation: the matrix, its KSP (preonly + LU) and the work
// vectors of a solve.
struct Slot {
  Mat A = nullptr;
  KSP ksp = nullptr;
  Vec x = nullptr, b = nullptr, all = nullptr;
  VecScatter scatter = nullptr;

  void destroy() noexcept {
    PetscBool finalized = PETSC_FALSE;
    PetscFinalized(&finalized);
    if (finalized) return;  // the objects went with PETSc
    if (all) VecDestroy(&all);
    if (scatter) VecScatterDestroy(&scatter);
    if (x) VecDestroy(&x);
    if (b) VecDestroy(&b);
    if (ksp) KSPDestroy(&ksp);
    if (A) MatDestroy(&A);
    *this = Slot{};
  }
};

// What the solver and every factorisation it made share: the owned rows' pattern and values
// (to assemble and refill combinations), the counters, and the pool of analysed idle slots.
//
// A factorisation co-owns this state, so it stays valid after its solver is destroyed, as
// shifted_solver.hpp promises of every backend. The driver (run_reduction) destroys the solver
// before the reducers, whose factorisations are released afterwards. When a factorisation held a
// reference to the solver instead, its release ran give_back() on the freed solver: the decision
// "park this slot or destroy it" (m_idle.size() < kIdleSlots) and the parked slot were read from
// freed memory whose contents depend on each rank's own heap history. A rank that parked a slot
// which another rank destroyed, or destroyed a stale one, entered MUMPS's collective teardown
// (MatDestroy_MUMPS) of a different instance than the other rank: the two-rank runs hung in
// zmumps_c (valgrind: invalid reads of the freed solver in ~PetscFactorization -> give_back).
// Now the slots are destroyed only by the release of a factorisation or of the last owner of
// this state, at the same point of the program on every rank.
class SolverState {
 public:
  explicit SolverState(const Terms& terms) : m_n(terms.n) { build_pattern(terms); }
  ~SolverState() {
    for (Slot& slot : m_idle) slot.destroy();
  }
  SolverState(const SolverState&) = delete;
  SolverState& operator=(const SolverState&) = delete;

  Index size() const { return m_n; }
  const RowPattern& pattern() const { return m_pattern; }

  // Every combination has the same pattern, so MUMPS's analysis (fill-reducing ordering and
  // symbolic factorisation) of one serves them all: a released factorisation leaves its analysed
  // objects here (at most kIdleSlots, each still holding its old factors), and the next
  // factorisation refills the matrix and refactorises numerically only. On a 10^5 triple chain
  // the analysis was 66% of the run (PETSc -log_view). Every rank releases and takes slots in the
  // same order, so the collective calls match.
  static constexpr std::size_t kIdleSlots = 1;
  Slot take_slot() const {
    std::lock_guard<std::mutex> lock(m_mutex);
    if (m_idle.empty()) return {};
    Slot slot = m_idle.back();
    m_idle.pop_back();
    return slot;
  }
  void give_back(Slot slot) const noexcept {
    {
      std::lock_guard<std::mutex> lock(m_mutex);
      if (m_idle.size() < kIdleSlots) {
        m_idle.push_back(slot);
        return;
      }
    }
    slot.destroy();
  }

  SolverCounters counters() const {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_counters;
  }
  void count(const std::function<void(SolverCounters&)>& f) const {
    std::lock_guard<std::mutex> lock(m_mutex);
    f(m_counters);
  }

  /// The combination sum_k w_k T_k as a distributed PETSc matrix (the caller destroys it).
  Mat assemble(std::span<const Complex> weights) const {
    const std::vector<PetscScalar> values = combination_values(weights);
    return make_matrix(m_pattern.diag_nnz, m_pattern.off_nnz, [&](Mat A) { set_rows(A, values); });
  }

  /// Overwrites the values of a matrix made by assemble() with another combination: the same
  /// nonzero pattern, so a factorisation of it keeps its analysis.
  void refill(Mat A, std::span<const Complex> weights) const {
    set_rows(A, combination_values(weights));
    ECMOR_PETSC(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
    ECMOR_PETSC(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  }

  /// Any N x N sparse matrix, distributed by the solver's rows (the caller destroys it).
  Mat distribute(const SparseMatrix& S) const {
    const RowPattern& p = m_pattern;
    const PetscInt local = p.row_end - p.row_begin;
    using RowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, PetscInt>;
    const RowMatrix R = S.middleRows(p.row_begin, local).template cast<double>();
    std::vector<PetscInt> diag(static_cast<std::size_t>(local), 0), off(diag);
    for (PetscInt r = 0; r < local; ++r)
      for (RowMatrix::InnerIterator it(R, r); it; ++it)
        ++((it.col() >= p.row_begin && it.col() < p.row_end) ? diag
                                                             : off)[static_cast<std::size_t>(r)];
    return make_matrix(diag, off, [&](Mat A) {
      std::vector<PetscInt> cols;
      std::vector<PetscScalar> values;
      for (PetscInt r = 0; r < local; ++r) {
        cols.clear();
        values.clear();
        for (RowMatrix::InnerIterator it(R, r); it; ++it) {
          cols.push_back(it.col());
          values.emplace_back(it.value(), 0.0);
        }
        const PetscInt row = p.row_begin + r;
        ECMOR_PETSC(MatSetValues(A, 1, &row, static_cast<PetscInt>(cols.size()), cols.data(),
                                 values.data(), INSERT_VALUES));
      }
    });
  }

 private:
  // The owned rows' values of sum_k w_k T_k, in the combined pattern.
  std::vector<PetscScalar> combination_values(std::span<const Complex> weights) const {
    const RowPattern& p = m_pattern;
    std::vector<PetscScalar> values(p.cols.size(), PetscScalar(0.0));
    for (std::size_t k = 0; k < p.scatter.size(); ++k) {
      const PetscScalar w(weights[k].real(), weights[k].imag());
      if (w == PetscScalar(0.0)) continue;
      const std::vector<double>& v = m_row_values[k];
      for (const auto& [value_index, pos] : p.scatter[k])
        values[static_cast<std::size_t>(pos)] += w * v[static_cast<std::size_t>(value_index)];
    }
    return values;
  }

  void set_rows(Mat A, const std::vector<PetscScalar>& values) const {
    const RowPattern& p = m_pattern;
    for (PetscInt r = 0; r < p.row_end - p.row_begin; ++r) {
      const PetscInt row = p.row_begin + r;
      const PetscInt b = p.offset[static_cast<std::size_t>(r)];
      const PetscInt e = p.offset[static_cast<std::size_t>(r) + 1];
      ECMOR_PETSC(
          MatSetValues(A, 1, &row, e - b, p.cols.data() + b, values.data() + b, INSERT_VALUES));
    }
  }

  // A distributed AIJ matrix of the solver's row split, preallocated with `diag` / `off` entries
  // per owned row inside / outside the diagonal block, filled by `fill` (MatSetValues) and
  // assembled; destroyed again if anything throws.
  template <class Fill>
  Mat make_matrix(const std::vector<PetscInt>& diag, const std::vector<PetscInt>& off,
                  Fill&& fill) const {
    const PetscInt local = m_pattern.row_end - m_pattern.row_begin;
    const auto n = static_cast<PetscInt>(m_n);
    Mat A = nullptr;
    ECMOR_PETSC(MatCreate(PETSC_COMM_WORLD, &A));
    try {
      ECMOR_PETSC(MatSetSizes(A, local, local, n, n));
      ECMOR_PETSC(MatSetType(A, MATAIJ));
      ECMOR_PETSC(MatSeqAIJSetPreallocation(A, 0, diag.data()));
      ECMOR_PETSC(MatMPIAIJSetPreallocation(A, 0, diag.data(), 0, off.data()));
      fill(A);
      ECMOR_PETSC(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
      ECMOR_PETSC(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
    } catch (...) {
      MatDestroy(&A);
      throw;
    }
    return A;
  }

  void build_pattern(const Terms& terms) {
    const Index n = terms.n;
    // Ownership as PETSc's PETSC_DECIDE would choose it: contiguous blocks of rows.
    PetscInt local = PETSC_DECIDE, global = static_cast<PetscInt>(n);
    ECMOR_PETSC(PetscSplitOwnership(PETSC_COMM_WORLD, &local, &global));
    PetscInt end = 0;
    ECMOR_PETSC(MPI_Scan(&local, &end, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
    RowPattern& p = m_pattern;
    p.row_begin = end - local;
    p.row_end = end;
    // Row-major copies of the owned rows of every term, merged into one sorted pattern.
    std::vector<Eigen::SparseMatrix<double, Eigen::RowMajor, PetscInt>> rows;
    for (const SparseMatrix& t : terms.t)
      rows.emplace_back(t.middleRows(p.row_begin, local).template cast<double>());
    p.offset.assign(static_cast<std::size_t>(local) + 1, 0);
    p.scatter.assign(terms.t.size(), {});
    std::vector<PetscInt> merged;
    for (PetscInt r = 0; r < local; ++r) {
      merged.clear();
      for (const auto& R : rows)
        for (typename std::decay_t<decltype(R)>::InnerIterator it(R, r); it; ++it)
          merged.push_back(static_cast<PetscInt>(it.col()));
      merged.push_back(p.row_begin + r);  // the diagonal always (shifts put values there)
      std::sort(merged.begin(), merged.end());
      merged.erase(std::unique(merged.begin(), merged.end()), merged.end());
      PetscInt diag = 0;
      for (PetscInt c : merged) diag += (c >= p.row_begin && c < p.row_end) ? 1 : 0;
      p.diag_nnz.push_back(diag);
      p.off_nnz.push_back(static_cast<PetscInt>(merged.size()) - diag);
      const PetscInt base = static_cast<PetscInt>(p.cols.size());
      p.cols.insert(p.cols.end(), merged.begin(), merged.end());
      p.offset[static_cast<std::size_t>(r) + 1] = static_cast<PetscInt>(p.cols.size());
      for (std::size_t k = 0; k < rows.size(); ++k) {
        const auto& R = rows[k];
        for (typename std::decay_t<decltype(R)>::InnerIterator it(R, r); it; ++it) {
          const auto pos =
              std::lower_bound(merged.begin(), merged.end(), static_cast<PetscInt>(it.col())) -
              merged.begin();
          const auto value_index = static_cast<PetscInt>(&it.value() - R.valuePtr());
          p.scatter[k].emplace_back(value_index, base + static_cast<PetscInt>(pos));
        }
      }
    }
    m_row_values.clear();
    for (const auto& R : rows) m_row_values.emplace_back(R.valuePtr(), R.valuePtr() + R.nonZeros());
  }

  Index m_n = 0;
  RowPattern m_pattern;
  std::vector<std::vector<double>> m_row_values;  // owned rows' values of each term
  mutable std::mutex m_mutex;                     // guards m_counters and m_idle
  mutable SolverCounters m_counters;
  mutable std::vector<Slot> m_idle;
};

class PetscSolver final : public detail::TermProducts<PetscSolver> {
  friend class detail::TermProducts<PetscSolver>;

 public:
  explicit PetscSolver(Terms terms) : m_terms(std::move(terms)) {
    ensure_petsc();
    m_state = std::make_shared<SolverState>(m_terms);
  }
  PetscSolver(const PetscSolver&) = delete;
  PetscSolver& operator=(const PetscSolver&) = delete;

  Index size() const override { return m_terms.n; }
  Index terms() const override { return static_cast<Index>(m_terms.t.size()); }
  std::string backend() const override {
    int size = 1;
    MPI_Comm_size(PETSC_COMM_WORLD, &size);
    return fmt::format("petsc (MUMPS, {} rank{})", size, size == 1 ? "" : "s");
  }
  bool concurrent() const override { return false; }

  std::shared_ptr<const Factorization> factorize_combination(
      std::span<const Complex> weights) override;

  SolverCounters counters() const override { return m_state->counters(); }

 private:
  // sum_k w_k T_k x (or T_k^T x) on the replicated terms, with real sparse products on the real
  // and imaginary parts of x: no complex or transposed copy of a term (a hot path of the Krylov
  // recurrences and of low-rank ADI).
  ComplexMatrix apply(std::span<const Complex> weights, const ComplexMatrix& x,
                      bool transposed) const {
    require_weights(weights);
    if (x.rows() != m_terms.n)
      throw InputError(fmt::format(
          "PETSc backend: {}: x has {} rows, expected {}",
          transposed ? "apply_combination_transposed" : "apply_combination", x.rows(), m_terms.n));
    const Matrix xr = x.real(), xi = x.imag();
    ComplexMatrix y = ComplexMatrix::Zero(m_terms.n, x.cols());
    Matrix tr, ti;
    for (std::size_t k = 0; k < m_terms.t.size(); ++k) {
      if (weights[k] == Complex(0.0)) continue;
      const SparseMatrix& t = m_terms.t[k];
      if (transposed) {
        tr.noalias() = t.transpose() * xr;
        ti.noalias() = t.transpose() * xi;
      } else {
        tr.noalias() = t * xr;
        ti.noalias() = t * xi;
      }
      const double a = weights[k].real(), b = weights[k].imag();
      y.real() += a * tr - b * ti;
      y.imag() += b * tr + a * ti;
    }
    return y;
  }

  void require_weights(std::span<const Complex> weights) const {
    if (weights.size() != m_terms.t.size())
      throw InputError(fmt::format("PETSc backend: {} weights for {} coefficient matrices",
                                   weights.size(), m_terms.t.size()));
  }

  Terms m_terms;
  std::shared_ptr<SolverState> m_state;
};

// One MUMPS LU of a combination: its matrix, KSP (preonly + LU) and work vectors.
class PetscFactorization final : public Factorization {
 public:
  PetscFactorization(std::shared_ptr<const SolverState> state, std::vector<Complex> weights)
      : m_state(std::move(state)), m_weights(std::move(weights)) {
    for (const Complex& w : m_weights) m_complex = m_complex || w.imag() != 0.0;
  }
  ~PetscFactorization() override {
    if (m_reusable) {
      m_state->give_back(m_slot);
    } else {
      m_slot.destroy();
    }
  }
  PetscFactorization(const PetscFactorization&) = delete;
  PetscFactorization& operator=(const PetscFactorization&) = delete;

  void factorize() {
    m_slot = m_state->take_slot();
    if (m_slot.ksp != nullptr) {
      // Analysed before: new values, numeric factorisation only (PCSetUp sees the same nonzero
      // pattern).
      m_state->refill(m_slot.A, m_weights);
      ECMOR_PETSC(KSPSetOperators(m_slot.ksp, m_slot.A, m_slot.A));
    } else {
      m_analysed = true;
      m_slot.A = m_state->assemble(m_weights);
      ECMOR_PETSC(KSPCreate(PETSC_COMM_WORLD, &m_slot.ksp));
      ECMOR_PETSC(KSPSetOperators(m_slot.ksp, m_slot.A, m_slot.A));
      ECMOR_PETSC(KSPSetType(m_slot.ksp, KSPPREONLY));
      PC pc = nullptr;
      ECMOR_PETSC(KSPGetPC(m_slot.ksp, &pc));
      ECMOR_PETSC(PCSetType(pc, PCLU));
      ECMOR_PETSC(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
      ECMOR_PETSC(PCFactorSetUpMatSolverType(pc));
      Mat F = nullptr;
      ECMOR_PETSC(PCFactorGetMatrix(pc, &F));
      // Null-pivot detection (ICNTL(24) = 1, MUMPS's default threshold CNTL(3) relative to the
      // matrix norm): an exactly singular combination (K of a free-floating body at s = 0)
      // factorises with a rounding-sized pivot, which MUMPS otherwise accepts.
      ECMOR_PETSC(MatMumpsSetIcntl(F, 24, 1));
      ECMOR_PETSC(MatCreateVecs(m_slot.A, &m_slot.x, &m_slot.b));
      ECMOR_PETSC(VecScatterCreateToAll(m_slot.x, &m_slot.scatter, &m_slot.all));
    }
    ECMOR_PETSC(KSPSetUp(m_slot.ksp));
    // MUMPS reports a singular matrix through the factor's error state and INFOG(28), the number
    // of null pivots (the same on every rank).
    PC pc = nullptr;
    ECMOR_PETSC(KSPGetPC(m_slot.ksp, &pc));
    Mat F = nullptr;
    ECMOR_PETSC(PCFactorGetMatrix(pc, &F));
    MatFactorError err = MAT_FACTOR_NOERROR;
    ECMOR_PETSC(MatFactorGetError(F, &err));
    PetscInt null_pivots = 0;
    ECMOR_PETSC(MatMumpsGetInfog(F, 28, &null_pivots));
    if (err != MAT_FACTOR_NOERROR || null_pivots > 0) {
      std::string w;
      for (const Complex& c : m_weights)
        w += fmt::format("{}{:g}{:+g}i", w.empty() ? "" : ", ", c.real(), c.imag());
      throw NumericalError(fmt::format(
          "PETSc backend: MUMPS could not factorise the combination with weights ({}): the "
          "matrix is (numerically) singular ({} null pivot{}, MatFactorError {})",
          w, null_pivots, null_pivots == 1 ? "" : "s", static_cast<int>(err)));
    }
    // RINFOG(3), the elimination's operations, and INFOG(29), the factors' entries: the same
    // on every rank.
    PetscReal flops = 0.0;
    ECMOR_PETSC(MatMumpsGetRinfog(F, 3, &flops));
    PetscInt entries = 0;
    ECMOR_PETSC(MatMumpsGetInfog(F, 29, &entries));
    // MUMPS counts a complex multiply-add as 2 operations, like a real one (mumps_ldlt.cpp).
    m_flops = (PetscDefined(USE_COMPLEX) ? 4.0 : 1.0) * static_cast<double>(flops);
    m_factor_entries = static_cast<double>(entries);
    m_reusable = true;  // a failed factorisation's objects are not handed on
  }
  double flops() const { return m_flops; }
  double factor_entries() const { return m_factor_entries; }

  /// True when this factorisation needed MUMPS's analysis (no analysed slot was idle).
  bool analysed() const { return m_analysed; }

  Index size() const override { return m_state->size(); }
  bool is_complex() const override { return m_complex; }
  std::string method() const override { return "mumps"; }
  const std::vector<Complex>& weights() const override { return m_weights; }
  double rcond() const override { return std::numeric_limits<double>::quiet_NaN(); }

  Matrix solve(const Matrix& B) const override {
    if (m_complex) throw NumericalError("PETSc backend: real solve with a complex factorisation");
    return run(B.cast<Complex>(), false).real();
  }
  ComplexMatrix solve(const ComplexMatrix& B) const override { return run(B, false); }
  Matrix solve_transposed(const Matrix& B) const override {
    if (m_complex) throw NumericalError("PETSc backend: real solve with a complex factorisation");
    return run(B.cast<Complex>(), true).real();
  }
  ComplexMatrix solve_transposed(const ComplexMatrix& B) const override { return run(B, true); }

  const SolverState& state() const { return *m_state; }
  Mat matrix() const { return m_slot.A; }
  KSP ksp() const { return m_slot.ksp; }

 private:
  ComplexMatrix run(const ComplexMatrix& B, bool transposed) const {
    if (B.rows() != m_state->size())
      throw InputError(fmt::format("Factorization::solve: right-hand side has {} rows, expected {}",
                                   B.rows(), m_state->size()));
    const auto t0 = Clock::now();
    const RowPattern& p = m_state->pattern();
    ComplexMatrix X(B.rows(), B.cols());
    for (Index j = 0; j < B.cols(); ++j) {
      PetscScalar* b = nullptr;
      ECMOR_PETSC(VecGetArray(m_slot.b, &b));
      for (PetscInt r = p.row_begin; r < p.row_end; ++r) {
        const Complex v = B(r, j);
        b[r - p.row_begin] = PetscScalar(v.real(), v.imag());
      }
      ECMOR_PETSC(VecRestoreArray(m_slot.b, &b));
      if (transposed) {
        ECMOR_PETSC(KSPSolveTranspose(m_slot.ksp, m_slot.b, m_slot.x));
      } else {
        ECMOR_PETSC(KSPSolve(m_slot.ksp, m_slot.b, m_slot.x));
      }
      ECMOR_PETSC(
          VecScatterBegin(m_slot.scatter, m_slot.x, m_slot.all, INSERT_VALUES, SCATTER_FORWARD));
      ECMOR_PETSC(
          VecScatterEnd(m_slot.scatter, m_slot.x, m_slot.all, INSERT_VALUES, SCATTER_FORWARD));
      const PetscScalar* x = nullptr;
      ECMOR_PETSC(VecGetArrayRead(m_slot.all, &x));
      for (Index r = 0; r < B.rows(); ++r)
        X(r, j) = Complex(PetscRealPart(x[r]), PetscImaginaryPart(x[r]));
      ECMOR_PETSC(VecRestoreArrayRead(m_slot.all, &x));
    }
    const double dt = seconds_since(t0);
    m_state->count([&](SolverCounters& c) {
      c.solves += B.cols();
      c.solve_seconds += dt;
    });
    if (!X.allFinite())
      throw NumericalError("PETSc backend: the solution has non-finite entries (singular shift?)");
    return X;
  }

  std::shared_ptr<const SolverState> m_state;  // co-owned: see SolverState
  std::vector<Complex> m_weights;
  bool m_complex = false;
  double m_flops = 0.0;
  double m_factor_entries = 0.0;
  Slot m_slot;
  bool m_reusable = false;
  bool m_analysed = false;
};

std::shared_ptr<const Factorization> PetscSolver::factorize_combination(
    std::span<const Complex> weights) {
  require_weights(weights);
  const auto t0 = Clock::now();
  auto f = std::make_shared<PetscFactorization>(
      m_state, std::vector<Complex>(weights.begin(), weights.end()));
  f->factorize();
  const double dt = seconds_since(t0);
  const bool cplx = f->is_complex();
  m_state->count([&](SolverCounters& c) {
    if (f->analysed()) ++c.symbolic_analyses;
    ++c.factorizations;
    ++c.lu_factorizations;
    if (cplx) ++c.complex_factorizations;
    c.factorization_seconds += dt;
    c.factorization_flops += f->flops();
    c.factor_entries += f->factor_entries();
  });
  return f;
}

#ifdef ECMOR_HAVE_SLEPC
// ---------------------------------------------------------------------------------------------
// SLEPc: the modal reducer's K phi = lambda M phi near sigma, on the distributed vectors.
//
// The problem handed to SLEPc is the pencil (K - sigma M, M), a generalized Hermitian one (GHEP:
// M-inner products), whose eigenvalues mu = lambda - sigma nearest the target 0 are wanted, by
// SLEPc's own shift-and-invert (with purification of the eigenvectors). Its spectral
// transformation keeps K - sigma M as an operator only (ST_MATMODE_SHELL: nothing is copied or
// assembled), and its linear solver is PREONLY with a shell preconditioner that applies the MUMPS
// factors ecmor already has: (K - sigma M)^-1 exactly. So no second factorisation is made.
// Then lambda = sigma + mu.

struct ShiftInvertContext {
  const PetscFactorization* F = nullptr;
  Index applications = 0;
};

PetscErrorCode apply_factors(PC pc, Vec x, Vec y) {
  ShiftInvertContext* c = nullptr;
  PetscCall(PCShellGetContext(pc, &c));
  PetscCall(KSPSolve(c->F->ksp(), x, y));
  ++c->applications;
  return 0;
}

// SLEPc's basic test (tolerance, iteration budget), and the run's stop condition, which must not
// throw through SLEPc.
PetscErrorCode stopping_test(EPS eps, PetscInt its, PetscInt max_it, PetscInt nconv, PetscInt nev,
                             EPSConvergedReason* reason, void* ctx) {
  PetscCall(EPSStoppingBasic(eps, its, max_it, nconv, nev, reason, ctx));
  if (*reason != EPS_CONVERGED_ITERATING) return 0;
  bool stop = false;
  try {
    stop = interrupt_requested();
  } catch (...) {
    stop = false;
  }
  if (stop) *reason = EPS_CONVERGED_USER;
  return 0;
}

// Owns the PETSc objects of one eigensolve.
struct EpsObjects {
  EPS eps = nullptr;
  Mat M = nullptr;
  Vec x = nullptr, all = nullptr;
  VecScatter scatter = nullptr;
  ~EpsObjects() {
    if (scatter) VecScatterDestroy(&scatter);
    if (all) VecDestroy(&all);
    if (x) VecDestroy(&x);
    if (eps) EPSDestroy(&eps);
    if (M) MatDestroy(&M);
  }
};

// A start vector from the seed: the whole vector is drawn on every rank (the same numbers), and
// each rank keeps its rows, so the start does not depend on the number of ranks.
void set_start_vector(EpsObjects& o, Index n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  PetscInt lo = 0, hi = 0;
  ECMOR_PETSC(VecGetOwnershipRange(o.x, &lo, &hi));
  PetscScalar* a = nullptr;
  ECMOR_PETSC(VecGetArray(o.x, &a));
  for (PetscInt r = 0; r < static_cast<PetscInt>(n); ++r) {
    const double v = uniform(rng);
    if (r >= lo && r < hi) a[r - lo] = PetscScalar(v, 0.0);
  }
  ECMOR_PETSC(VecRestoreArray(o.x, &a));
  ECMOR_PETSC(EPSSetInitialSpace(o.eps, 1, &o.x));
}

// Sets up o.eps for the pencil (K - sigma M, M) as the comment at the top of this section says:
// Krylov-Schur on a GHEP, target 0, SLEPc's shift-and-invert applying F's factors through a shell
// preconditioner with context ctx, the run's stopping test, and a seeded start vector.
// SLEPc's calling sequence, kept as one: each call configures an object reached through the one
// before (EPS -> ST -> KSP -> PC), all owned by the EPS and put together only in EPSSolve; split,
// the pieces would hand half-configured handles to each other and none would read on its own.
// The shell preconditioner keeps a pointer to ctx, which must outlive EPSSolve.
void configure_shift_invert(EpsObjects& o, const PetscFactorization& F, ShiftInvertContext& ctx,
                            const EigenOptions& options) {
  ECMOR_PETSC(EPSCreate(PETSC_COMM_WORLD, &o.eps));
  ECMOR_PETSC(EPSSetOperators(o.eps, F.matrix(), o.M));
  ECMOR_PETSC(EPSSetProblemType(o.eps, EPS_GHEP));
  ECMOR_PETSC(EPSSetType(o.eps, EPSKRYLOVSCHUR));
  ECMOR_PETSC(EPSSetTarget(o.eps, 0.0));
  ECMOR_PETSC(EPSSetWhichEigenpairs(o.eps, EPS_TARGET_MAGNITUDE));
  ECMOR_PETSC(EPSSetDimensions(o.eps, static_cast<PetscInt>(options.nev),
                               options.ncv > 0 ? static_cast<PetscInt>(options.ncv) : PETSC_DEFAULT,
                               PETSC_DEFAULT));
  // ARPACK's tolerance 0 means machine precision; SLEPc's default (1e-8) is looser.
  const double tol = options.tolerance > 0.0 ? options.tolerance : 1e-12;
  ECMOR_PETSC(EPSSetTolerances(o.eps, tol, static_cast<PetscInt>(options.max_iterations)));
  ST st = nullptr;
  ECMOR_PETSC(EPSGetST(o.eps, &st));
  ECMOR_PETSC(STSetType(st, STSINVERT));
  ECMOR_PETSC(STSetMatMode(st, ST_MATMODE_SHELL));
  KSP ksp = nullptr;
  ECMOR_PETSC(STGetKSP(st, &ksp));
  ECMOR_PETSC(KSPSetType(ksp, KSPPREONLY));
  PC pc = nullptr;
  ECMOR_PETSC(KSPGetPC(ksp, &pc));
  ECMOR_PETSC(PCSetType(pc, PCSHELL));
  ECMOR_PETSC(PCShellSetContext(pc, &ctx));
  ECMOR_PETSC(PCShellSetApply(pc, apply_factors));
  if (options.seed != 0) set_start_vector(o, F.size(), options.seed);
  // The run's time limit and signals (interrupt.hpp) end the iteration at a restart: the stopping
  // test is called at the same iteration on every rank, so the collective stop test matches.
  ECMOR_PETSC(EPSSetStoppingTestFunction(o.eps, stopping_test, nullptr, nullptr));
}

// Runs the configured solve, counts its operator applications as solves of F, and returns the
// number of restarts. \throws Interrupted when the run's stop condition ended it, NumericalError
// when fewer than nev eigenpairs converged.
PetscInt solve_eps(EpsObjects& o, const PetscFactorization& F, const ShiftInvertContext& ctx,
                   Index nev, const std::string& where) {
  const auto t0 = Clock::now();
  ECMOR_PETSC(EPSSolve(o.eps));
  const double dt = seconds_since(t0);
  F.state().count([&](SolverCounters& c) {
    c.solves += ctx.applications;
    c.solve_seconds += dt;
  });
  EPSConvergedReason reason = EPS_CONVERGED_ITERATING;
  ECMOR_PETSC(EPSGetConvergedReason(o.eps, &reason));
  if (reason == EPS_CONVERGED_USER) throw Interrupted("interrupted in " + where);
  PetscInt nconv = 0, iterations = 0;
  ECMOR_PETSC(EPSGetConverged(o.eps, &nconv));
  ECMOR_PETSC(EPSGetIterationNumber(o.eps, &iterations));
  if (nconv < static_cast<PetscInt>(nev))
    throw NumericalError(
        fmt::format("{}: only {} of {} eigenpairs converged in {} restarts "
                    "(SLEPc reason {})",
                    where, nconv, nev, iterations, static_cast<int>(reason)));
  return iterations;
}

// The nev eigenpairs nearest sigma (SLEPc sorts them by |mu|), gathered on every rank: lambda =
// sigma + mu and the complex eigenvectors (n x nev).
std::pair<Vector, ComplexMatrix> gathered_eigenpairs(EpsObjects& o, double sigma, Index nev,
                                                     Index n) {
  ECMOR_PETSC(VecScatterCreateToAll(o.x, &o.scatter, &o.all));
  Vector lambda(nev);
  ComplexMatrix X(n, nev);
  for (Index j = 0; j < nev; ++j) {
    PetscScalar mu = 0.0;
    ECMOR_PETSC(EPSGetEigenpair(o.eps, static_cast<PetscInt>(j), &mu, nullptr, o.x, nullptr));
    lambda(j) = sigma + PetscRealPart(mu);  // SLEPc returns mu, back-transformed
    ECMOR_PETSC(VecScatterBegin(o.scatter, o.x, o.all, INSERT_VALUES, SCATTER_FORWARD));
    ECMOR_PETSC(VecScatterEnd(o.scatter, o.x, o.all, INSERT_VALUES, SCATTER_FORWARD));
    const PetscScalar* a = nullptr;
    ECMOR_PETSC(VecGetArrayRead(o.all, &a));
    for (Index r = 0; r < n; ++r) X(r, j) = Complex(PetscRealPart(a[r]), PetscImaginaryPart(a[r]));
    ECMOR_PETSC(VecRestoreArrayRead(o.all, &a));
  }
  return {std::move(lambda), std::move(X)};
}

// Real, M-orthonormal eigenvectors. K and M are real: each eigenspace has a real basis, but
// complex arithmetic returns its vectors with arbitrary phases. Each vector is turned to make its
// largest entry real. Then, per group of equal eigenvalues (relative 1e-10), the real and
// imaginary parts of the group's vectors, largest first, are M-orthogonalised (twice) against
// every vector kept so far; a part is kept when 1e-8 of its complex vector's M-norm survives,
// until the group is spanned. (Parts that are rounding noise never reach that size.)
class RealEigenbasis {
 public:
  RealEigenbasis(const SparseMatrix& M, Index n, Index nev) : m_M(M) {
    m_result.eigenvalues.resize(nev);
    m_result.eigenvectors.resize(n, nev);
  }

  // Adds the group of eigenvalues lambda(order[g..e)) with the eigenvectors of X. \throws
  // NumericalError naming `where` when their real and imaginary parts span fewer dimensions.
  void add_group(const Vector& lambda, const ComplexMatrix& X, const std::vector<Index>& order,
                 std::size_t g, std::size_t e, const std::string& where) {
    std::vector<Part> parts;
    for (std::size_t k = g; k < e; ++k) {
      ComplexVector x = X.col(order[k]);
      Index imax = 0;
      x.cwiseAbs().maxCoeff(&imax);
      if (std::abs(x(imax)) > 0.0) x *= std::conj(x(imax)) / std::abs(x(imax));
      Vector re = x.real(), im = x.imag();
      const double a = m_norm(re), b = m_norm(im), whole = std::hypot(a, b);
      parts.push_back({std::move(re), a, whole});
      parts.push_back({std::move(im), b, whole});
    }
    std::stable_sort(parts.begin(), parts.end(),
                     [](const Part& p, const Part& q) { return p.size > q.size; });
    const Index want = static_cast<Index>(e - g);
    Index got = 0;
    for (Part& part : parts) {
      if (got == want) break;
      if (!(part.reference > 0.0)) continue;
      Vector& v = part.v;
      for (int pass = 0; pass < 2; ++pass)
        for (Index k = 0; k < m_kept; ++k) {
          const auto q = m_result.eigenvectors.col(k);
          v -= q.dot(m_M * v) * q;
        }
      const double norm = m_norm(v);
      if (!(norm > 1e-8 * part.reference)) continue;
      m_result.eigenvectors.col(m_kept) = v / norm;
      m_result.eigenvalues(m_kept) = lambda(order[g + static_cast<std::size_t>(got)]);
      ++m_kept;
      ++got;
    }
    if (got < want)
      throw NumericalError(fmt::format(
          "{}: the eigenvectors of the eigenvalue {:.10g} (multiplicity {}) span only {} real "
          "dimension{}",
          where, lambda(order[g]), want, got, got == 1 ? "" : "s"));
  }

  // The eigenpairs kept, in the order added.
  SymmetricEigenResult take() {
    m_result.eigenvalues.conservativeResize(m_kept);
    m_result.eigenvectors.conservativeResize(m_result.eigenvectors.rows(), m_kept);
    return std::move(m_result);
  }

 private:
  struct Part {
    Vector v;
    double size;       // its M-norm
    double reference;  // the M-norm of its complex vector
  };
  double m_norm(const Vector& v) const { return std::sqrt(std::max(0.0, v.dot(m_M * v))); }

  const SparseMatrix& m_M;
  SymmetricEigenResult m_result;
  Index m_kept = 0;
};

// The eigenpairs (lambda, X) as real M-orthonormal ones in ascending order (RealEigenbasis), the
// eigenvalues grouped by equality to 1e-10 relative (1e-14 of the largest absolute).
SymmetricEigenResult real_eigenpairs(const Vector& lambda, const ComplexMatrix& X,
                                     const SparseMatrix& M, const std::string& where) {
  const Index nev = lambda.size();
  std::vector<Index> order(static_cast<std::size_t>(nev));
  for (Index j = 0; j < nev; ++j) order[static_cast<std::size_t>(j)] = j;
  std::stable_sort(order.begin(), order.end(),
                   [&](Index a, Index b) { return lambda(a) < lambda(b); });
  RealEigenbasis basis(M, X.rows(), nev);
  const double scale = lambda.cwiseAbs().maxCoeff();
  for (std::size_t g = 0; g < order.size();) {
    std::size_t e = g + 1;
    while (e < order.size() &&
           std::abs(lambda(order[e]) - lambda(order[g])) <=
               1e-10 * std::max(std::abs(lambda(order[e])), std::abs(lambda(order[g]))) +
                   1e-14 * scale)
      ++e;
    basis.add_group(lambda, X, order, g, e, where);
    g = e;
  }
  return basis.take();
}

SymmetricEigenResult symmetric_eigs(const Factorization& factorization, const SparseMatrix& M,
                                    double sigma, const EigenOptions& options) {
  const auto* F = dynamic_cast<const PetscFactorization*>(&factorization);
  if (F == nullptr)
    throw InputError("PETSc backend: the SLEPc eigensolver needs a factorisation of this backend");
  const std::string where =
      fmt::format("SLEPc Krylov-Schur (sigma = {:g}, nev = {})", sigma, options.nev);
  EpsObjects o;
  ShiftInvertContext ctx;
  o.M = F->state().distribute(M);
  ECMOR_PETSC(MatCreateVecs(o.M, &o.x, nullptr));
  ctx.F = F;
  configure_shift_invert(o, *F, ctx, options);
  const PetscInt iterations = solve_eps(o, *F, ctx, options.nev, where);
  const auto [lambda, X] = gathered_eigenpairs(o, sigma, options.nev, F->size());
  SymmetricEigenResult result = real_eigenpairs(lambda, X, M, where);
  result.iterations = iterations;
  result.operator_applications = ctx.applications;
  result.method = "slepc";
  return result;
}
#endif  // ECMOR_HAVE_SLEPC

std::unique_ptr<ShiftedSolver> make_solver(const Model& model) {
  Terms terms;
  terms.n = size_of(model);
  if (const auto* so = std::get_if<SecondOrderModel>(&model)) {
    terms.t = {so->K, so->D, so->M};
  } else {
    const auto& d = std::get<DescriptorModel>(model);
    terms.t = {SparseMatrix(-d.A), d.E};
  }
  for (SparseMatrix& t : terms.t) {
    if (t.rows() != terms.n || t.cols() != terms.n)
      throw InputError("PETSc backend: the coefficient matrices are not all N x N");
    t.makeCompressed();
  }
  return std::make_unique<PetscSolver>(std::move(terms));
}

int rank() {
  int r = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &r);
  return r;
}

int size() {
  int n = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &n);
  return n;
}

bool any(bool local) {
  int in = local ? 1 : 0, out = 0;
  MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_LOR, PETSC_COMM_WORLD);
  return out != 0;
}

[[noreturn]] void abort_job(int code) {
  MPI_Abort(PETSC_COMM_WORLD, code);
  std::exit(code);
}

#ifdef ECMOR_HAVE_SLEPC
constexpr auto kSymmetricEigs = &symmetric_eigs;
#else
constexpr SymmetricEigenResult (*kSymmetricEigs)(const Factorization&, const SparseMatrix&, double,
                                                 const EigenOptions&) = nullptr;
#endif
const PetscBackendApi kApi{kPetscBackendApiVersion, &make_solver, &rank, &size, &any, &abort_job,
                           kSymmetricEigs};

}  // namespace
}  // namespace ecmor::detail

extern "C" __attribute__((visibility("default"))) const ecmor::detail::PetscBackendApi*
ecmor_petsc_backend() {
  return &ecmor::detail::kApi;
}
