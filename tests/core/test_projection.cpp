// Petrov-Galerkin projection (seed Eqs. 2, 4) and orthogonalisation with deflation.
#include <gtest/gtest.h>

#include <random>

#include "ecmor/error.hpp"
#include "ecmor/frequency_response.hpp"
#include "ecmor/model_io.hpp"
#include "ecmor/projection.hpp"
#include "ecmor/reduced_response.hpp"

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
// round-off, on a shared model with a velocity output (build_so) and a badly scaled one (lf10).
TEST(Projection, FullOrderReductionReproducesTransferFunction) {
  for (const char* name : {"lf10", "build_so", "iss_so"}) {
    const Model full = load_model(std::string("../shared/models/") + name);
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
  const Model full = load_model("../shared/models/triplechain_saak09_n451");
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
  const Model full = load_model("../shared/models/lf10");
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
  const Model full = load_model("../shared/models/lf10");  // M eigenvalues 3e-11 .. 7e-5
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

namespace ecmor {
namespace {

// The O(n^2) Hessenberg evaluation agrees with a dense LU of P_r(s) per frequency.
TEST(ReducedResponse, HessenbergPathAgreesWithDenseLU) {
  for (const char* name : {"build_so", "iss_so", "build", "cdplayer", "triplechain_saak09_n451"}) {
    const Model full = load_model(std::string("../shared/models/") + name);
    const Index N = size_of(full);
    Matrix Q;
    orthonormalize_append(Q, random_matrix(N, std::min<Index>(N, 30), 11));
    const ReducedModel r = project(full, Q, Q);
    const ReducedResponse fast(r);
    EXPECT_TRUE(fast.hessenberg()) << name;
    for (double f : {1e-4, 0.03, 1.0, 7.5, 300.0}) {
      const Complex s = s_from_hz(f);
      const ComplexMatrix ref = transfer_function(r, s);
      EXPECT_LT(relative_difference(fast(s), ref), 1e-9) << name << " f=" << f;
    }
  }
}

// A singular reduced mass matrix (here: a basis vector in the kernel of a singular M) takes the
// dense fallback and still evaluates correctly.
TEST(ReducedResponse, SingularMassFallsBackToDenseLU) {
  ReducedSecondOrderModel r;
  r.M = Matrix::Zero(2, 2);
  r.M(0, 0) = 1.0;
  r.D = Matrix::Identity(2, 2);
  r.K = 4.0 * Matrix::Identity(2, 2);
  r.B = Matrix::Ones(2, 1);
  r.C = Matrix::Ones(1, 2);
  const ReducedResponse fast(r);
  EXPECT_FALSE(fast.hessenberg());
  const Complex s(0.0, 2.0);
  const Complex expected = 1.0 / (s * s + s + 4.0) + 1.0 / (s + 4.0);
  EXPECT_LT(std::abs(fast(s)(0, 0) - expected), 1e-14);
}

TEST(ReducedResponse, EvaluationAtAPoleIsANumericalError) {
  ReducedDescriptorModel r;
  r.E = Matrix::Identity(2, 2);
  r.A = Matrix::Zero(2, 2);
  r.A(0, 1) = 3.0;
  r.A(1, 0) = -3.0;  // poles +-3i
  r.B = Matrix::Ones(2, 1);
  r.C = Matrix::Ones(1, 2);
  const ReducedResponse fast(r);
  EXPECT_THROW(fast(Complex(0.0, 3.0)), NumericalError);
}

}  // namespace
}  // namespace ecmor
