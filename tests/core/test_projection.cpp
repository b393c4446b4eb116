// Petrov-Galerkin projection (seed Eqs. 2, 4) and orthogonalisation with deflation.
#include <gtest/gtest.h>

#include <random>

#include "ecmor/base/error.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace ecmor {
namespace {

Matrix random_matrix(Index rows, Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  std::normal_distribution<double> dist;
  Matrix X(rows, cols);
  for (Index j = 0; j < cols; ++j)
    for (Index i = 0; i < rows; ++i) X(i, j) = dist(gen);
  return X;
}

double relative_difference(const ComplexMatrix& a, const ComplexMatrix& b) {
  return (a - b).norm() / b.norm();
}

// A "reduction" with V = W = I is the full model: its transfer function must reproduce H to
// round-off, on a benchmark model with a velocity output (build_so) and a badly scaled one (lf10).
TEST(Projection, FullOrderReductionReproducesTransferFunction) {
  for (const char* name : {"lf10", "build_so", "iss_so"}) {
    const Model full = load_model(std::string("models/") + name);
    const Index n = size_of(full);
    const Matrix I = Matrix::Identity(n, n);
    const ReducedModel r = project(full, I, I);
    auto solver = make_shifted_solver(full);
    for (double f : {0.01, 1.0, 13.7, 250.0}) {
      const Complex s = s_from_hz(f);
      const ComplexMatrix H = transfer_function(full, *solver, s);
      EXPECT_LT(relative_difference(transfer_function(r, s), H), 1e-9) << name << " f=" << f;
    }
  }
}

// The reduced transfer function depends only on span(V), span(W): V T and W S give the same Hr
// for invertible T, S. And the reduced matrices equal the dense products.
TEST(Projection, ReducedModelDependsOnlyOnTheSubspaces) {
  const Model full = load_model("models/triplechain_saak09_n451");
  const auto& so = std::get<SecondOrderModel>(full);
  const Index N = so.size(), n = 8;
  Matrix V = random_matrix(N, n, 1);
  Matrix Q;
  orthonormalize_append(Q, V);
  const ReducedSecondOrderModel r1 = project(so, Q, Q);
  EXPECT_LT((r1.K - Q.transpose() * Matrix(so.K) * Q).norm(), 1e-12 * r1.K.norm());
  EXPECT_LT((r1.M - Q.transpose() * Matrix(so.M) * Q).norm(), 1e-12 * r1.M.norm());
  EXPECT_LT((r1.B - Q.transpose() * so.B).norm(), 1e-12 * r1.B.norm());
  const Matrix T = random_matrix(n, n, 2) + 5.0 * Matrix::Identity(n, n);
  const Matrix S = random_matrix(n, n, 3) + 5.0 * Matrix::Identity(n, n);
  const ReducedModel r2 = project(full, Q * T, Q * S);
  for (double f : {1e-4, 0.01, 0.3}) {
    const Complex s = s_from_hz(f);
    EXPECT_LT(relative_difference(transfer_function(r2, s), transfer_function(ReducedModel(r1), s)),
              1e-9);
  }
}

TEST(Projection, MismatchedBasesAreNamed) {
  const Model full = load_model("models/lf10");
  try {
    project(full, Matrix::Identity(18, 3), Matrix::Identity(18, 4));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("18 x 3"), std::string::npos);
  }
  EXPECT_THROW(project(full, Matrix::Identity(17, 3), Matrix::Identity(17, 3)), InputError);
  Matrix bad = Matrix::Identity(18, 2);
  bad(0, 0) = std::nan("");
  EXPECT_THROW(project(full, bad, bad), NumericalError);
}

TEST(Orthonormalize, EuclideanWithDeflation) {
  const Matrix a = random_matrix(50, 1, 4), b = random_matrix(50, 1, 5);
  Matrix X(50, 4);
  X << a, 2.0 * a, b, a - 3.0 * b;  // rank 2
  Matrix Q;
  EXPECT_EQ(orthonormalize_append(Q, X), 2);
  EXPECT_EQ(Q.cols(), 2);
  EXPECT_LT(orthogonality_loss(Q), 1e-14);
  // span(Q) = span(a, b): projecting a and b onto it loses nothing.
  EXPECT_LT((a - Q * (Q.transpose() * a)).norm(), 1e-12 * a.norm());
  EXPECT_LT((b - Q * (Q.transpose() * b)).norm(), 1e-12 * b.norm());
  // Appending later keeps the existing columns untouched.
  const Matrix Q0 = Q;
  EXPECT_EQ(orthonormalize_append(Q, random_matrix(50, 3, 6)), 3);
  EXPECT_EQ((Q.leftCols(2) - Q0).norm(), 0.0);
  EXPECT_LT(orthogonality_loss(Q), 1e-14);
}

TEST(Orthonormalize, MassInnerProductOnABadlyScaledMatrix) {
  const Model full = load_model("models/lf10");  // M eigenvalues 3e-11 .. 7e-5
  const SparseMatrix& M = std::get<SecondOrderModel>(full).M;
  Matrix Q;
  EXPECT_EQ(orthonormalize_append(Q, random_matrix(18, 10, 7), InnerProduct{&M}), 10);
  EXPECT_LT(orthogonality_loss(Q, InnerProduct{&M}), 1e-10);
}

TEST(Orthonormalize, RejectsNonFiniteAndMismatchedInput) {
  Matrix Q = Matrix::Identity(5, 1);
  EXPECT_THROW(orthonormalize_append(Q, Matrix::Ones(4, 1)), InputError);
  Matrix X = Matrix::Ones(5, 1);
  X(2, 0) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(orthonormalize_append(Q, X), NumericalError);
}

}  // namespace
}  // namespace ecmor
