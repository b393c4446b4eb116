// Tests of the SuiteSparse ShiftedSolver on small systems with closed-form or dense references.
#include <gtest/gtest.h>
#include <omp.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "common/builders.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/linalg/recent_factorizations.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace {

using ecmor::test::sparse;

using namespace ecmor;

/// 2-DOF mass-spring-damper: M = diag(m1, m2), K = [[k1 + k2, -k2], [-k2, k2]], D = 0.1 M + 0.01 K.
SecondOrderModel two_dof() {
  Matrix M(2, 2), K(2, 2);
  M << 2.0, 0.0, 0.0, 1.0;
  K << 30.0, -10.0, -10.0, 10.0;
  Matrix D = 0.1 * M + 0.01 * K;
  SecondOrderModel m;
  m.M = sparse(M);
  m.K = sparse(K);
  m.D = sparse(D);
  m.B = Matrix::Ones(2, 1);
  m.C = Matrix::Ones(1, 2);
  return m;
}

// The solver keeps pointers to the model's matrices, so it is made from a named model only: a
// temporary, or a SecondOrderModel converted to a temporary Model, would die first (the sanitizer
// run found the latter in a test: stack-use-after-scope).
template <class T>
concept SolverFrom = requires(T&& m) {
  make_shifted_solver(std::forward<T>(m));
};
static_assert(SolverFrom<const Model&> && SolverFrom<const SecondOrderModel&> &&
              SolverFrom<const DescriptorModel&> && SolverFrom<SecondOrderModel&>);
static_assert(!SolverFrom<Model> && !SolverFrom<SecondOrderModel> && !SolverFrom<DescriptorModel>);
template <class T>
concept ViewFrom = requires(T&& m, ShiftedSolver& s) {
  FirstOrderView(std::forward<T>(m), s);
};
static_assert(ViewFrom<const Model&> && !ViewFrom<Model> && !ViewFrom<const SecondOrderModel&>);
template <class T>
concept CacheFrom = requires(T&& m, ShiftedSolver& s) {
  ResponseCache(std::forward<T>(m), s);
};
static_assert(CacheFrom<const Model&> && !CacheFrom<Model> && !CacheFrom<const DescriptorModel&>);

/// Undamped 1-DOF: s^2 + 4: eigenvalues +-2i.
SecondOrderModel one_dof_undamped() {
  SecondOrderModel m;
  m.M = sparse(Matrix::Constant(1, 1, 1.0));
  m.D = SparseMatrix(1, 1);  // empty pattern: the union adds the diagonal
  m.K = sparse(Matrix::Constant(1, 1, 4.0));
  m.B = Matrix::Ones(1, 1);
  m.C = Matrix::Ones(1, 1);
  return m;
}

/// Descriptor with unsymmetric A and singular E (a DAE).
DescriptorModel small_descriptor() {
  Matrix E(3, 3), A(3, 3);
  E << 1.0, 0.0, 0.0,  //
      0.0, 2.0, 0.0,   //
      0.0, 0.0, 0.0;
  A << -1.0, 2.0, 0.0,  //
      -3.0, -1.0, 1.0,  //
      0.5, 0.0, 1.0;
  DescriptorModel m;
  m.E = sparse(E);
  m.A = sparse(A);
  m.B = Matrix::Ones(3, 2);
  m.B(2, 1) = -1.0;
  m.C = Matrix::Ones(1, 3);
  return m;
}

/// A chain of N masses whose terms have DIFFERENT patterns: M diagonal, K tridiagonal, D with
/// dashpots that couple the ends (entries in neither M's nor K's pattern). Symmetric positive
/// definite M, K; symmetric D.
SecondOrderModel chain(int n) {
  std::vector<Eigen::Triplet<double, int>> tm, tk, td;
  for (int i = 0; i < n; ++i) {
    tm.emplace_back(i, i, 1.0 + 0.01 * i);
    tk.emplace_back(i, i, (i == 0 || i == n - 1) ? 300.0 : 200.0);
    if (i + 1 < n) {
      tk.emplace_back(i, i + 1, -100.0);
      tk.emplace_back(i + 1, i, -100.0);
    }
  }
  td.emplace_back(0, 0, 0.5);
  td.emplace_back(n - 1, n - 1, 0.5);
  td.emplace_back(0, n - 1, -0.5);
  td.emplace_back(n - 1, 0, -0.5);
  td.emplace_back(n / 2, n / 2, 0.2);
  SecondOrderModel m;
  m.M.resize(n, n);
  m.K.resize(n, n);
  m.D.resize(n, n);
  m.M.setFromTriplets(tm.begin(), tm.end());
  m.K.setFromTriplets(tk.begin(), tk.end());
  m.D.setFromTriplets(td.begin(), td.end());
  m.B = Matrix::Zero(n, 2);
  m.B(0, 0) = 1.0;
  m.B(n - 1, 1) = 1.0;
  m.C = Matrix::Ones(1, n);
  return m;
}

ComplexMatrix dense_P(const SecondOrderModel& m, Complex s) {
  return (s * s) * Matrix(m.M).cast<Complex>() + s * Matrix(m.D).cast<Complex>() +
         Matrix(m.K).cast<Complex>();
}
ComplexMatrix dense_P(const DescriptorModel& m, Complex s) {
  return s * Matrix(m.E).cast<Complex>() - Matrix(m.A).cast<Complex>();
}

double rel_err(const ComplexMatrix& X, const ComplexMatrix& Y) { return (X - Y).norm() / Y.norm(); }

TEST(ShiftedSolver, BasicProperties) {
  Model model = two_dof();
  auto solver = make_shifted_solver(model);
  EXPECT_EQ(solver->size(), 2);
  EXPECT_EQ(solver->terms(), 3);
  EXPECT_EQ(solver->backend(), "suitesparse");
  Model dm = small_descriptor();
  auto dsolver = make_shifted_solver(dm);
  EXPECT_EQ(dsolver->terms(), 2);
  const auto c = solver->counters();
  EXPECT_EQ(c.symbolic_analyses, 0);  // lazy
  EXPECT_EQ(c.factorizations, 0);
}

// The driver's shared solver: a request for exactly the combination most recently factorised is
// served without a new factorisation (the reducer asking for P(s) where the error control has
// just solved); anything else, even one bit off, is factorised anew.
TEST(RecentFactorizations, ServesTheMostRecentCombinationOnly) {
  Model model = two_dof();
  auto inner = make_shifted_solver(model);
  RecentFactorizations solver(*inner, 1);
  const Complex s1(0.0, 2.0), s2(0.0, 3.0);
  const auto a = solver.factorize(s1);
  const auto b = solver.factorize(s1);
  EXPECT_EQ(a.get(), b.get());
  EXPECT_EQ(solver.reuses(), 1);
  EXPECT_EQ(solver.counters().factorizations, 1);
  const auto c = solver.factorize(Complex(0.0, std::nextafter(2.0, 3.0)));
  EXPECT_NE(c.get(), a.get());
  EXPECT_EQ(solver.counters().factorizations, 2);
  // Keeps one: s1 was evicted by the last request.
  (void)solver.factorize(s2);
  (void)solver.factorize(s1);
  EXPECT_EQ(solver.counters().factorizations, 4);
  EXPECT_EQ(solver.reuses(), 1);
  // The kept factorisation is the real one: it solves P(s1) x = b.
  const Matrix rhs = Matrix::Ones(2, 1);
  const ComplexMatrix x = solver.factorize(s1)->solve(ComplexMatrix(rhs.cast<Complex>()));
  const std::vector<Complex> w = {1.0, s1, s1 * s1};
  EXPECT_LT((solver.apply_combination(w, x) - rhs.cast<Complex>()).norm(), 1e-12);
  EXPECT_EQ(solver.reuses(), 2);

  RecentFactorizations none(*inner, 0);
  (void)none.factorize(s1);
  (void)none.factorize(s1);
  EXPECT_EQ(none.reuses(), 0);
  EXPECT_THROW(RecentFactorizations(*inner, -1), ConfigError);
}

TEST(ShiftedSolver, RealSpdShiftUsesCholesky) {
  const auto sys = two_dof();
  Model model = sys;
  auto solver = make_shifted_solver(model);
  const Complex s(0.5, 0.0);
  const auto before = std::chrono::steady_clock::now();
  auto f = solver->factorize(s);
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - before).count();
  EXPECT_EQ(f->method(), "cholmod");
  EXPECT_FALSE(f->is_complex());
  EXPECT_GT(f->rcond(), 0.0);
  Matrix B(2, 3);
  B << 1.0, 0.0, 2.0, 0.0, 1.0, -1.0;
  Matrix X = f->solve(B);
  Matrix Xref = dense_P(sys, s).real().inverse() * B;
  EXPECT_LT((X - Xref).norm() / Xref.norm(), 1e-14);
  // Symmetric: transposed solve is the same.
  EXPECT_LT((f->solve_transposed(B) - Xref).norm() / Xref.norm(), 1e-14);
  // Complex RHS with a real factorisation: real and imaginary parts.
  ComplexMatrix Bc = B.cast<Complex>() * Complex(1.0, -2.0);
  ComplexMatrix Xc = f->solve(Bc);
  EXPECT_LT(rel_err(Xc, Xref.cast<Complex>() * Complex(1.0, -2.0)), 1e-14);
  const auto c = solver->counters();
  EXPECT_EQ(c.cholesky_factorizations, 1);
  EXPECT_EQ(c.lu_factorizations, 0);
  EXPECT_EQ(c.factorizations, 1);
  EXPECT_EQ(c.failed_cholesky, 0);
  EXPECT_EQ(c.symbolic_analyses, 1);
  EXPECT_EQ(c.solves, 3 + 3 + 6);  // per column; complex RHS = 2 real columns each
  // The factorisation's time, in seconds: more than nothing, and within the wall time of the call
  // that made it.
  EXPECT_GT(c.factorization_seconds, 0.0);
  EXPECT_LE(c.factorization_seconds, wall);
}

TEST(ShiftedSolver, CholeskyCanBeSwitchedOff) {
  Model model = two_dof();
  SolverOptions opt;
  opt.use_cholesky = false;
  auto solver = make_shifted_solver(model, opt);
  auto f = solver->factorize(Complex(0.5, 0.0));
  EXPECT_EQ(f->method(), "umfpack");
  EXPECT_EQ(solver->counters().lu_factorizations, 1);
}

TEST(ShiftedSolver, IndefiniteSymmetricFallsBackToLu) {
  const auto sys = two_dof();
  Model model = sys;
  auto solver = make_shifted_solver(model);
  // K - sigma M with sigma between the two generalised eigenvalues (2.93 and 17.07).
  const double sigma = 8.0;
  const std::vector<Complex> w{1.0, 0.0, -sigma};
  auto f = solver->factorize_combination(w);
  EXPECT_EQ(f->method(), "umfpack");
  EXPECT_EQ(f->weights(), w);
  Matrix P = Matrix(sys.K) - sigma * Matrix(sys.M);
  Matrix B = Matrix::Identity(2, 2);
  EXPECT_LT((f->solve(B) - P.inverse()).norm() / P.inverse().norm(), 1e-14);
  const auto c = solver->counters();
  EXPECT_EQ(c.failed_cholesky, 1);
  EXPECT_EQ(c.lu_factorizations, 1);
  EXPECT_EQ(c.cholesky_factorizations, 0);
  EXPECT_EQ(c.factorizations, 1);
  EXPECT_EQ(c.symbolic_analyses, 2);  // CHOLMOD + UMFPACK real
}

TEST(ShiftedSolver, ComplexShiftsReuseOneSymbolicAnalysis) {
  const auto sys = chain(60);
  Model model = sys;
  auto solver = make_shifted_solver(model);
  Index first = -1;
  for (int k = 0; k < 10; ++k) {
    const Complex s(0.1 * k, 1.0 + 2.0 * k);
    auto f = solver->factorize(s);
    EXPECT_TRUE(f->is_complex());
    EXPECT_EQ(f->method(), "umfpack");
    ComplexMatrix B = sys.B.cast<Complex>();
    ComplexMatrix X = f->solve(B);
    ComplexMatrix Xref = dense_P(sys, s).partialPivLu().solve(B);
    EXPECT_LT(rel_err(X, Xref), 1e-12) << "s = " << s;
    if (k == 0) first = solver->counters().symbolic_analyses;
  }
  const auto c = solver->counters();
  EXPECT_EQ(first, 1);
  EXPECT_EQ(c.symbolic_analyses, first);
  EXPECT_EQ(c.complex_factorizations, 10);
  EXPECT_EQ(c.lu_factorizations, 10);
  EXPECT_EQ(c.solves, 20);
  EXPECT_GT(c.solve_seconds, 0.0);
}

TEST(ShiftedSolver, RealSolveOnComplexFactorizationThrows) {
  Model model = two_dof();
  auto solver = make_shifted_solver(model);
  auto f = solver->factorize(Complex(0.0, 1.0));
  EXPECT_THROW(f->solve(Matrix(Matrix::Ones(2, 1))), NumericalError);
  EXPECT_THROW(f->solve_transposed(Matrix(Matrix::Ones(2, 1))), NumericalError);
}

TEST(ShiftedSolver, TransposedSolvesAgreeWithDense) {
  const auto sys = small_descriptor();
  Model model = sys;
  auto solver = make_shifted_solver(model);
  Matrix B(3, 2);
  B << 1.0, -1.0, 2.0, 0.5, 0.0, 3.0;
  // Real unsymmetric shift: UMFPACK.
  {
    const Complex s(0.7, 0.0);
    auto f = solver->factorize(s);
    EXPECT_EQ(f->method(), "umfpack");
    EXPECT_FALSE(f->is_complex());
    Matrix P = dense_P(sys, s).real();
    Matrix Xt = P.transpose().inverse() * B;
    EXPECT_LT((f->solve_transposed(B) - Xt).norm() / Xt.norm(), 1e-14);
    Matrix X = P.inverse() * B;
    EXPECT_LT((f->solve(B) - X).norm() / X.norm(), 1e-14);
    ComplexMatrix Bc = B.cast<Complex>() * Complex(0.0, 1.0);
    EXPECT_LT(rel_err(f->solve_transposed(Bc), Xt.cast<Complex>() * Complex(0.0, 1.0)), 1e-14);
  }
  // Complex shift: transpose, not conjugate transpose.
  {
    const Complex s(0.3, 1.7);
    auto f = solver->factorize(s);
    ComplexMatrix P = dense_P(sys, s);
    ComplexMatrix Bc = B.cast<Complex>();
    Bc(1, 1) = Complex(0.5, -2.0);
    ComplexMatrix Xt = P.transpose().inverse() * Bc;
    ComplexMatrix X = P.inverse() * Bc;
    EXPECT_LT(rel_err(f->solve_transposed(Bc), Xt), 1e-14);
    EXPECT_LT(rel_err(f->solve(Bc), X), 1e-14);
    // The conjugate transpose would give a different answer here.
    ComplexMatrix Xh = P.adjoint().inverse() * Bc;
    EXPECT_GT(rel_err(Xh, Xt), 1e-3);
  }
}

TEST(ShiftedSolver, UnionPatternOfDifferentTerms) {
  // Terms with different patterns (D couples the chain's ends): compare with a dense solve.
  const auto sys = chain(40);
  Model model = sys;
  auto solver = make_shifted_solver(model);
  for (Complex s : {Complex(0.0, 0.0), Complex(0.3, 0.0), Complex(0.0, 13.0), Complex(-0.2, 7.0)}) {
    auto f = solver->factorize(s);
    ComplexMatrix P = dense_P(sys, s);
    ComplexMatrix B = sys.B.cast<Complex>();
    EXPECT_LT(rel_err(f->solve(B), P.partialPivLu().solve(B)), 1e-12) << s;
    EXPECT_LT(rel_err(f->solve_transposed(B), P.transpose().partialPivLu().solve(B)), 1e-12) << s;
  }
  // Real shifts of an SPD chain are Cholesky.
  EXPECT_EQ(solver->counters().cholesky_factorizations, 2);
}

TEST(ShiftedSolver, ApplyCombinationIsTheSparseProduct) {
  const auto sys = chain(25);
  Model model = sys;
  auto solver = make_shifted_solver(model);
  const std::vector<Complex> w{Complex(1.0, 0.5), Complex(-2.0, 0.0), Complex(0.0, 3.0)};
  ComplexMatrix x = ComplexMatrix::Random(25, 3);
  ComplexMatrix ref = (w[0] * Matrix(sys.K).cast<Complex>() + w[1] * Matrix(sys.D).cast<Complex>() +
                       w[2] * Matrix(sys.M).cast<Complex>()) *
                      x;
  EXPECT_LT(rel_err(solver->apply_combination(w, x), ref), 1e-15);
  // Descriptor: T_0 = -A, T_1 = E.
  const auto ds = small_descriptor();
  Model dm = ds;
  auto dsolver = make_shifted_solver(dm);
  const std::vector<Complex> v{Complex(2.0, 0.0), Complex(0.0, -1.0)};
  ComplexMatrix y = ComplexMatrix::Random(3, 2);
  ComplexMatrix dref =
      (-v[0] * Matrix(ds.A).cast<Complex>() + v[1] * Matrix(ds.E).cast<Complex>()) * y;
  EXPECT_LT(rel_err(dsolver->apply_combination(v, y), dref), 1e-15);
  // Residual of a solve through apply_combination: P (P^-1 b) = b.
  auto f = dsolver->factorize_combination(v);
  ComplexMatrix z = f->solve(y);
  EXPECT_LT(rel_err(dsolver->apply_combination(v, z), y), 1e-14);
  // Transposed product of an unsymmetric descriptor pencil, and its transposed solve.
  ComplexMatrix tref =
      (-v[0] * Matrix(ds.A).cast<Complex>() + v[1] * Matrix(ds.E).cast<Complex>()).transpose() * y;
  ASSERT_GT((Matrix(ds.A) - Matrix(ds.A).transpose()).norm(), 0.0);  // the case is unsymmetric
  EXPECT_LT(rel_err(dsolver->apply_combination_transposed(v, y), tref), 1e-15);
  EXPECT_LT(rel_err(dsolver->apply_combination_transposed(v, f->solve_transposed(y)), y), 1e-14);
}

TEST(ShiftedSolver, SingularShiftThrowsNamingTheShift) {
  Model model = one_dof_undamped();
  auto solver = make_shifted_solver(model);
  try {
    solver->factorize(Complex(0.0, 2.0));
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("singular"), std::string::npos) << msg;
    EXPECT_NE(msg.find("s = 0+2i"), std::string::npos) << msg;
    EXPECT_NE(msg.find("rcond"), std::string::npos) << msg;
  }
  // Nearby shifts are fine.
  EXPECT_NO_THROW(solver->factorize(Complex(0.0, 2.1)));
}

TEST(ShiftedSolver, SingularRealSymmetricShiftFallsThroughCholeskyToLuAndThrows) {
  // A = diag(-1, -2), E = I: s = -1 is an eigenvalue; P(-1) = diag(0, 1) is symmetric PSD.
  DescriptorModel m;
  m.E = sparse(Matrix::Identity(2, 2));
  Matrix A = Matrix::Zero(2, 2);
  A(0, 0) = -1.0;
  A(1, 1) = -2.0;
  m.A = sparse(A);
  m.B = Matrix::Ones(2, 1);
  m.C = Matrix::Ones(1, 2);
  Model model = m;
  auto solver = make_shifted_solver(model);
  try {
    solver->factorize(Complex(-1.0, 0.0));
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
  }
  EXPECT_EQ(solver->counters().failed_cholesky, 1);
  // A general combination names its weights.
  try {
    const std::vector<Complex> w{Complex(2.0, 0.0), Complex(-2.0, 0.0)};  // 2(-A) - 2E = diag(0, 2)
    solver->factorize_combination(w);
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("singular"), std::string::npos) << msg;
    EXPECT_NE(msg.find("weights (2+0i, -2+0i)"), std::string::npos) << msg;
  }
}

TEST(ShiftedSolver, NonFiniteWeightsThrow) {
  Model model = two_dof();
  auto solver = make_shifted_solver(model);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Complex> w{1.0, Complex(0.0, nan), 0.0};
  EXPECT_THROW(solver->factorize_combination(w), NumericalError);
  EXPECT_THROW(solver->factorize(Complex(std::numeric_limits<double>::infinity(), 0.0)),
               NumericalError);
  const std::vector<Complex> two{1.0, 1.0};
  EXPECT_THROW(solver->factorize_combination(two), InputError);
}

TEST(ShiftedSolver, OptionsValidation) {
  SolverOptions o;
  EXPECT_NO_THROW(o.validate());
  o.singular_rcond = -1.0;
  try {
    o.validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("singular_rcond"), std::string::npos);
  }
  o = SolverOptions{};
  o.refinement_steps = -1;
  EXPECT_THROW(o.validate(), ConfigError);
  o = SolverOptions{};
  o.symmetry_tol = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(o.validate(), ConfigError);
  Model model = two_dof();
  EXPECT_THROW(make_shifted_solver(model, o), ConfigError);
}

TEST(ShiftedSolver, IterativeRefinementOption) {
  const auto sys = small_descriptor();
  Model model = sys;
  SolverOptions opt;
  opt.refinement_steps = 2;
  auto solver = make_shifted_solver(model, opt);
  Matrix B(3, 2);
  B << 1.0, -1.0, 2.0, 0.5, 0.0, 3.0;
  for (Complex s : {Complex(0.7, 0.0), Complex(0.3, 1.7)}) {
    auto f = solver->factorize(s);
    ComplexMatrix P = dense_P(sys, s);
    ComplexMatrix Bc = B.cast<Complex>();
    EXPECT_LT(rel_err(f->solve(Bc), P.inverse() * Bc), 1e-14);
    EXPECT_LT(rel_err(f->solve_transposed(Bc), P.transpose().inverse() * Bc), 1e-14);
  }
}

TEST(ShiftedSolver, UnsymmetricTermsNeverUseCholesky) {
  auto sys = two_dof();
  Matrix K = Matrix(sys.K);
  K(0, 1) += 1e-3;  // asymmetry 3e-5 > 1e-12
  sys.K = sparse(K);
  Model model = sys;
  auto solver = make_shifted_solver(model);
  EXPECT_EQ(solver->factorize(Complex(0.5, 0.0))->method(), "umfpack");
  // A weight of zero on the unsymmetric term: M alone is symmetric.
  const std::vector<Complex> w{0.0, 0.0, 1.0};
  EXPECT_EQ(solver->factorize_combination(w)->method(), "cholmod");
  // A looser tolerance accepts K.
  SolverOptions opt;
  opt.symmetry_tol = 1e-3;
  auto loose = make_shifted_solver(model, opt);
  EXPECT_EQ(loose->factorize(Complex(0.5, 0.0))->method(), "cholmod");
}

TEST(ShiftedSolver, ConcurrentFactorizationsAndSolves) {
  const auto sys = chain(200);
  Model model = sys;
  auto solver = make_shifted_solver(model);
  const int n = 24;
  std::vector<Complex> shifts;
  for (int k = 0; k < n; ++k)
    shifts.push_back(k % 3 == 0 ? Complex(0.1 * k, 0.0) : Complex(0.01 * k, 0.5 * k));
  std::vector<ComplexMatrix> serial(n), parallel(n);
  ComplexMatrix B = sys.B.cast<Complex>();
  {
    auto serial_solver = make_shifted_solver(model);
    for (int k = 0; k < n; ++k) serial[k] = serial_solver->factorize(shifts[k])->solve(B);
  }
  // The solver below starts without symbolic analyses: they are made lazily, concurrently.
  std::vector<std::string> errors(n);
  // Four threads take shifts from a shared counter (like OpenMP's dynamic schedule).
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int k = next++; k < n; k = next++) {
      try {
        auto f = solver->factorize(shifts[k]);
        parallel[k] = f->solve(B);
        (void)f->solve_transposed(B);
      } catch (const std::exception& e) {
        errors[k] = e.what();
      }
    }
  };
  {
    std::vector<std::thread> pool;
    for (int t = 0; t < 4; ++t) pool.emplace_back(worker);
    for (auto& t : pool) t.join();
  }
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(errors[k], "");
    EXPECT_EQ((parallel[k] - serial[k]).norm(), 0.0) << k;
  }
  // A single factorisation shared by concurrent solves.
  auto f = solver->factorize(Complex(0.0, 3.0));
  auto g = solver->factorize(Complex(0.2, 0.0));
  ComplexMatrix ref = f->solve(B), refg = g->solve(B);
  std::atomic<int> bad{0};
  {
    std::vector<std::thread> pool;
    for (int t = 0; t < 4; ++t)
      pool.emplace_back([&] {
        for (int k = 0; k < 4; ++k) {
          if ((f->solve(B) - ref).norm() != 0.0) ++bad;
          if ((g->solve(B) - refg).norm() != 0.0) ++bad;
        }
      });
    for (auto& t : pool) t.join();
  }
  EXPECT_EQ(bad.load(), 0);
  const auto c = solver->counters();
  EXPECT_EQ(c.factorizations, n + 2);
  EXPECT_EQ(c.symbolic_analyses, 2);  // CHOLMOD + UMFPACK complex
}

TEST(ShiftedSolver, FactorizationOutlivesSolver) {
  const auto sys = chain(10);
  Model model = sys;
  std::shared_ptr<const Factorization> f;
  {
    auto solver = make_shifted_solver(model);
    f = solver->factorize(Complex(0.0, 1.0));
  }
  ComplexMatrix B = sys.B.cast<Complex>();
  EXPECT_LT(rel_err(f->solve(B), dense_P(sys, Complex(0.0, 1.0)).partialPivLu().solve(B)), 1e-13);
}

TEST(ShiftedSolver, CountersArithmetic) {
  SolverCounters a, b;
  a.solves = 5;
  a.factorizations = 2;
  a.solve_seconds = 1.5;
  b.solves = 3;
  b.factorizations = 1;
  b.solve_seconds = 0.5;
  SolverCounters d = a - b;
  EXPECT_EQ(d.solves, 2);
  EXPECT_EQ(d.factorizations, 1);
  EXPECT_DOUBLE_EQ(d.solve_seconds, 1.0);
  d += b;
  EXPECT_EQ(d.solves, 5);
}

}  // namespace

namespace ecmor {
namespace {

// D = 0 (undamped): P(i w) = K - w^2 M is real, so no complex factorisation is needed, and H is
// still right: 1 / (k - m w^2).
TEST(ShiftedSolverUndamped, ZeroDampingGivesARealFactorisation) {
  SecondOrderModel s;
  s.M = SparseMatrix(1, 1);
  s.M.insert(0, 0) = 2.0;
  s.K = SparseMatrix(1, 1);
  s.K.insert(0, 0) = 8.0;
  s.D = SparseMatrix(1, 1);  // no entries
  s.B = Matrix::Ones(1, 1);
  s.C = Matrix::Ones(1, 1);
  const Model model = s;
  auto solver = make_shifted_solver(model);
  const Complex iw(0.0, 1.5);
  const auto f = solver->factorize(iw);
  EXPECT_FALSE(f->is_complex());
  EXPECT_EQ(solver->counters().complex_factorizations, 0);
  const ComplexMatrix H = transfer_function(model, *f, iw);
  EXPECT_NEAR(std::abs(H(0, 0) - 1.0 / (8.0 - 2.0 * 2.25)), 0.0, 1e-15);
}

// ---------------------------------------------------------------------------------------------
// Complex symmetric LDL^T (MUMPS) and the fill-reducing orderings.

SolverOptions ldlt_options() {
  SolverOptions o;
  o.complex_symmetric = "ldlt";
  return o;
}

// The flop counts the backends report (SolverCounters::factorization_flops), against the textbook
// counts for a dense n x n matrix, where no ordering changes the work: Cholesky n^3 / 3, real LU
// 2 n^3 / 3, complex LU 8 n^3 / 3 (a complex multiply-add is 8 real flops), complex LDL^T half of
// that. The band error's choice between modes (verify: auto) is made on these counts.
TEST(ShiftedSolver, FlopCountsOfADenseMatrixAreTheTextbookCounts) {
  constexpr int n = 60;
  Matrix R = Matrix::Random(n, n);
  Matrix K = R * R.transpose() + n * Matrix::Identity(n, n);
  SecondOrderModel sys;
  sys.M = sparse(Matrix::Identity(n, n));
  sys.D = sparse(0.01 * K);
  sys.K = sparse(K);
  sys.B = Matrix::Ones(n, 1);
  sys.C = Matrix::Ones(1, n);
  const Model model = sys;
  const double cube = static_cast<double>(n) * n * n;
  auto expect_flops = [&](ShiftedSolver& solver, Complex s, double textbook, const char* what) {
    const SolverCounters before = solver.counters();
    (void)solver.factorize(s);
    const SolverCounters c = solver.counters() - before;
    EXPECT_GT(c.factorization_flops, 0.7 * textbook) << what;
    EXPECT_LT(c.factorization_flops, 1.5 * textbook) << what;
    // A dense factor has n (n + 1) / 2 entries per triangle.
    EXPECT_GE(c.factor_entries, 0.5 * n * (n + 1)) << what;
    EXPECT_LE(c.factor_entries, 1.0 * n * (n + 1)) << what;
  };
  auto lu = make_shifted_solver(model);
  expect_flops(*lu, Complex(0.0, 0.0), cube / 3.0, "Cholesky of K");
  expect_flops(*lu, Complex(0.0, 2.0), 8.0 * cube / 3.0, "complex LU");
  SolverOptions no_cholesky;
  no_cholesky.use_cholesky = false;
  auto real_lu = make_shifted_solver(model, no_cholesky);
  expect_flops(*real_lu, Complex(0.0, 0.0), 2.0 * cube / 3.0, "real LU");
  auto ldlt = make_shifted_solver(model, ldlt_options());
  expect_flops(*ldlt, Complex(0.0, 2.0), 4.0 * cube / 3.0, "complex LDL^T");
}

TEST(ShiftedSolverLdlt, AgreesWithDenseLuAndReusesTheFirstOrdering) {
  const auto sys = chain(300);
  Model model = sys;
  auto solver = make_shifted_solver(model, ldlt_options());
  EXPECT_FALSE(solver->concurrent());  // MUMPS calls are serialised
  const ComplexMatrix B = sys.B.cast<Complex>();
  for (int k = 0; k < 6; ++k) {
    const Complex s(0.05 * k, 0.5 + 3.0 * k);
    auto f = solver->factorize(s);
    EXPECT_TRUE(f->is_complex());
    EXPECT_EQ(f->method(), "mumps-ldlt");
    const ComplexMatrix P = dense_P(sys, s);
    const ComplexMatrix Xref = P.partialPivLu().solve(B);
    EXPECT_LT(rel_err(f->solve(B), Xref), 1e-12) << "s = " << s;
    // P is complex symmetric: P^-T B = P^-1 B.
    EXPECT_LT(rel_err(f->solve_transposed(B), P.transpose().partialPivLu().solve(B)), 1e-12);
    EXPECT_THROW(f->solve(Matrix(Matrix::Ones(sys.M.rows(), 1))), NumericalError);
  }
  const auto c = solver->counters();
  EXPECT_EQ(c.ldlt_factorizations, 6);
  EXPECT_EQ(c.complex_factorizations, 6);
  EXPECT_EQ(c.lu_factorizations, 0);
  EXPECT_EQ(c.symbolic_analyses, 1);  // the first factorisation's ordering serves the others
  EXPECT_EQ(c.solves, 24);
}

TEST(ShiftedSolverLdlt, AutoChoosesByPredictedMemoryAndSymmetry) {
  const auto sys = chain(300);
  Model model = sys;
  SolverOptions o;  // complex_symmetric = auto: LU while the LUs of all threads fit the budget
  auto lu = make_shifted_solver(model, o);
  EXPECT_TRUE(lu->concurrent());
  EXPECT_EQ(lu->factorize(Complex(0.1, 2.0))->method(), "umfpack");
  EXPECT_EQ(lu->counters().symbolic_analyses, 1);  // small: no analysis needed to decide
  o.ldlt_memory_fraction = 0.0;                    // no memory for any LU
  auto ldlt = make_shifted_solver(model, o);
  EXPECT_FALSE(ldlt->concurrent());
  EXPECT_EQ(ldlt->factorize(Complex(0.1, 2.0))->method(), "mumps-ldlt");
  // A budget between the chain's real factor (nnz(L) ~ 900: a band plus the end-to-end dashpot)
  // and a dense one (45 150): the analysis decides, for LU.
  const double threads = std::max(1, omp_get_max_threads());
  const double physical =
      static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGESIZE));
  o.ldlt_memory_fraction = threads * 40.0 * 5000.0 / physical;
  auto analysed = make_shifted_solver(model, o);
  EXPECT_TRUE(analysed->concurrent());
  EXPECT_EQ(analysed->counters().symbolic_analyses, 1);  // CHOLMOD's, to decide
  EXPECT_EQ(analysed->factorize(Complex(0.1, 2.0))->method(), "umfpack");
  o.complex_symmetric = "lu";
  EXPECT_EQ(make_shifted_solver(model, o)->factorize(Complex(0.1, 2.0))->method(), "umfpack");
  // Real shifts of SPD combinations stay with CHOLMOD, unsymmetric models with UMFPACK.
  EXPECT_EQ(make_shifted_solver(model, ldlt_options())->factorize(Complex(0.5, 0.0))->method(),
            "cholmod");
  Model dae = small_descriptor();
  auto unsym = make_shifted_solver(dae, ldlt_options());
  EXPECT_TRUE(unsym->concurrent());
  EXPECT_EQ(unsym->factorize(Complex(0.0, 1.0))->method(), "umfpack");
}

TEST(ShiftedSolverLdlt, SingularShiftThrowsNamingTheShift) {
  // two_dof: K phi = lambda M phi has lambda = 5 and 20, and D = 0.1 M + 0.01 K, so P(s) is
  // singular where s^2 + (0.1 + 0.01 lambda) s + lambda = 0: s = -0.075 +- i sqrt(5 - 0.075^2).
  Model model = two_dof();
  auto solver = make_shifted_solver(model, ldlt_options());
  const Complex pole(-0.075, std::sqrt(5.0 - 0.075 * 0.075));
  try {
    solver->factorize(pole);
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("singular"), std::string::npos) << msg;
    EXPECT_NE(msg.find("s = -0.075+2.23"), std::string::npos) << msg;
    EXPECT_NE(msg.find("MUMPS"), std::string::npos) << msg;
  }
  EXPECT_NO_THROW(solver->factorize(Complex(-0.075, 2.3)));
}

TEST(ShiftedSolverLdlt, ConcurrentCallersGetTheSerialResults) {
  const auto sys = chain(200);
  Model model = sys;
  const ComplexMatrix B = sys.B.cast<Complex>();
  const int n = 12;
  std::vector<ComplexMatrix> serial(n), parallel(n);
  auto shift = [](int k) { return Complex(0.02 * k, 0.7 * (k + 1)); };
  {
    auto s1 = make_shifted_solver(model, ldlt_options());
    for (int k = 0; k < n; ++k) serial[k] = s1->factorize(shift(k))->solve(B);
  }
  auto solver = make_shifted_solver(model, ldlt_options());
  std::atomic<int> next{0};
  std::vector<std::string> errors(n);
  std::vector<std::thread> pool;
  for (int t = 0; t < 3; ++t)
    pool.emplace_back([&] {
      for (int k = next++; k < n; k = next++) {
        try {
          parallel[k] = solver->factorize(shift(k))->solve(B);
        } catch (const std::exception& e) {
          errors[k] = e.what();
        }
      }
    });
  for (auto& t : pool) t.join();
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(errors[k], "");
    EXPECT_LT(rel_err(parallel[k], serial[k]), 1e-13) << k;
  }
}

TEST(ShiftedSolverOrdering, EveryOrderingAndMethodSolvesTheSameSystem) {
  // A 3-D-like pattern (a 6 x 6 x 6 grid Laplacian plus mass) so that the orderings differ.
  const int g = 6, n = g * g * g;
  std::vector<Eigen::Triplet<double, int>> tk, tm;
  auto id = [&](int i, int j, int k) { return i + g * (j + g * k); };
  for (int k = 0; k < g; ++k)
    for (int j = 0; j < g; ++j)
      for (int i = 0; i < g; ++i) {
        const int a = id(i, j, k);
        tk.emplace_back(a, a, 6.5);
        tm.emplace_back(a, a, 1.0 + 0.001 * a);
        const int nb[3][3] = {{i + 1, j, k}, {i, j + 1, k}, {i, j, k + 1}};
        for (const auto& q : nb) {
          if (q[0] >= g || q[1] >= g || q[2] >= g) continue;
          const int b = id(q[0], q[1], q[2]);
          tk.emplace_back(a, b, -1.0);
          tk.emplace_back(b, a, -1.0);
        }
      }
  SecondOrderModel sys;
  sys.K.resize(n, n);
  sys.M.resize(n, n);
  sys.K.setFromTriplets(tk.begin(), tk.end());
  sys.M.setFromTriplets(tm.begin(), tm.end());
  sys.D = 0.02 * sys.M + 0.01 * sys.K;
  sys.B = Matrix::Zero(n, 2);
  sys.B(0, 0) = 1.0;
  sys.B(n - 1, 1) = 1.0;
  sys.C = Matrix::Ones(1, n);
  Model model = sys;
  const ComplexMatrix B = sys.B.cast<Complex>();
  for (const Complex s : {Complex(0.0, 1.3), Complex(0.0, 0.0)}) {
    const ComplexMatrix Xref = dense_P(sys, s).partialPivLu().solve(B);
    for (const char* ordering : {"auto", "amd", "metis"})
      for (const char* method : {"lu", "ldlt"}) {
        SolverOptions o;
        o.ordering = ordering;
        o.complex_symmetric = method;
        auto solver = make_shifted_solver(model, o);
        EXPECT_LT(rel_err(solver->factorize(s)->solve(B), Xref), 1e-12)
            << ordering << " " << method << " s = " << s;
      }
  }
}

TEST(ShiftedSolverOrdering, OptionsValidation) {
  for (auto set : {+[](SolverOptions& o) { o.ordering = "nested"; },
                   +[](SolverOptions& o) { o.complex_symmetric = "cholesky"; },
                   +[](SolverOptions& o) { o.ldlt_memory_fraction = 1.5; }}) {
    SolverOptions o;
    set(o);
    EXPECT_THROW(o.validate(), ConfigError);
  }
  SolverOptions o;
  o.ordering = "nested";
  try {
    o.validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()),
              "SolverOptions: ordering = 'nested': must be one of auto, amd, metis");
  }
}

// The API and the YAML reader apply one rule per option (SolverOptions::specs()): symmetry_tol was
// ">= 0" in validate() and "[0, 1)" in the configuration, so 1.5 passed one and failed the other.
TEST(ShiftedSolver, TheApiAndTheConfigurationApplyTheSameRules) {
  SolverOptions o;
  o.symmetry_tol = 1.5;
  EXPECT_EQ(test::message_of<ConfigError>([&] { o.validate(); }),
            "SolverOptions: symmetry_tol = 1.5: must be in [0, 1)");
  o = SolverOptions{};
  o.backend = "mumps";
  EXPECT_EQ(test::message_of<ConfigError>([&] { o.validate(); }),
            "SolverOptions (backend): name = 'mumps': must be one of suitesparse, petsc");
}

}  // namespace
}  // namespace ecmor
