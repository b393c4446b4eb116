// second_order_form(): recognising a first-order model E x' = A x + B u that is a second-order
// model in the state x = [q; q']. References: the shipped second-order form of the ISS model
// (iss_so, converted independently from the same SLICOT file), a one-degree-of-freedom oscillator
// whose transfer function is written down by hand, and transfer functions by dense Eigen LU solves.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "common/builders.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/model/model_io.hpp"

namespace ecmor {
namespace {

using test::shared_model;
using test::sparse;

// H(s) = C (s E - A)^-1 B by a dense LU.
ComplexMatrix dense_h(const DescriptorModel& m, Complex s) {
  const ComplexMatrix P = s * Matrix(m.E).cast<Complex>() - Matrix(m.A).cast<Complex>();
  return m.C.cast<Complex>() * P.partialPivLu().solve(m.B.cast<Complex>());
}

// H(s) = (C + s Cv) (s^2 M + s D + K)^-1 B by a dense LU.
ComplexMatrix dense_h(const SecondOrderModel& m, Complex s) {
  const ComplexMatrix P = (s * s) * Matrix(m.M).cast<Complex>() + s * Matrix(m.D).cast<Complex>() +
                          Matrix(m.K).cast<Complex>();
  ComplexMatrix C = m.C.cast<Complex>();
  if (m.has_velocity_output()) C += s * m.Cv.cast<Complex>();
  return C * P.partialPivLu().solve(m.B.cast<Complex>());
}

// A first-order realisation E = blkdiag(F, M), A = [0 F; -K -D], B = [0; B2], C = [C1 C2] of a
// second-order model, written from the definition (dense, for small test cases).
DescriptorModel realise(const Matrix& F, const Matrix& M, const Matrix& D, const Matrix& K,
                        const Matrix& B2, const Matrix& C1, const Matrix& C2) {
  const Index n = M.rows();
  Matrix E = Matrix::Zero(2 * n, 2 * n), A = Matrix::Zero(2 * n, 2 * n);
  E.topLeftCorner(n, n) = F;
  E.bottomRightCorner(n, n) = M;
  A.topRightCorner(n, n) = F;
  A.bottomLeftCorner(n, n) = -K;
  A.bottomRightCorner(n, n) = -D;
  DescriptorModel m;
  m.E = sparse(E);
  m.A = sparse(A);
  m.B = Matrix::Zero(2 * n, B2.cols());
  m.B.bottomRows(n) = B2;
  m.C.resize(C1.rows(), 2 * n);
  m.C << C1, C2;
  return m;
}

// A small model with every block non-trivial: F SPD and not diagonal (F need not be I), M SPD,
// D and K symmetric, two inputs, two outputs with both position and velocity parts.
DescriptorModel small_model() {
  Matrix F(3, 3), M(3, 3), D(3, 3), K(3, 3), B2(3, 2), C1(2, 3), C2(2, 3);
  F << 2.0, 0.5, 0.0, 0.5, 1.5, 0.25, 0.0, 0.25, 1.0;
  M << 1.0, 0.1, 0.0, 0.1, 2.0, 0.0, 0.0, 0.0, 0.5;
  D << 0.3, -0.1, 0.0, -0.1, 0.2, 0.0, 0.0, 0.0, 0.1;
  K << 4.0, -1.0, 0.0, -1.0, 3.0, -1.0, 0.0, -1.0, 2.0;
  B2 << 1.0, 0.0, 0.0, 2.0, -1.0, 0.5;
  C1 << 1.0, 0.0, 0.0, 0.0, 0.0, 1.0;
  C2 << 0.0, 0.5, 0.0, 0.3, 0.0, 0.0;
  return realise(F, M, D, K, B2, C1, C2);
}

TEST(SecondOrderForm, OneDegreeOfFreedomMatchesTheAnalyticTransferFunction) {
  // m q'' + d q' + k q = b u, y = c q + cv q', written with F = 3 (not 1) in E11 and A12:
  // H(s) = (c + s cv) b / (m s^2 + d s + k).
  const double f = 3.0, m = 2.0, d = 0.4, k = 5.0, b = 1.5, c = 0.7, cv = -0.2;
  const DescriptorModel fo =
      realise(Matrix::Constant(1, 1, f), Matrix::Constant(1, 1, m), Matrix::Constant(1, 1, d),
              Matrix::Constant(1, 1, k), Matrix::Constant(1, 1, b), Matrix::Constant(1, 1, c),
              Matrix::Constant(1, 1, cv));
  const auto so = second_order_form(fo);
  ASSERT_TRUE(so.has_value());
  EXPECT_EQ(Matrix(so->M)(0, 0), m);
  EXPECT_EQ(Matrix(so->D)(0, 0), d);
  EXPECT_EQ(Matrix(so->K)(0, 0), k);
  EXPECT_EQ(so->B(0, 0), b);
  EXPECT_EQ(so->C(0, 0), c);
  ASSERT_TRUE(so->has_velocity_output());
  EXPECT_EQ(so->Cv(0, 0), cv);
  for (const Complex s :
       {Complex(0.0, 0.0), Complex(0.0, 1.0), Complex(0.0, std::sqrt(k / m)), Complex(2.0, 30.0)}) {
    const Complex h = (c + s * cv) * b / (m * s * s + d * s + k);
    // A 1 x 1 (2 x 2 first-order) solve: rounding only, a few eps relative.
    EXPECT_NEAR(std::abs(dense_h(*so, s)(0, 0) - h) / std::abs(h), 0.0, 1e-14) << s;
    EXPECT_NEAR(std::abs(dense_h(fo, s)(0, 0) - h) / std::abs(h), 0.0, 1e-14) << s;
  }
}

TEST(SecondOrderForm, VelocityOutputStaysEmptyWhenC2IsZero) {
  DescriptorModel fo = small_model();
  fo.C.rightCols(3).setZero();
  const auto so = second_order_form(fo);
  ASSERT_TRUE(so.has_value());
  EXPECT_FALSE(so->has_velocity_output());
  EXPECT_EQ(so->C.rows(), 2);
  EXPECT_EQ(so->C.cols(), 3);
}

TEST(SecondOrderForm, SmallModelWithNonIdentityE11HasTheSameTransferFunction) {
  const DescriptorModel fo = small_model();
  const auto so = second_order_form(fo);
  ASSERT_TRUE(so.has_value());
  EXPECT_EQ(so->size(), 3);
  for (const Complex s :
       {Complex(0.0, 0.0), Complex(0.0, 0.7), Complex(0.0, 5.0), Complex(1.0, 2.0)}) {
    const ComplexMatrix H = dense_h(fo, s);
    // 3 x 3 and 6 x 6 well-conditioned dense solves: agreement to a few hundred eps.
    EXPECT_LT((dense_h(*so, s) - H).norm() / H.norm(), 1e-13) << s;
  }
}

TEST(SecondOrderForm, IssIsRecognisedAndEqualsTheShippedSecondOrderModel) {
  const Model full = shared_model("iss");
  const auto& fo = std::get<DescriptorModel>(full);
  const auto so = second_order_form(fo);
  ASSERT_TRUE(so.has_value());
  ASSERT_EQ(so->size(), 135);
  // iss_so was derived from the same SLICOT file by another converter: M = I, D, K diagonal,
  // velocity outputs (C zero).
  const Model ref_model = shared_model("iss_so");
  const auto& ref = std::get<SecondOrderModel>(ref_model);
  EXPECT_EQ(Matrix(so->M), Matrix(ref.M));
  EXPECT_EQ(Matrix(so->D), Matrix(ref.D));
  EXPECT_EQ(Matrix(so->K), Matrix(ref.K));
  EXPECT_EQ(so->B, ref.B);
  EXPECT_EQ(so->C.cwiseAbs().maxCoeff(), 0.0);
  ASSERT_TRUE(so->has_velocity_output());
  EXPECT_EQ(so->Cv, ref.Cv);
  // Transfer functions by dense LU of the 270 x 270 first-order pencil and of the 135 x 135
  // second-order one, at frequencies across the band, on and off the resonance peak (0.766 rad/s,
  // info.json). The modal system is diagonal: both solves are exact to rounding, relative to
  // ||H||, up to the pencils' condition (<= 1e5 here), so 1e-10.
  for (const double w : {0.01, 0.7663410868011648, 3.0, 37.0, 400.0}) {
    const Complex s(0.0, w);
    const ComplexMatrix H = dense_h(fo, s);
    EXPECT_LT((dense_h(*so, s) - H).norm() / H.norm(), 1e-10) << "omega = " << w;
  }
}

TEST(SecondOrderForm, EachBrokenRuleIsNotRecognised) {
  const DescriptorModel good = small_model();
  ASSERT_TRUE(second_order_form(good).has_value());
  const Index n = 3;
  auto with = [&](const std::function<void(Matrix & E, Matrix & A, DescriptorModel & m)>& change) {
    DescriptorModel m = good;
    Matrix E(m.E), A(m.A);
    change(E, A, m);
    m.E = sparse(E);
    m.A = sparse(A);
    return second_order_form(m).has_value();
  };
  EXPECT_FALSE(with([&](Matrix& E, Matrix&, DescriptorModel&) { E(0, n + 1) = 1e-3; }))
      << "E12 nonzero";
  EXPECT_FALSE(with([&](Matrix& E, Matrix&, DescriptorModel&) { E(n + 2, 1) = 1e-3; }))
      << "E21 nonzero";
  EXPECT_FALSE(with([&](Matrix&, Matrix& A, DescriptorModel&) { A(1, 2) = 1e-3; }))
      << "A11 nonzero";
  EXPECT_FALSE(with([&](Matrix&, Matrix& A, DescriptorModel&) { A(0, n) *= 1.0 + 1e-15; }))
      << "A12 != E11 (one entry off by one ulp)";
  EXPECT_FALSE(with([&](Matrix&, Matrix& A, DescriptorModel&) { A(2, n) = 1e-3; }))
      << "A12 != E11 (an extra entry)";
  EXPECT_FALSE(with([&](Matrix&, Matrix&, DescriptorModel& m) { m.B(1, 0) = 1e-3; }))
      << "B1 nonzero";
  // E11 = A12 but not positive definite (indefinite, and singular): no q' = v.
  EXPECT_FALSE(with([&](Matrix& E, Matrix& A, DescriptorModel&) {
    E(0, 0) = -2.0;
    A(0, n) = -2.0;
  })) << "E11 indefinite";
  EXPECT_FALSE(with([&](Matrix& E, Matrix& A, DescriptorModel&) {
    E.topLeftCorner(n, n).setZero();
    A.topRightCorner(n, n).setZero();
  })) << "E11 = A12 = 0";
  // E11 = A12 unsymmetric (and nonsingular): the pattern asks for SPD E11.
  EXPECT_FALSE(with([&](Matrix& E, Matrix& A, DescriptorModel&) {
    E(0, 1) = 0.9;
    A(0, n + 1) = 0.9;
  })) << "E11 unsymmetric";

  // Odd N: the 6 x 6 model with one more state (a decoupled, stable first-order mode).
  DescriptorModel odd;
  Matrix E7 = Matrix::Identity(7, 7), A7 = -Matrix::Identity(7, 7);
  E7.topLeftCorner(6, 6) = Matrix(good.E);
  A7.topLeftCorner(6, 6) = Matrix(good.A);
  odd.E = sparse(E7);
  odd.A = sparse(A7);
  odd.B = Matrix::Zero(7, 2);
  odd.B.topRows(6) = good.B;
  odd.C = Matrix::Zero(2, 7);
  odd.C.leftCols(6) = good.C;
  EXPECT_FALSE(second_order_form(odd).has_value()) << "N odd";
}

TEST(SecondOrderForm, ExplicitlyStoredZerosAreNoCoupling) {
  DescriptorModel m = small_model();
  // Store zeros in E12 and A11 (a converter may write them): still the pattern.
  std::vector<Eigen::Triplet<double>> te, ta;
  for (Index j = 0; j < m.E.outerSize(); ++j)
    for (SparseMatrix::InnerIterator it(m.E, j); it; ++it)
      te.emplace_back(static_cast<int>(it.row()), static_cast<int>(it.col()), it.value());
  for (Index j = 0; j < m.A.outerSize(); ++j)
    for (SparseMatrix::InnerIterator it(m.A, j); it; ++it)
      ta.emplace_back(static_cast<int>(it.row()), static_cast<int>(it.col()), it.value());
  te.emplace_back(0, 4, 0.0);
  ta.emplace_back(1, 1, 0.0);
  m.E.setFromTriplets(te.begin(), te.end());
  m.A.setFromTriplets(ta.begin(), ta.end());
  ASSERT_GT(m.E.nonZeros(), small_model().E.nonZeros());
  EXPECT_TRUE(second_order_form(m).has_value());
}

TEST(SecondOrderForm, ShippedFirstOrderModels) {
  // build (the SLICOT building) is the first-order form of build_so: recognised, with the
  // slightly unsymmetric K and D of build_so (the krylov plugin keeps its first-order path).
  {
    const Model full = shared_model("build");
    const auto& fo = std::get<DescriptorModel>(full);
    const auto so = second_order_form(fo);
    ASSERT_TRUE(so.has_value());
    EXPECT_EQ(so->size(), 24);
    EXPECT_GT(relative_asymmetry(so->K), 1e-10);
    for (const double w : {0.1, 5.11143348344182, 100.0}) {
      const Complex s(0.0, w);
      const ComplexMatrix H = dense_h(fo, s);
      EXPECT_LT((dense_h(*so, s) - H).norm() / H.norm(), 1e-10) << "build omega = " << w;
    }
  }
  // Models without the structure: E SPD and A symmetric (rail), a dense A (beam), general ones.
  for (const char* name :
       {"rail_371", "cdplayer", "beam", "heat_cont", "pde", "random200", "fom"}) {
    const Model full = shared_model(name);
    const auto& fo = std::get<DescriptorModel>(full);
    EXPECT_FALSE(second_order_form(fo).has_value()) << name;
  }
}

// summarize() (model_io.hpp) reports the structure `ecmor info` prints: n of the second-order
// form, and whether its M, D, K are all symmetric (the condition krylov's structure: auto needs).
TEST(SecondOrderForm, SummaryReportsTheStructureAndItsSymmetry) {
  DescriptorModel fo = small_model();
  ModelSummary s = summarize(Model(fo));
  EXPECT_EQ(s.second_order_size, 3);
  EXPECT_TRUE(s.second_order_symmetric);
  fo.A.coeffRef(4, 0) += 0.5;  // -K(1, 0) only: K is no longer symmetric, the form stays
  s = summarize(Model(fo));
  EXPECT_EQ(s.second_order_size, 3);
  EXPECT_FALSE(s.second_order_symmetric);
  fo.A.coeffRef(0, 0) = 1.0;  // A11 != 0: no second-order form
  s = summarize(Model(fo));
  EXPECT_EQ(s.second_order_size, 0);
  EXPECT_FALSE(s.second_order_symmetric);
  // A second-order model is what it is: the fields describe descriptor models only.
  EXPECT_EQ(summarize(Model(*second_order_form(small_model()))).second_order_size, 0);
}

}  // namespace
}  // namespace ecmor
