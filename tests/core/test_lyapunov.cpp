// Dense Lyapunov and Sylvester solvers: residuals on random stable matrices, agreement with the
// Kronecker-product formulation (an independent dense linear solve) on small cases, the singular
// equation, and every bad-input rule.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <random>
#include <regex>

#include "common/builders.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/gramians/lyapunov.hpp"

namespace ecmor {
namespace {

using test::random_matrix;

using test::message_of;

/// A random matrix shifted so that all eigenvalues have Re <= -1 (checked with EigenSolver).
Matrix random_stable(Index n, unsigned seed) {
  Matrix A = random_matrix(n, n, seed);
  const double max_re = Eigen::EigenSolver<Matrix>(A, false).eigenvalues().real().maxCoeff();
  A -= (max_re + 1.0) * Matrix::Identity(n, n);
  return A;
}

Matrix random_spd(Index n, unsigned seed) {
  const Matrix R = random_matrix(n, n, seed);
  return Matrix::Identity(n, n) + R * R.transpose() / static_cast<double>(n);
}

/// X from the Kronecker form (E kron A + A kron E) vec X = -vec Q, solved by a dense LU: an
/// independent reference for small n (O(n^6)).
Matrix kronecker_lyapunov(const Matrix& A, const Matrix& E, const Matrix& Q) {
  const Index n = A.rows();
  Matrix L(n * n, n * n);
  for (Index j = 0; j < n; ++j)
    for (Index i = 0; i < n; ++i) L.block(i * n, j * n, n, n) = E(i, j) * A + A(i, j) * E;
  const Vector x = L.partialPivLu().solve(-Eigen::Map<const Vector>(Q.data(), n * n));
  return Eigen::Map<const Matrix>(x.data(), n, n);
}

double rel_diff(const Matrix& X, const Matrix& Y) { return (X - Y).norm() / Y.norm(); }

// Residuals of a backward-stable method are a modest multiple of n eps ||A|| ||X|| / ||Q||; on
// these well-conditioned random problems that is below 1e-12 (measured 1e-15..3e-14).
class LyapunovRandom : public ::testing::TestWithParam<Index> {};

TEST_P(LyapunovRandom, StandardResidualSymmetryAndDefiniteness) {
  const Index n = GetParam();
  const Matrix A = random_stable(n, 11 + static_cast<unsigned>(n));
  const Matrix B = random_matrix(n, 2, 3);
  const Matrix Q = B * B.transpose();
  const Matrix X = solve_lyapunov(A, Q);
  EXPECT_LT(lyapunov_residual(A, Matrix(), X, Q), 1e-12);
  EXPECT_EQ((X - X.transpose()).norm(), 0.0);
  // Q = BB' positive semidefinite and A stable: X = int e^{At} BB' e^{A't} dt is too.
  const Vector ev = Eigen::SelfAdjointEigenSolver<Matrix>(X).eigenvalues();
  EXPECT_GE(ev.minCoeff(), -1e-12 * ev.maxCoeff());
}

TEST_P(LyapunovRandom, GeneralizedWithSpdE) {
  const Index n = GetParam();
  const Matrix A = random_stable(n, 5 + static_cast<unsigned>(n));
  const Matrix E = random_spd(n, 7);
  const Matrix C = random_matrix(3, n, 9);
  const Matrix Q = C.transpose() * C;
  const Matrix X = solve_lyapunov(A, E, Q);
  EXPECT_LT(lyapunov_residual(A, E, X, Q), 1e-12);
}

TEST_P(LyapunovRandom, GeneralizedWithUnsymmetricE) {
  const Index n = GetParam();
  const Matrix A = random_stable(n, 21 + static_cast<unsigned>(n));
  const Matrix E = Matrix::Identity(n, n) + 0.3 * random_matrix(n, n, 4) / std::sqrt(double(n));
  const Matrix Q = random_spd(n, 8);
  const SchurPencil pencil(A, E);
  EXPECT_EQ(pencil.reduction(), "lu");
  const Matrix X = solve_lyapunov(A, E, Q);
  EXPECT_LT(lyapunov_residual(A, E, X, Q), 1e-12);
}

TEST_P(LyapunovRandom, SymmetricPencilUsesRealEigendecomposition) {
  const Index n = GetParam();
  const Matrix R = random_matrix(n, n, 31);
  const Matrix A = -(R * R.transpose() + Matrix::Identity(n, n));
  const Matrix E = random_spd(n, 32);
  const SchurPencil pencil(A, E);
  EXPECT_TRUE(pencil.symmetric());
  EXPECT_EQ(pencil.reduction(), "cholesky");
  const Matrix B = random_matrix(n, 3, 33);
  const Matrix Q = B * B.transpose();
  EXPECT_LT(lyapunov_residual(A, E, solve_lyapunov(A, E, Q), Q), 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Sizes, LyapunovRandom, ::testing::Values(5, 50, 300));

TEST(Lyapunov, AgreesWithKroneckerSolveOnSmallCases) {
  const Index n = 5;
  const Matrix A = random_stable(n, 1);
  const Matrix Q = random_spd(n, 2);
  EXPECT_LT(rel_diff(solve_lyapunov(A, Q), kronecker_lyapunov(A, Matrix::Identity(n, n), Q)),
            1e-13);
  const Matrix Es = random_spd(n, 3);
  EXPECT_LT(rel_diff(solve_lyapunov(A, Es, Q), kronecker_lyapunov(A, Es, Q)), 1e-13);
  const Matrix Eu = Matrix::Identity(n, n) + 0.3 * random_matrix(n, n, 4);
  EXPECT_LT(rel_diff(solve_lyapunov(A, Eu, Q), kronecker_lyapunov(A, Eu, Q)), 1e-12);
}

TEST(Lyapunov, ComplexEigenvalues) {
  // Lightly damped rotations -a +- i w, hidden by an orthogonal similarity.
  const Index n = 6;
  Matrix D = Matrix::Zero(n, n);
  const double a[3] = {0.01, 0.5, 2.0}, w[3] = {10.0, 3.0, 0.1};
  for (int k = 0; k < 3; ++k) {
    D.block(2 * k, 2 * k, 2, 2) << -a[k], w[k], -w[k], -a[k];
  }
  const Matrix Qo = Eigen::HouseholderQR<Matrix>(random_matrix(n, n, 12)).householderQ();
  const Matrix A = Qo * D * Qo.transpose();
  const Eigen::EigenSolver<Matrix> es(A, false);
  EXPECT_GT(es.eigenvalues().imag().cwiseAbs().maxCoeff(), 9.0);
  const Matrix B = random_matrix(n, 1, 13);
  const Matrix Q = B * B.transpose();
  const Matrix X = solve_lyapunov(A, Q);
  EXPECT_LT(lyapunov_residual(A, Matrix(), X, Q), 1e-12);
  EXPECT_LT(rel_diff(X, kronecker_lyapunov(A, Matrix::Identity(n, n), Q)), 1e-12);
  // One 2 x 2 block in closed form: A = [[-a, w], [-w, -a]], Q = I gives X = I / (2a).
  Matrix A2(2, 2);
  A2 << -0.25, 4.0, -4.0, -0.25;
  EXPECT_LT(rel_diff(solve_lyapunov(A2, Matrix::Identity(2, 2)), Matrix::Identity(2, 2) * 2.0),
            1e-14);
}

TEST(Lyapunov, SingularEquationNamesTheEigenvalues) {
  Matrix A = Matrix::Zero(3, 3);
  A.diagonal() << 1.0, -1.0, -2.0;
  const std::string msg =
      message_of<NumericalError>([&] { solve_lyapunov(A, Matrix::Identity(3, 3)); });
  EXPECT_NE(msg.find("singular"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not stable enough"), std::string::npos) << msg;
  EXPECT_TRUE(std::regex_search(msg, std::regex("lambda_i = 1\\+0i and lambda_j = -1\\+0i|"
                                                "lambda_i = -1\\+0i and lambda_j = 1\\+0i")))
      << msg;
  // The same spectrum behind a similarity: eigenvalues +-1 to rounding.
  const Matrix S = Matrix::Identity(3, 3) + 0.4 * random_matrix(3, 3, 5);
  const Matrix As = S * A * S.inverse();
  const std::string msg2 =
      message_of<NumericalError>([&] { solve_lyapunov(As, Matrix::Identity(3, 3)); });
  EXPECT_TRUE(std::regex_search(msg2, std::regex("lambda_i = -?1[+-]"))) << msg2;
  EXPECT_NE(msg2.find("lambda_i + conj(lambda_j)"), std::string::npos) << msg2;
  // A stable A with an eigenvalue at 0 (lambda + conj(lambda) = 0) is singular as well.
  Matrix A0 = Matrix::Zero(2, 2);
  A0(1, 1) = -1.0;
  EXPECT_NE(message_of<NumericalError>([&] {
              solve_lyapunov(A0, Matrix::Identity(2, 2));
            }).find("lambda_i = 0+0i"),
            std::string::npos);
}

TEST(Lyapunov, BadSizesAreNamed) {
  const Matrix A = random_stable(4, 1);
  const Matrix Q = Matrix::Identity(4, 4);
  EXPECT_NE(message_of<InputError>([&] {
              solve_lyapunov(A, Matrix::Identity(3, 3));
            }).find("solve_lyapunov: Q is 3 x 3: must be 4 x 4"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] {
              solve_lyapunov(Matrix(Matrix::Zero(4, 3)), Q);
            }).find("A is 4 x 3: must be square"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] { solve_lyapunov(Matrix(), Matrix()); }).find("A is 0 x 0"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] {
              solve_lyapunov(A, Matrix::Identity(5, 5), Q);
            }).find("E is 5 x 5: must be 4 x 4"),
            std::string::npos);
  Matrix Qn = Q;
  Qn(0, 1) = 0.5;
  EXPECT_NE(message_of<InputError>([&] { solve_lyapunov(A, Qn); }).find("Q is not symmetric"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] {
              solve_sylvester(A, random_stable(2, 3), Matrix(Matrix::Zero(4, 3)));
            }).find("solve_sylvester: Q is 4 x 3: must be 4 x 2"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] {
              lyapunov_residual(A, Matrix(), Matrix::Identity(3, 3), Q);
            }).find("X is 3 x 3"),
            std::string::npos);
}

TEST(Lyapunov, NonFiniteValuesAreNamed) {
  const Matrix Q = Matrix::Identity(4, 4);
  Matrix A = random_stable(4, 1);
  A(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message_of<InputError>([&] {
              solve_lyapunov(A, Q);
            }).find("A has a non-finite value (nan) at (2, 3)"),
            std::string::npos);
  Matrix Qi = Q;
  Qi(3, 3) = std::numeric_limits<double>::infinity();
  EXPECT_NE(message_of<InputError>([&] {
              solve_lyapunov(random_stable(4, 1), Qi);
            }).find("Q has a non-finite value (inf) at (4, 4)"),
            std::string::npos);
  Matrix E = Matrix::Identity(4, 4);
  E(0, 0) = -std::numeric_limits<double>::infinity();
  EXPECT_NE(message_of<InputError>([&] {
              solve_lyapunov(random_stable(4, 1), E, Q);
            }).find("E has a non-finite value (-inf) at (1, 1)"),
            std::string::npos);
}

TEST(Lyapunov, SingularEIsNotSupported) {
  Matrix E = Matrix::Identity(4, 4);
  E(3, 3) = 0.0;  // an algebraic equation: a DAE
  const std::string msg = message_of<InputError>(
      [&] { solve_lyapunov(random_stable(4, 1), E, Matrix::Identity(4, 4)); });
  EXPECT_NE(msg.find("E is numerically singular"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not supported"), std::string::npos) << msg;
}

TEST(Sylvester, ResidualAndKronecker) {
  const Index n = 40, m = 7;
  const Matrix A = random_stable(n, 41), B = random_stable(m, 42);
  const Matrix Q = random_matrix(n, m, 43);
  const Matrix X = solve_sylvester(A, B, Q);
  EXPECT_LT((A * X + X * B.transpose() + Q).norm() / Q.norm(), 1e-12);
  // Generalized, with an SPD E (Cholesky) on one side and an unsymmetric F (LU) on the other.
  const Matrix E = random_spd(n, 44);
  const Matrix F = Matrix::Identity(m, m) + 0.2 * random_matrix(m, m, 45);
  const Matrix Xg = solve_sylvester(A, E, B, F, Q);
  EXPECT_LT((A * Xg * F.transpose() + E * Xg * B.transpose() + Q).norm() / Q.norm(), 1e-12);
  // Small case against the Kronecker form (F kron A + B kron E) vec X = -vec Q.
  const Matrix a = random_stable(3, 46), b = random_stable(2, 47), e = random_spd(3, 48);
  const Matrix f = Matrix::Identity(2, 2) + 0.2 * random_matrix(2, 2, 49);
  const Matrix q = random_matrix(3, 2, 50);
  Matrix L(6, 6);
  for (Index j = 0; j < 2; ++j)
    for (Index i = 0; i < 2; ++i) L.block(i * 3, j * 3, 3, 3) = f(i, j) * a + b(i, j) * e;
  const Vector x = L.partialPivLu().solve(-Eigen::Map<const Vector>(q.data(), 6));
  EXPECT_LT(rel_diff(solve_sylvester(a, e, b, f, q), Eigen::Map<const Matrix>(x.data(), 3, 2)),
            1e-13);
}

TEST(Sylvester, SingularPairIsNamed) {
  Matrix A = Matrix::Zero(2, 2), B = Matrix::Zero(1, 1);
  A.diagonal() << -3.0, 2.0;
  B(0, 0) = -2.0;
  const std::string msg =
      message_of<NumericalError>([&] { solve_sylvester(A, B, Matrix::Ones(2, 1)); });
  EXPECT_NE(msg.find("lambda_i = 2+0i of the left pencil and mu_j = -2+0i"), std::string::npos)
      << msg;
}

}  // namespace
}  // namespace ecmor
