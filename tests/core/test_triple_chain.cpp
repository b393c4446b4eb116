// Tests of the triple chain generator (bench/triple_chain.hpp): exact reproduction of the shared
// M-M.E.S.S. instances, an independent spring-by-spring dense assembly on small cases, physical
// properties at large N, and the bad-parameter rules.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <ostream>
#include <string>
#include <variant>

#include "../../bench/triple_chain.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/model_io.hpp"

namespace {

using ecmor::Index;
using ecmor::Matrix;
using ecmor::SecondOrderModel;
using ecmor::SparseMatrix;
using ecmor::bench::triple_chain;

double relative_difference(const SparseMatrix& A, const SparseMatrix& reference) {
  return SparseMatrix(A - reference).norm() / reference.norm();
}

struct SharedInstance {
  const char* name;
  Index n1;
  double alpha, beta, v;
};

void PrintTo(const SharedInstance& p, std::ostream* os) {
  *os << p.name << " (n1=" << p.n1 << ", alpha=" << p.alpha << ", beta=" << p.beta << ", v=" << p.v
      << ")";
}

class TripleChainShared : public ::testing::TestWithParam<SharedInstance> {};

// The generator must reproduce the published instances: this settles the index conventions
// (which masses carry the dampers, where m0 sits). The files hold the values written by
// M-M.E.S.S. in double precision, so the only admissible difference is one rounding of the
// alpha M + beta K + v P sum: 1e-15 relative in the Frobenius norm.
TEST_P(TripleChainShared, ReproducesTheModelFiles) {
  const SharedInstance& p = GetParam();
  const ecmor::Model loaded = ecmor::load_model(std::string("models/") + p.name);
  const auto& file = std::get<SecondOrderModel>(loaded);
  const SecondOrderModel gen = triple_chain(p.n1, p.alpha, p.beta, p.v);

  ASSERT_EQ(gen.size(), 3 * p.n1 + 1);
  ASSERT_EQ(gen.size(), file.size());
  EXPECT_LE(relative_difference(gen.M, file.M), 1e-15);
  EXPECT_LE(relative_difference(gen.K, file.K), 1e-15);
  EXPECT_LE(relative_difference(gen.D, file.D), 1e-15);
  // Same sparsity: the files store the full symmetric pattern without explicit zeros.
  EXPECT_EQ(gen.M.nonZeros(), file.M.nonZeros());
  EXPECT_EQ(gen.K.nonZeros(), file.K.nonZeros());
  EXPECT_EQ(gen.D.nonZeros(), file.D.nonZeros());

  ASSERT_EQ(gen.B.rows(), file.B.rows());
  ASSERT_EQ(gen.B.cols(), 1);
  ASSERT_EQ(gen.C.rows(), 1);
  ASSERT_EQ(gen.C.cols(), file.C.cols());
  EXPECT_EQ((gen.B - file.B).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((gen.C - file.C).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_TRUE(gen.B.isOnes(0.0));
  EXPECT_EQ(gen.Cv.size(), 0);
}

INSTANTIATE_TEST_SUITE_P(
    Models, TripleChainShared,
    ::testing::Values(SharedInstance{"triplechain_cmess_n301", 100, 2.0, 5.0, 5.0},
                      SharedInstance{"triplechain_saak09_n451", 150, 0.01, 0.01, 5.0},
                      SharedInstance{"triplechain_mess_n1501", 500, 0.002, 0.002, 5.0}),
    [](const ::testing::TestParamInfo<SharedInstance>& param_info) {
      return std::string(param_info.param.name);
    });

// Independent reference: the dense matrices assembled spring by spring from the physical
// description (each spring k between masses i and j adds k (e_i - e_j)(e_i - e_j)', a grounded
// spring adds k e_i e_i'), not entry by entry as the generator does.
struct DenseChain {
  Matrix M, D, K;
};

DenseChain dense_reference(Index n1, double alpha, double beta, double v) {
  const Index N = 3 * n1 + 1;
  const Index m0 = N - 1;
  const double mass[3] = {1.0, 2.0, 3.0};
  const double spring[3] = {10.0, 20.0, 1.0};
  DenseChain r;
  r.M = Matrix::Zero(N, N);
  r.K = Matrix::Zero(N, N);
  auto spring_between = [&](Index i, Index j, double k) {
    r.K(i, i) += k;
    r.K(j, j) += k;
    r.K(i, j) -= k;
    r.K(j, i) -= k;
  };
  for (Index c = 0; c < 3; ++c) {
    const Index first = c * n1;
    r.K(first, first) += spring[c];  // first mass to the ground
    for (Index i = first; i < first + n1; ++i) r.M(i, i) = mass[c];
    for (Index i = first; i + 1 < first + n1; ++i) spring_between(i, i + 1, spring[c]);
    spring_between(first + n1 - 1, m0, spring[c]);  // last mass to m0
  }
  r.M(m0, m0) = 10.0;
  r.K(m0, m0) += 50.0;  // m0 to the ground
  r.D = alpha * r.M + beta * r.K;
  r.D(0, 0) += v;            // e_1
  r.D(n1 - 1, n1 - 1) += v;  // e_n1
  r.D(2 * n1, 2 * n1) += v;  // e_(2n1+1)
  return r;
}

TEST(TripleChain, MatchesSpringBySpringAssemblyOnSmallChains) {
  // n1 = 1 makes e_1 = e_n1 (that mass carries 2 v); n1 = 2 puts the dampers on adjacent masses.
  for (Index n1 : {1, 2, 3, 7}) {
    SCOPED_TRACE("n1 = " + std::to_string(n1));
    const double alpha = 0.3, beta = 0.07, v = 1.5;
    const SecondOrderModel gen = triple_chain(n1, alpha, beta, v);
    const DenseChain ref = dense_reference(n1, alpha, beta, v);
    // Entries are small integers times alpha, beta, v: a few roundings at most.
    EXPECT_LE((Matrix(gen.M) - ref.M).norm(), 1e-15 * ref.M.norm());
    EXPECT_LE((Matrix(gen.K) - ref.K).norm(), 1e-15 * ref.K.norm());
    EXPECT_LE((Matrix(gen.D) - ref.D).norm(), 1e-15 * ref.D.norm());
  }
}

TEST(TripleChain, DampersAtFirstAndLastOfChainOneAndFirstOfChainThree) {
  const Index n1 = 10;
  const double v = 4.0;
  const SecondOrderModel gen = triple_chain(n1, 0.0, 0.0, v);
  // With alpha = beta = 0 only the grounded dampers remain: D = v P exactly.
  Matrix expected = Matrix::Zero(gen.size(), gen.size());
  expected(0, 0) = v;
  expected(n1 - 1, n1 - 1) = v;
  expected(2 * n1, 2 * n1) = v;
  EXPECT_EQ((Matrix(gen.D) - expected).cwiseAbs().maxCoeff(), 0.0);
}

// Large N (the bench's 1e6): sizes and nnz are O(N) as promised, and the physics holds: K 1 is
// the force of the grounded springs only (k_c on each chain's first mass, k0 on m0), M 1 the
// masses, and all three matrices are symmetric.
TEST(TripleChain, MillionDofModelHasLinearSizeAndPhysicalRowSums) {
  const Index n1 = 333333;
  const double alpha = 0.002, beta = 0.002, v = 5.0;
  const SecondOrderModel gen = triple_chain(n1, alpha, beta, v);
  const Index N = 3 * n1 + 1;
  ASSERT_EQ(N, 1000000);
  ASSERT_EQ(gen.size(), N);
  EXPECT_EQ(gen.M.nonZeros(), N);
  EXPECT_EQ(gen.K.nonZeros(), 9 * n1 + 1);
  EXPECT_EQ(gen.D.nonZeros(), 9 * n1 + 1);

  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(N);
  Eigen::VectorXd k_expected = Eigen::VectorXd::Zero(N);
  k_expected(0) = 10.0;
  k_expected(n1) = 20.0;
  k_expected(2 * n1) = 1.0;
  k_expected(N - 1) = 50.0;
  // Row sums of integers: exact.
  EXPECT_EQ((gen.K * ones - k_expected).cwiseAbs().maxCoeff(), 0.0);

  Eigen::VectorXd m_expected(N);
  m_expected.segment(0, n1).setConstant(1.0);
  m_expected.segment(n1, n1).setConstant(2.0);
  m_expected.segment(2 * n1, n1).setConstant(3.0);
  m_expected(N - 1) = 10.0;
  EXPECT_EQ((gen.M * ones - m_expected).cwiseAbs().maxCoeff(), 0.0);

  // D 1 = alpha M 1 + beta K 1 + v (e_1 + e_n1 + e_(2n1+1)): a few roundings per row.
  Eigen::VectorXd d_expected = alpha * m_expected + beta * k_expected;
  d_expected(0) += v;
  d_expected(n1 - 1) += v;
  d_expected(2 * n1) += v;
  EXPECT_LE((gen.D * ones - d_expected).cwiseAbs().maxCoeff(), 1e-14);

  for (const SparseMatrix* A : {&gen.M, &gen.K, &gen.D}) {
    EXPECT_EQ(SparseMatrix(*A - SparseMatrix(A->transpose())).norm(), 0.0);
  }
}

void expect_config_error(Index n1, double alpha, double beta, double v, const std::string& name,
                         const std::string& value, const std::string& rule) {
  try {
    (void)triple_chain(n1, alpha, beta, v);
    ADD_FAILURE() << "no error for " << name << " = " << value;
  } catch (const ecmor::ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("triple_chain"), std::string::npos) << what;
    EXPECT_NE(what.find(name + " = " + value), std::string::npos) << what;
    EXPECT_NE(what.find(rule), std::string::npos) << what;
  }
}

TEST(TripleChain, RejectsBadParametersNamingThem) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  constexpr double inf = std::numeric_limits<double>::infinity();
  expect_config_error(0, 1, 1, 1, "n1", "0", "must be in [1, ");
  expect_config_error(-4, 1, 1, 1, "n1", "-4", "must be in [1, ");
  expect_config_error(ecmor::bench::kTripleChainMaxN1 + 1, 1, 1, 1, "n1",
                      std::to_string(ecmor::bench::kTripleChainMaxN1 + 1), "32-bit");
  expect_config_error(10, nan, 1, 1, "alpha", "nan", "must be finite");
  expect_config_error(10, 1, inf, 1, "beta", "inf", "must be finite");
  expect_config_error(10, 1, 1, -inf, "v", "-inf", "must be finite");
  expect_config_error(10, -0.5, 1, 1, "alpha", "-0.5", "must be >= 0");
  expect_config_error(10, 1, -2, 1, "beta", "-2", "must be >= 0");
  expect_config_error(10, 1, 1, -5, "v", "-5", "must be >= 0");
}

TEST(TripleChain, LargestAdmissibleN1FitsThe32BitIndices) {
  // The bound itself is checked arithmetically (building it would need ~20 GB).
  const long long n1 = ecmor::bench::kTripleChainMaxN1;
  EXPECT_LE(9 * n1 + 1, static_cast<long long>(std::numeric_limits<int>::max()));
  EXPECT_GT(9 * (n1 + 1) + 1, static_cast<long long>(std::numeric_limits<int>::max()));
}

}  // namespace
