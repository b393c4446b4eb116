// The BLAS/LAPACK kernels of dense_kernels.hpp against Eigen's own products and against SVDs built
// from known factors.
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/dense_kernels.hpp"

namespace ecmor {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

Matrix random_matrix(Index rows, Index cols, unsigned seed) {
  std::srand(seed);
  return Matrix::Random(rows, cols);
}

TEST(DenseKernels, RealProductAgreesWithEigenInEveryTransposition) {
  // Sizes that are not multiples of any kernel's block size.
  const Matrix A = random_matrix(37, 53, 1), B = random_matrix(53, 29, 2);
  const Matrix At = A.transpose(), Bt = B.transpose();
  const Matrix expected = A * B;
  const double tol = 53 * kEps * A.cwiseAbs().maxCoeff() * B.cwiseAbs().maxCoeff() * 10;
  EXPECT_LE((dense_product(A, B) - expected).cwiseAbs().maxCoeff(), tol);
  EXPECT_LE((dense_product(At, B, true, false) - expected).cwiseAbs().maxCoeff(), tol);
  EXPECT_LE((dense_product(A, Bt, false, true) - expected).cwiseAbs().maxCoeff(), tol);
  EXPECT_LE((dense_product(At, Bt, true, true) - expected).cwiseAbs().maxCoeff(), tol);
}

TEST(DenseKernels, ComplexProductAgreesWithEigen) {
  std::srand(3);
  const ComplexMatrix A = ComplexMatrix::Random(41, 23), B = ComplexMatrix::Random(23, 17);
  const ComplexMatrix expected = A * B;
  EXPECT_LE((dense_product(A, B) - expected).cwiseAbs().maxCoeff(), 23 * kEps * 4 * 10);
}

TEST(DenseKernels, ProductsOfEmptyAndMismatchedShapes) {
  const Matrix A(4, 0), B(0, 3);
  const Matrix C = dense_product(A, B);
  ASSERT_EQ(C.rows(), 4);
  ASSERT_EQ(C.cols(), 3);
  EXPECT_EQ(C.cwiseAbs().maxCoeff(), 0.0);  // an empty inner dimension: the zero matrix
  EXPECT_EQ(dense_product(Matrix(0, 5), Matrix(5, 2)).rows(), 0);
  try {
    dense_product(Matrix(Matrix::Ones(3, 4)), Matrix(Matrix::Ones(3, 4)));
    FAIL() << "inner dimensions 4 and 3 were accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("inner dimensions must agree"), std::string::npos)
        << e.what();
  }
  const ComplexMatrix W = ComplexMatrix::Ones(2, 3);
  EXPECT_THROW(dense_product(W, W), InputError);
}

TEST(DenseKernels, ThinSvdRecoversKnownFactors) {
  // A = U diag(s) V' with orthonormal U (60 x 12), V (12 x 12) and s spanning ten decades.
  const Index m = 60, k = 12;
  const Matrix U =
      Eigen::HouseholderQR<Matrix>(random_matrix(m, k, 4)).householderQ() * Matrix::Identity(m, k);
  const Matrix V =
      Eigen::HouseholderQR<Matrix>(random_matrix(k, k, 5)).householderQ() * Matrix::Identity(k, k);
  Vector s(k);
  for (Index i = 0; i < k; ++i) s(i) = std::pow(10.0, -static_cast<double>(i) * 10.0 / (k - 1));
  const Matrix A = U * s.asDiagonal() * V.transpose();
  for (const Matrix& X : {A, Matrix(A.transpose())}) {
    const ThinSvd svd = thin_svd(X);
    ASSERT_EQ(svd.s.size(), k);
    ASSERT_EQ(svd.U.rows(), X.rows());
    ASSERT_EQ(svd.V.rows(), X.cols());
    for (Index i = 0; i < k; ++i) EXPECT_NEAR(svd.s(i), s(i), 100 * kEps) << "s_" << i;
    EXPECT_LE((svd.U * svd.s.asDiagonal() * svd.V.transpose() - X).cwiseAbs().maxCoeff(),
              100 * kEps);
    EXPECT_LE((svd.U.transpose() * svd.U - Matrix::Identity(k, k)).cwiseAbs().maxCoeff(),
              100 * kEps);
    EXPECT_LE((svd.V.transpose() * svd.V - Matrix::Identity(k, k)).cwiseAbs().maxCoeff(),
              100 * kEps);
  }
}

TEST(DenseKernels, ThinSvdRefusesNonFiniteEntriesAndHandlesEmpty) {
  Matrix A = Matrix::Ones(3, 3);
  A(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(thin_svd(A), InputError);
  const ThinSvd empty = thin_svd(Matrix(5, 0));
  EXPECT_EQ(empty.s.size(), 0);
  EXPECT_EQ(empty.U.rows(), 5);
}

}  // namespace
}  // namespace ecmor
