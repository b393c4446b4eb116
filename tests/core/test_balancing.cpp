// DenseBalancing (gramians/balancing.hpp) against analytic facts of balanced truncation: the
// Hankel singular values of a first-order SISO system, W' E V = I, balanced Gramians of the
// truncation, and Glover's bound against the dense H-infinity error.
#include <gtest/gtest.h>

#include <cmath>

#include "ecmor/base/error.hpp"
#include "ecmor/gramians/balancing.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/measures/hinf_norm.hpp"

using namespace ecmor;

namespace {

/// A stable descriptor model E x' = A x + B u with E SPD, A = -(symmetric positive definite)
/// shifted, B, C random-ish but fixed.
ReducedDescriptorModel test_model(Index n) {
  ReducedDescriptorModel m;
  Matrix R = Matrix::Zero(n, n);
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < n; ++j) R(i, j) = std::sin(1.0 + 3.0 * i * i + 7.0 * j + 0.37 * i * j);
  m.E = Matrix::Identity(n, n) + 0.1 * R * R.transpose() / static_cast<double>(n);
  m.A = -(Matrix::Identity(n, n) * 0.5 + R * R.transpose()) + 0.3 * (R - R.transpose());
  m.B = R.leftCols(2);
  m.C = R.topRows(3);
  return m;
}

}  // namespace

TEST(DenseBalancing, FirstOrderSisoHasTheAnalyticHankelValue) {
  // G(s) = b c / (s + a): P = b^2 / (2a), Q = c^2 / (2a), s_1 = sqrt(PQ) = |b c| / (2a).
  ReducedDescriptorModel m;
  m.E = Matrix::Identity(1, 1);
  m.A = Matrix::Constant(1, 1, -4.0);
  m.B = Matrix::Constant(1, 1, 3.0);
  m.C = Matrix::Constant(1, 1, 2.0);
  const DenseBalancing b(m);
  ASSERT_EQ(b.hankel_singular_values().size(), 1);
  EXPECT_NEAR(b.hankel_singular_values()(0), 6.0 / 8.0, 1e-14);
}

TEST(DenseBalancing, TruncationIsBalancedAndMeetsGloversBound) {
  const ReducedDescriptorModel full = test_model(12);
  const DenseBalancing b(full);
  const Vector& s = b.hankel_singular_values();
  for (Index i = 1; i < s.size(); ++i) EXPECT_LE(s(i), s(i - 1));
  const Index r = 4;
  ASSERT_GT(s(r), 1e-6 * s(0)) << "the test model's truncation error must stand above rounding";
  Matrix V, W;
  b.bases(r, V, W);
  EXPECT_LT((W.transpose() * full.E * V - Matrix::Identity(r, r)).norm(), 1e-10);
  const ReducedDescriptorModel bt = b.truncate(r);
  // The truncation's Gramians are diag(s_1..s_r) (balanced), up to rounding.
  const Gramians g = gramians(ReducedModel(bt));
  EXPECT_LT((g.P - Matrix(s.head(r).asDiagonal())).norm(), 1e-8 * s(0));
  EXPECT_LT((g.Q - Matrix(s.head(r).asDiagonal())).norm(), 1e-8 * s(0));
  // ||G - Gr||_inf <= 2 sum of the discarded values, and above the first discarded one.
  const double tail = s.tail(s.size() - r).sum();
  const double err = hinf_error_norm(ReducedModel(full), ReducedModel(bt)).value;
  EXPECT_LE(err, 2.0 * tail * (1.0 + 1e-6));
  EXPECT_GE(err, s(r) * (1.0 - 1e-6));
}

TEST(DenseBalancing, OrdersOutsideThePositiveValuesAreRefusedByName) {
  const DenseBalancing b(test_model(6));
  EXPECT_THROW(b.truncate(0), InputError);
  try {
    (void)b.truncate(b.positive_count() + 1);
    FAIL() << "an order above the positive Hankel singular values was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("positive Hankel singular values"), std::string::npos);
  }
}
