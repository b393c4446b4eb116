// spectrum_summary() (spectrum_summary.hpp), the modes `ecmor info --eigenfrequencies` lists:
// against dense eigen-decompositions of small pencils (an independent reference), the rigid-body
// mode of a free chain, the count limited by N, and the errors by name.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "common/builders.hpp"
#include "common/small_models.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/linalg/spectrum_summary.hpp"

namespace ecmor {
namespace {

using test::message_of;

SpectrumSummary summary_of(const Model& model, Index count) {
  auto solver = make_shifted_solver(model);
  return spectrum_summary(model, *solver, count);
}

// Ascending undamped eigenfrequencies sqrt(lambda) / 2pi of (K, M), dense.
std::vector<double> dense_frequencies(const SecondOrderModel& so) {
  const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> es(Matrix(so.K), Matrix(so.M));
  std::vector<double> f;
  for (Index i = 0; i < es.eigenvalues().size(); ++i)
    f.push_back(std::sqrt(std::max(es.eigenvalues()(i), 0.0)) / kTwoPi);
  return f;
}

// E = blkdiag(I, M), A = [0 I; -K -D], B = [0; B], C = [C 0]: the eigenvalues of (A, E) are those
// of the quadratic pencil s^2 M + s D + K.
DescriptorModel first_order(const SecondOrderModel& so) {
  const Index n = so.size();
  Matrix E = Matrix::Zero(2 * n, 2 * n), A = Matrix::Zero(2 * n, 2 * n);
  E.topLeftCorner(n, n).setIdentity();
  E.bottomRightCorner(n, n) = Matrix(so.M);
  A.topRightCorner(n, n).setIdentity();
  A.bottomLeftCorner(n, n) = -Matrix(so.K);
  A.bottomRightCorner(n, n) = -Matrix(so.D);
  DescriptorModel d;
  d.E = test::sparse(E);
  d.A = test::sparse(A);
  d.B = Matrix::Zero(2 * n, so.B.cols());
  d.B.bottomRows(n) = so.B;
  d.C = Matrix::Zero(so.C.rows(), 2 * n);
  d.C.leftCols(n) = so.C;
  return d;
}

TEST(SpectrumSummary, AnchoredChainHasTheDenseEigenfrequenciesAndNoRigidMode) {
  const SecondOrderModel so = test::spring_chain(12, 20.0, 50.0, 0.05, 1e-3);
  const SpectrumSummary s = summary_of(Model(so), 5);
  EXPECT_TRUE(s.undamped);
  EXPECT_NE(s.rigid_body.find("no rigid-body mode"), std::string::npos) << s.rigid_body;
  const std::vector<double> ref = dense_frequencies(so);
  ASSERT_EQ(s.modes.size(), 5u);
  for (std::size_t i = 0; i < s.modes.size(); ++i) {
    // Well separated eigenvalues of a 12 x 12 pencil: ARPACK and the dense solver agree to
    // rounding, far below 1e-8 relative.
    EXPECT_NEAR(s.modes[i].frequency_hz, ref[i], 1e-8 * ref[i]) << i;
    EXPECT_FALSE(s.modes[i].rigid) << i;
    EXPECT_FALSE(s.modes[i].damping_ratio.has_value()) << i;
  }
}

TEST(SpectrumSummary, FreeChainListsItsRigidBodyModeFirst) {
  const SecondOrderModel so = test::spring_chain(12, 0.0, 50.0, 0.05, 1e-3);  // K singular
  const SpectrumSummary s = summary_of(Model(so), 4);
  EXPECT_NE(s.rigid_body.find("1 rigid-body mode"), std::string::npos) << s.rigid_body;
  const std::vector<double> ref = dense_frequencies(so);
  ASSERT_EQ(s.modes.size(), 4u);
  EXPECT_TRUE(s.modes[0].rigid);
  EXPECT_LT(s.modes[0].frequency_hz, 1e-6 * ref[1]);
  for (std::size_t i = 1; i < s.modes.size(); ++i) {
    EXPECT_FALSE(s.modes[i].rigid) << i;
    EXPECT_NEAR(s.modes[i].frequency_hz, ref[i], 1e-8 * ref[i]) << i;
  }
}

TEST(SpectrumSummary, CountIsLimitedByTheModelSize) {
  const SecondOrderModel so = test::spring_chain(8, 20.0, 50.0, 0.05, 1e-3);
  const SpectrumSummary s = summary_of(Model(so), 100);
  const std::vector<double> ref = dense_frequencies(so);
  ASSERT_EQ(s.modes.size(), 6u);  // N - 2
  for (std::size_t i = 0; i < s.modes.size(); ++i)
    EXPECT_NEAR(s.modes[i].frequency_hz, ref[i], 1e-8 * ref[i]) << i;
}

TEST(SpectrumSummary, DescriptorModelGivesTheEigenvaluesNearestZeroWithDamping) {
  const SecondOrderModel so = test::spring_chain(10, 20.0, 50.0, 0.05, 1e-3);
  const DescriptorModel d = first_order(so);
  const SpectrumSummary s = summary_of(Model(d), 4);
  EXPECT_FALSE(s.undamped);
  EXPECT_TRUE(s.rigid_body.empty());
  // Reference: the eigenvalues of E^-1 A (E is nonsingular), by distance to 0.
  const Matrix EinvA = Matrix(d.E).partialPivLu().solve(Matrix(d.A));
  const Eigen::ComplexEigenSolver<ComplexMatrix> es(EinvA.cast<Complex>());
  std::vector<Complex> ref(es.eigenvalues().data(),
                           es.eigenvalues().data() + es.eigenvalues().size());
  std::sort(ref.begin(), ref.end(),
            [](const Complex& a, const Complex& b) { return std::abs(a) < std::abs(b); });
  // Light damping: every mode is a conjugate pair, so ARPACK returns 4 (or a pair more).
  ASSERT_GE(s.modes.size(), 4u);
  ASSERT_LE(s.modes.size(), 5u);
  for (std::size_t i = 0; i < s.modes.size(); ++i) {
    const SpectrumMode& m = s.modes[i];
    ASSERT_TRUE(m.damping_ratio.has_value()) << i;
    EXPECT_FALSE(m.rigid) << i;
    // The pairs nearest 0, in order: mode i is eigenvalue i of the sorted reference (the two
    // members of a pair have the same modulus and damping ratio).
    const Complex l = ref[i];
    EXPECT_NEAR(m.frequency_hz, std::abs(l) / kTwoPi, 1e-8 * std::abs(l) / kTwoPi) << i;
    EXPECT_NEAR(*m.damping_ratio, -l.real() / std::abs(l), 1e-8) << i;
    EXPECT_GT(*m.damping_ratio, 0.0) << i;  // Rayleigh damping: every mode decays
  }
}

TEST(SpectrumSummary, ErrorsNameTheProblem) {
  SecondOrderModel so = test::spring_chain(8, 20.0, 50.0, 0.05, 1e-3);
  const std::string count = message_of<ConfigError>([&] { (void)summary_of(Model(so), 0); });
  EXPECT_NE(count.find("count = 0: must be >= 1"), std::string::npos) << count;
  so.K.coeffRef(0, 1) += 1e-3;  // unsymmetric K: the undamped eigenproblem is not symmetric
  const std::string asym = message_of<InputError>([&] { (void)summary_of(Model(so), 3); });
  EXPECT_NE(asym.find("K and M must be symmetric"), std::string::npos) << asym;
  EXPECT_NE(asym.find("relative asymmetry of K"), std::string::npos) << asym;
}

}  // namespace
}  // namespace ecmor
