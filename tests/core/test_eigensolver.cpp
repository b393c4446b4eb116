// Tests of the ARPACK shift-invert eigensolvers against dense Eigen references and analytic
// spectra. The factorisation is a test-only dense LU, which also shows that the eigensolvers depend
// only on the Factorization interface (backend neutrality).
#include <gtest/gtest.h>
#include <zlib.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "ecmor/linalg/eigensolver.hpp"

namespace ecmor {
namespace {

// ---- test helpers ---------------------------------------------------------------------------

// Dense LU of a real matrix P behind the Factorization interface.
class DenseLuFactorization final : public Factorization {
 public:
  explicit DenseLuFactorization(const Matrix& P) : m_lu(P), m_lu_t(Matrix(P.transpose())) {}
  Index size() const override { return m_lu.rows(); }
  bool is_complex() const override { return false; }
  std::string method() const override { return "dense-lu (test)"; }
  const std::vector<Complex>& weights() const override { return m_weights; }
  double rcond() const override { return m_lu.rcond(); }
  Matrix solve(const Matrix& B) const override { return m_lu.solve(B); }
  ComplexMatrix solve(const ComplexMatrix& B) const override {
    return m_lu.solve(B.real()).cast<Complex>() +
           Complex(0, 1) * m_lu.solve(B.imag()).cast<Complex>();
  }
  Matrix solve_transposed(const Matrix& B) const override { return m_lu_t.solve(B); }
  ComplexMatrix solve_transposed(const ComplexMatrix& B) const override {
    return m_lu_t.solve(B.real()).cast<Complex>() +
           Complex(0, 1) * m_lu_t.solve(B.imag()).cast<Complex>();
  }

 private:
  Eigen::PartialPivLU<Matrix> m_lu;
  Eigen::PartialPivLU<Matrix> m_lu_t;
  std::vector<Complex> m_weights;
};

// Minimal Matrix Market reader (coordinate real general, as all the benchmark models are stored,
// gzip'ed or not); kept independent of model_io and of ecmor's own gzip decompression (it reads
// through zlib's gzFile, which takes plain and compressed files alike) so this test checks the
// eigensolver alone.
SparseMatrix read_mtx(const std::string& path) {
  const gzFile in = gzopen(path.c_str(), "rb");
  if (!in) throw std::runtime_error("cannot open " + path);
  std::string text;
  char chunk[1 << 16];
  for (int got = 0; (got = gzread(in, chunk, sizeof chunk)) > 0;) text.append(chunk, got);
  gzclose(in);
  std::istringstream lines(text);
  std::string line;
  do {
    std::getline(lines, line);
  } while (!line.empty() && line[0] == '%');
  std::istringstream header(line);
  Index rows = 0, cols = 0, nnz = 0;
  header >> rows >> cols >> nnz;
  std::vector<Eigen::Triplet<double, int>> triplets;
  for (Index k = 0; k < nnz; ++k) {
    int i = 0, j = 0;
    double v = 0.0;
    lines >> i >> j >> v;
    triplets.emplace_back(i - 1, j - 1, v);
  }
  if (!lines) throw std::runtime_error(path + ": fewer entries than its size line promises");
  SparseMatrix A(rows, cols);
  A.setFromTriplets(triplets.begin(), triplets.end());
  return A;
}

std::string model_dir(const std::string& name) { return "models/" + name + "/"; }

// sin of the largest principal angle between span(X) and span(Y) (Euclidean): ||(I - QyQy')Qx||_2.
double largest_angle_sin(const Matrix& X, const Matrix& Y) {
  const Matrix Qx =
      Eigen::HouseholderQR<Matrix>(X).householderQ() * Matrix::Identity(X.rows(), X.cols());
  const Matrix Qy =
      Eigen::HouseholderQR<Matrix>(Y).householderQ() * Matrix::Identity(Y.rows(), Y.cols());
  const Matrix R = Qx - Qy * (Qy.transpose() * Qx);
  return Eigen::JacobiSVD<Matrix>(R).singularValues()(0);
}

// Fixed-fixed spring-mass chain, unit springs and masses: K = tridiag(-1, 2, -1), M = I,
// lambda_j = 4 sin^2(j pi / (2 (N + 1))).
SparseMatrix chain_stiffness(Index n) {
  std::vector<Eigen::Triplet<double, int>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0);
    if (i + 1 < n) {
      t.emplace_back(i, i + 1, -1.0);
      t.emplace_back(i + 1, i, -1.0);
    }
  }
  SparseMatrix K(n, n);
  K.setFromTriplets(t.begin(), t.end());
  return K;
}

SparseMatrix sparse_identity(Index n) {
  SparseMatrix I(n, n);
  I.setIdentity();
  return I;
}

struct Pencil {
  SparseMatrix K, M;
};

Pencil load_second_order(const std::string& name) {
  return {read_mtx(model_dir(name) + "K.mtx.gz"), read_mtx(model_dir(name) + "M.mtx.gz")};
}

// Checks everything an eigen-decomposition of the symmetric pencil must satisfy.
void expect_valid_symmetric_pairs(const SparseMatrix& K, const SparseMatrix& M,
                                  const SymmetricEigenResult& r, double residual_tol) {
  const Index k = r.eigenvalues.size();
  ASSERT_EQ(r.eigenvectors.cols(), k);
  for (Index j = 1; j < k; ++j) EXPECT_LE(r.eigenvalues[j - 1], r.eigenvalues[j]);
  const Matrix gram = r.eigenvectors.transpose() * (M * r.eigenvectors);
  EXPECT_LT((gram - Matrix::Identity(k, k)).cwiseAbs().maxCoeff(), 1e-12) << "M-orthonormality";
  const double k_norm = Matrix(K).norm();
  for (Index j = 0; j < k; ++j) {
    const Vector phi = r.eigenvectors.col(j);
    const double res = (K * phi - r.eigenvalues[j] * (M * phi)).norm() / (k_norm * phi.norm());
    EXPECT_LT(res, residual_tol) << "residual of pair " << j;
  }
}

// ---- options --------------------------------------------------------------------------------

TEST(EigenOptions, ValidRangesPass) {
  EigenOptions o;
  o.nev = 5;
  EXPECT_NO_THROW(o.validate(10));
  o.ncv = 10;
  EXPECT_NO_THROW(o.validate(10));
}

void expect_config_error(const EigenOptions& o, Index n, const std::string& needle) {
  try {
    o.validate(n);
    FAIL() << "expected ConfigError containing '" << needle << "'";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(EigenOptions, EachRuleNamesTheField) {
  EigenOptions o;
  o.nev = 0;
  expect_config_error(o, 10, "EigenOptions::nev = 0: must be >= 1");
  o.nev = 10;
  expect_config_error(o, 10, "EigenOptions::nev = 10: must be < N = 10");
  o.nev = 4;
  o.ncv = 4;
  expect_config_error(o, 10, "EigenOptions::ncv = 4");
  o.ncv = 11;
  expect_config_error(o, 10, "EigenOptions::ncv = 11");
  o.ncv = 0;
  o.tolerance = -1e-3;
  expect_config_error(o, 10, "EigenOptions::tolerance");
  o.tolerance = std::nan("");
  expect_config_error(o, 10, "EigenOptions::tolerance");
  o.tolerance = 0.0;
  o.max_iterations = 0;
  expect_config_error(o, 10, "EigenOptions::max_iterations = 0");
}

// ---- symmetric ------------------------------------------------------------------------------

TEST(SymmetricShiftInvert, AnalyticChainSpectrumByArpack) {
  const Index n = 200;
  const SparseMatrix K = chain_stiffness(n);
  const SparseMatrix M = sparse_identity(n);
  const double sigma = -1e-3;  // below the spectrum: K - sigma M is SPD
  DenseLuFactorization f(Matrix(K) - sigma * Matrix(M));
  EigenOptions o;
  o.nev = 8;
  const SymmetricEigenResult r = symmetric_shift_invert(f, M, sigma, o);
  EXPECT_FALSE(r.dense_fallback);
  ASSERT_EQ(r.eigenvalues.size(), 8);
  for (Index j = 0; j < 8; ++j) {
    const double s = std::sin(static_cast<double>(j + 1) * kPi / (2.0 * (n + 1)));
    EXPECT_NEAR(r.eigenvalues[j], 4.0 * s * s, 1e-12 * 4.0 * s * s) << j;
  }
  EXPECT_GT(r.operator_applications, 8);
  expect_valid_symmetric_pairs(K, M, r, 1e-13);
}

// A stop request (the run's time limit, a signal) ends an ARPACK run between two operator
// applications with Interrupted naming ARPACK and the shift; without one the same run completes.
// Only the thread that installed the scope sees it.
TEST(SymmetricShiftInvert, StopRequestInterruptsArpackBetweenApplications) {
  const Index n = 200;
  const SparseMatrix K = chain_stiffness(n);
  const SparseMatrix M = sparse_identity(n);
  DenseLuFactorization f(Matrix(K) + 1e-3 * Matrix(M));
  EigenOptions o;
  o.nev = 8;
  int polls = 0;
  {
    InterruptScope scope([&] { return ++polls > 5; });
    try {
      symmetric_shift_invert(f, M, -1e-3, o);
      FAIL() << "not interrupted";
    } catch (const Interrupted& e) {
      EXPECT_NE(std::string(e.what()).find("interrupted in ARPACK dsaupd (sigma = -0.001, nev = 8"),
                std::string::npos)
          << e.what();
    }
    EXPECT_EQ(polls, 6);
    // Another thread has no scope: its run is not interrupted.
    SymmetricEigenResult other;
    std::thread worker([&] { other = symmetric_shift_invert(f, M, -1e-3, o); });
    worker.join();
    EXPECT_EQ(other.eigenvalues.size(), 8);
  }
  // The scope is gone: the run completes.
  EXPECT_EQ(symmetric_shift_invert(f, M, -1e-3, o).eigenvalues.size(), 8);
  EXPECT_EQ(polls, 6);
}

TEST(SymmetricShiftInvert, TriplechainAgainstDenseReference) {
  const Pencil p = load_second_order("triplechain_saak09_n451");
  const Matrix Kd(p.K), Md(p.M);
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> dense(Kd, Md);
  const Vector& ref = dense.eigenvalues();
  // A shift inside the spectrum (K - sigma M indefinite): the nev eigenvalues nearest sigma.
  const Index centre = 100;
  const double sigma = 0.5 * (ref[centre] + ref[centre + 1]);
  DenseLuFactorization f(Kd - sigma * Md);
  EigenOptions o;
  o.nev = 12;
  o.seed = 42;
  const SymmetricEigenResult r = symmetric_shift_invert(f, p.M, sigma, o);
  ASSERT_EQ(r.eigenvalues.size(), 12);
  // The dense eigenvalues nearest sigma: a window [lo, lo + 12) around centre.
  Index lo = centre, hi = centre + 1;  // [lo, hi)
  while (hi - lo < 12) {
    if (lo > 0 && (hi >= ref.size() || sigma - ref[lo - 1] < ref[hi] - sigma))
      --lo;
    else
      ++hi;
  }
  // The window must be separated from the rest, else "nearest 12" is ambiguous.
  const double radius = std::max(sigma - ref[lo], ref[hi - 1] - sigma);
  ASSERT_LT(radius, std::min(sigma - ref[lo - 1], ref[hi] - sigma));
  for (Index j = 0; j < 12; ++j) {
    EXPECT_NEAR(r.eigenvalues[j], ref[lo + j], 1e-10 * std::abs(ref[lo + j])) << j;
  }
  EXPECT_LT(largest_angle_sin(r.eigenvectors, dense.eigenvectors().middleCols(lo, 12)), 1e-8);
  expect_valid_symmetric_pairs(p.K, p.M, r, 1e-12);
}

TEST(SymmetricShiftInvert, Lf10BadlyScaledMassUsesDenseFallback) {
  const Pencil p = load_second_order("lf10");
  const Matrix Kd(p.K), Md(p.M);
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> dense(Kd, Md);
  const Vector& ref = dense.eigenvalues();
  const double sigma = -0.5 * ref[0];
  DenseLuFactorization f(Kd - sigma * Md);
  EigenOptions o;
  o.nev = 6;
  const SymmetricEigenResult r = symmetric_shift_invert(f, p.M, sigma, o);
  EXPECT_TRUE(r.dense_fallback);
  ASSERT_EQ(r.eigenvalues.size(), 6);
  for (Index j = 0; j < 6; ++j) {
    EXPECT_NEAR(r.eigenvalues[j], ref[j], 1e-10 * ref[j]) << j;
  }
  // Modes one at a time: the lf10 spectrum is simple.
  for (Index j = 0; j < 6; ++j) {
    EXPECT_LT(largest_angle_sin(r.eigenvectors.col(j), dense.eigenvectors().col(j)), 1e-8) << j;
  }
  // M has entries ~1e-5..1e-11 and the eigenvectors are M-normalised, hence huge; the residual is
  // relative to ||K|| ||phi||.
  expect_valid_symmetric_pairs(p.K, p.M, r, 1e-13);
}

TEST(SymmetricShiftInvert, SeededRunsAreReproducible) {
  const Index n = 120;
  const SparseMatrix K = chain_stiffness(n);
  const SparseMatrix M = sparse_identity(n);
  DenseLuFactorization f(Matrix(K) + 0.01 * Matrix(M));
  EigenOptions o;
  o.nev = 5;
  o.seed = 7;
  const SymmetricEigenResult a = symmetric_shift_invert(f, M, -0.01, o);
  const SymmetricEigenResult b = symmetric_shift_invert(f, M, -0.01, o);
  EXPECT_EQ(a.eigenvalues, b.eigenvalues);
  EXPECT_EQ(a.operator_applications, b.operator_applications);
}

TEST(SymmetricShiftInvert, NonConvergenceReportsInfoCodeInWords) {
  const Index n = 400;
  const SparseMatrix K = chain_stiffness(n);
  const SparseMatrix M = sparse_identity(n);
  // A shift in the middle of a dense, clustered spectrum, a minimal Krylov space and one restart.
  DenseLuFactorization f(Matrix(K) - 2.0 * Matrix(M) + 1e-9 * Matrix::Identity(n, n));
  EigenOptions o;
  o.nev = 30;
  o.ncv = 32;
  o.max_iterations = 1;
  o.seed = 3;
  try {
    symmetric_shift_invert(f, M, 2.0 - 1e-9, o);
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("info = 1"), std::string::npos) << msg;
    EXPECT_NE(msg.find("maximum number of restarts reached"), std::string::npos) << msg;
    EXPECT_NE(msg.find("of 30 eigenpairs converged"), std::string::npos) << msg;
  }
}

TEST(SymmetricShiftInvert, MismatchedSizesNameM) {
  DenseLuFactorization f(Matrix::Identity(50, 50));
  const SparseMatrix M = sparse_identity(40);
  try {
    symmetric_shift_invert(f, M, 0.0, EigenOptions{});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("M is 40 x 40"), std::string::npos) << e.what();
  }
}

TEST(SymmetricShiftInvert, IndefiniteMassInDenseFallbackIsNamed) {
  SparseMatrix M = sparse_identity(10);
  M.coeffRef(3, 3) = -1.0;
  DenseLuFactorization f(Matrix(chain_stiffness(10)) + Matrix(M));
  EigenOptions o;
  o.nev = 2;
  try {
    symmetric_shift_invert(f, M, -1.0, o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("M is not positive definite"), std::string::npos)
        << e.what();
  }
}

// ---- general --------------------------------------------------------------------------------

struct DescriptorPencil {
  SparseMatrix A, E;
};

DescriptorPencil load_descriptor(const std::string& name) {
  return {read_mtx(model_dir(name) + "A.mtx.gz"), read_mtx(model_dir(name) + "E.mtx.gz")};
}

// Dense reference: generalized eigenvalues of (A, E), finite ones.
std::vector<Complex> dense_pencil_eigenvalues(const Matrix& A, const Matrix& E) {
  Eigen::GeneralizedEigenSolver<Matrix> ges(A, E, false);
  std::vector<Complex> out;
  for (Index j = 0; j < A.rows(); ++j) {
    if (std::abs(ges.betas()[j]) > 1e-13 * std::abs(ges.alphas()[j])) {
      out.push_back(ges.alphas()[j] / ges.betas()[j]);
    }
  }
  return out;
}

void check_general(const DescriptorPencil& p, double sigma, Index nev, bool left,
                   bool expect_dense) {
  const Matrix Ad(p.A), Ed(p.E);
  DenseLuFactorization f(Ad - sigma * Ed);
  EigenOptions o;
  o.nev = nev;
  o.seed = 11;
  const GeneralEigenResult r = general_shift_invert(f, p.E, sigma, o, left);
  EXPECT_EQ(r.dense_fallback, expect_dense);
  ASSERT_GE(r.eigenvalues.size(), nev);
  ASSERT_LE(r.eigenvalues.size(), nev + 1);
  std::vector<Complex> ref = dense_pencil_eigenvalues(Ad, Ed);
  std::sort(ref.begin(), ref.end(),
            [&](Complex a, Complex b) { return std::abs(a - sigma) < std::abs(b - sigma); });
  const double a_norm = Ad.norm(), e_norm = Ed.norm();
  for (Index j = 0; j < r.eigenvalues.size(); ++j) {
    const Complex l = r.eigenvalues[j];
    // Matches one of the dense eigenvalues nearest sigma (QZ's own error is ~eps ||A|| / |beta|).
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0;
         k < static_cast<std::size_t>(r.eigenvalues.size()) + 2 && k < ref.size(); ++k) {
      best = std::min(best, std::abs(ref[k] - l));
    }
    EXPECT_LT(best, 1e-9 * std::abs(l)) << "eigenvalue " << l;
    if (j > 0) {
      EXPECT_LE(std::abs(r.eigenvalues[j - 1] - sigma), std::abs(l - sigma) * (1 + 1e-12));
    }
    const ComplexVector x = r.eigenvectors.col(j);
    EXPECT_NEAR(x.norm(), 1.0, 1e-12);
    // Right: A x = l E x.  Left: y' A = l y' E  <=>  A' y = l E' y.
    const ComplexVector res =
        left ? ComplexVector(Ad.transpose().cast<Complex>() * x -
                             l * (Ed.transpose().cast<Complex>() * x))
             : ComplexVector(Ad.cast<Complex>() * x - l * (Ed.cast<Complex>() * x));
    EXPECT_LT(res.norm() / (a_norm + std::abs(l) * e_norm), 1e-11) << "residual of " << l;
  }
  // Every dense eigenvalue strictly nearer sigma than the farthest returned one is returned.
  const double radius = std::abs(r.eigenvalues[r.eigenvalues.size() - 1] - sigma);
  for (const Complex& l : ref) {
    if (std::abs(l - sigma) < radius * (1 - 1e-8)) {
      double best = std::numeric_limits<double>::infinity();
      for (Index j = 0; j < r.eigenvalues.size(); ++j)
        best = std::min(best, std::abs(r.eigenvalues[j] - l));
      EXPECT_LT(best, 1e-9 * std::abs(l)) << "missed " << l;
    }
  }
}

TEST(GeneralShiftInvert, BuildRightAndLeftByArpack) {
  const DescriptorPencil p = load_descriptor("build");  // N = 48, complex pairs
  check_general(p, 0.0 - 1.0, 6, false, false);
  check_general(p, -1.0, 6, true, false);
}

TEST(GeneralShiftInvert, IssNearAResonanceByArpack) {
  const DescriptorPencil p = load_descriptor("iss");  // N = 270, lightly damped pairs
  check_general(p, -0.1, 10, false, false);
  check_general(p, -0.1, 10, true, false);
}

TEST(GeneralShiftInvert, SymmetricPencilAgreesWithSymmetricSolver) {
  const Index n = 150;
  const SparseMatrix K = chain_stiffness(n);
  const SparseMatrix M = sparse_identity(n);
  DescriptorPencil p{K, M};
  check_general(p, -0.01, 5, false, false);
  DenseLuFactorization f(Matrix(K) + 0.01 * Matrix(M));
  EigenOptions o;
  o.nev = 5;
  const GeneralEigenResult g = general_shift_invert(f, M, -0.01, o);
  const SymmetricEigenResult s = symmetric_shift_invert(f, M, -0.01, o);
  ASSERT_EQ(g.eigenvalues.size(), 5);
  for (Index j = 0; j < 5; ++j) {
    EXPECT_NEAR(g.eigenvalues[j].real(), s.eigenvalues[j], 1e-12 * s.eigenvalues[j]);
    EXPECT_EQ(g.eigenvalues[j].imag(), 0.0);
  }
}

TEST(GeneralShiftInvert, SingularEDenseFallbackDropsInfiniteEigenvalues) {
  // A 4 x 4 DAE: E = diag(1, 1, 1, 0). Finite eigenvalues are those of the Schur complement.
  Matrix Ad(4, 4);
  Ad << -1, 2, 0, 1,  //
      -2, -1, 0, 0,   //
      0, 0, -3, 1,    //
      1, 0, 1, -1;
  Matrix Ed = Matrix::Identity(4, 4);
  Ed(3, 3) = 0.0;
  const DescriptorPencil p{Ad.sparseView(), Ed.sparseView()};
  // Reference: eliminate x4 = (x1 + x3) (from row 4) -> 3 x 3 standard problem.
  const Matrix S =
      Ad.topLeftCorner(3, 3) - Ad.topRightCorner(3, 1) * Ad.bottomLeftCorner(1, 3) / Ad(3, 3);
  const Eigen::VectorXcd ref = S.eigenvalues();
  DenseLuFactorization f(Ad - 0.5 * Ed);
  EigenOptions o;
  o.nev = 3;
  const GeneralEigenResult r = general_shift_invert(f, p.E, 0.5, o);
  EXPECT_TRUE(r.dense_fallback);
  ASSERT_EQ(r.eigenvalues.size(), 3);
  for (Index j = 0; j < 3; ++j) {
    double best = std::numeric_limits<double>::infinity();
    for (Index k = 0; k < 3; ++k) best = std::min(best, std::abs(ref[k] - r.eigenvalues[j]));
    EXPECT_LT(best, 1e-12 * std::abs(r.eigenvalues[j])) << r.eigenvalues[j];
  }
}

TEST(GeneralShiftInvert, ComplexFactorisationIsRejected) {
  class ComplexFactorization final : public Factorization {
   public:
    Index size() const override { return 40; }
    bool is_complex() const override { return true; }
    std::string method() const override { return "fake"; }
    const std::vector<Complex>& weights() const override { return m_w; }
    double rcond() const override { return 1.0; }
    Matrix solve(const Matrix& B) const override { return B; }
    ComplexMatrix solve(const ComplexMatrix& B) const override { return B; }
    Matrix solve_transposed(const Matrix& B) const override { return B; }
    ComplexMatrix solve_transposed(const ComplexMatrix& B) const override { return B; }

   private:
    std::vector<Complex> m_w;
  } f;
  try {
    general_shift_invert(f, sparse_identity(40), 0.0, EigenOptions{});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("complex"), std::string::npos) << e.what();
  }
}

// ---- dense reference --------------------------------------------------------------------------

TEST(DenseGeneralizedEigenvalues, DiagonalPencilIsExact) {
  const Vector k = (Vector(4) << 8.0, 1.0, 27.0, 2.0).finished();
  const Vector m = (Vector(4) << 2.0, 4.0, 3.0, 1.0).finished();
  const Vector l =
      dense_generalized_eigenvalues(k.asDiagonal().toDenseMatrix(), m.asDiagonal().toDenseMatrix());
  const Vector expected = (Vector(4) << 0.25, 2.0, 4.0, 9.0).finished();
  EXPECT_LT((l - expected).cwiseAbs().maxCoeff(), 1e-14 * 9.0);
}

TEST(DenseGeneralizedEigenvalues, NonsymmetricRealSpectrum) {
  // Upper-triangular K with M = I: eigenvalues are the diagonal.
  Matrix K(3, 3);
  K << 3, 1, 5, 0, -2, 4, 0, 0, 7;
  const Vector l = dense_generalized_eigenvalues(K, Matrix::Identity(3, 3));
  EXPECT_NEAR(l[0], -2.0, 1e-13);
  EXPECT_NEAR(l[1], 3.0, 1e-13);
  EXPECT_NEAR(l[2], 7.0, 1e-13);
}

TEST(DenseGeneralizedEigenvalues, BadInputIsNamed) {
  try {
    dense_generalized_eigenvalues(Matrix::Identity(3, 3), Matrix::Identity(4, 4));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("K is 3 x 3 and M is 4 x 4"), std::string::npos);
  }
  Matrix R(2, 2);
  R << 0, 1, -1, 0;  // eigenvalues +-i
  try {
    dense_generalized_eigenvalues(R, Matrix::Identity(2, 2));
    FAIL();
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("complex eigenvalue"), std::string::npos);
  }
}

}  // namespace

}  // namespace ecmor
