// The full model's stability (stability.hpp), decided two ways: from dense eigenvalues (small
// models) and from the inertia of K and D (large second-order models). Each case has a known
// answer by construction: a spring-mass chain whose poles are known to lie left of, on, or right
// of the imaginary axis.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/small_models.hpp"
#include "ecmor/measures/stability.hpp"
#include "ecmor/model/model_io.hpp"

namespace ecmor {
namespace {

using test::spring_chain;

struct Case {
  const char* name;
  SecondOrderModel model;
  Stability expected;
  const char* reason;  ///< phrase of the structural route's reason
};

std::vector<Case> cases() {
  return {
      {"damped", spring_chain(30, 20.0, 50.0, 0.05, 1e-3), Stability::Asymptotic,
       "every mode is damped"},
      {"undamped", spring_chain(30, 20.0, 50.0, 0.0, 0.0), Stability::Marginal, "D = 0"},
      {"free_floating", spring_chain(30, 0.0, 50.0, 0.05, 1e-3), Stability::Marginal,
       "K is singular"},
      // D = beta K leaves the rigid-body mode undamped: a double pole at s = 0 (Jordan block),
      // whose second copy comes out near sqrt(eps), of either sign.
      {"free_floating_stiffness_damping", spring_chain(30, 0.0, 50.0, 0.0, 1e-3),
       Stability::Marginal, "K is singular"},
      {"negative_spring", spring_chain(30, 20.0, -40.0, 0.05, 1e-3), Stability::Unstable,
       "K is indefinite"},
  };
}

TEST(FullModelStability, DenseEigenvaluesClassifyEachChain) {
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    const StabilityReport r = dense_model_stability(Model(c.model));
    EXPECT_TRUE(r.dense);
    EXPECT_EQ(r.verdict, c.expected) << r.reason;
    EXPECT_NE(r.method.find("60 x 60"), std::string::npos) << r.method;
    if (c.expected == Stability::Asymptotic) {
      EXPECT_LT(r.max_real_pole, 0.0);
    }
    if (c.expected == Stability::Unstable) {
      EXPECT_GT(r.max_real_pole, 0.0);
    }
  }
}

TEST(FullModelStability, InertiaOfKAndDAgreesWithTheEigenvalues) {
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    // The structural test decides each chain, whether the dense check is allowed or not.
    for (const Index dense_states : {Index{0}, Index{1000}}) {
      const StabilityReport r = full_model_stability(Model(c.model), dense_states);
      EXPECT_FALSE(r.dense);
      EXPECT_EQ(r.verdict, c.expected) << r.reason;
      EXPECT_NE(r.reason.find(c.reason), std::string::npos) << r.reason;
      EXPECT_TRUE(std::isnan(r.max_real_pole));
    }
  }
}

// D only semidefinite (one dashpot at the free end): the structural test cannot decide, so the
// dense eigenvalues do when allowed.
TEST(FullModelStability, SemidefiniteDampingFallsBackToTheEigenvalues) {
  SecondOrderModel m = spring_chain(30, 20.0, 50.0, 0.0, 0.0);
  m.D.resize(30, 30);
  m.D.insert(29, 29) = 2.0;
  const StabilityReport structural = full_model_stability(Model(m), 0);
  EXPECT_EQ(structural.verdict, Stability::Unknown);
  EXPECT_NE(structural.reason.find("D is not positive definite"), std::string::npos);
  const StabilityReport r = full_model_stability(Model(m), 1000);
  EXPECT_TRUE(r.dense);
  // Every mode of a chain moves its end mass (M^-1/2 K M^-1/2 is an irreducible tridiagonal
  // matrix, whose eigenvectors have no zero end component), so the one dashpot damps them all.
  EXPECT_EQ(r.verdict, Stability::Asymptotic) << r.reason;
  EXPECT_LT(r.max_real_pole, 0.0);
}

TEST(FullModelStability, UnsymmetricDampingOrLargeDescriptorIsUnknown) {
  SecondOrderModel m = spring_chain(30, 20.0, 50.0, 0.05, 1e-3);
  m.D.coeffRef(0, 1) += 0.5;  // a gyroscopic-like unsymmetric term
  const StabilityReport r = full_model_stability(Model(m), 0);
  EXPECT_EQ(r.verdict, Stability::Unknown);
  EXPECT_NE(r.reason.find("not symmetric"), std::string::npos) << r.reason;
  // The same model is decided by its eigenvalues when the dense check is allowed.
  EXPECT_EQ(full_model_stability(Model(m), 1000).verdict, Stability::Asymptotic);

  DescriptorModel d;
  d.E = SparseMatrix(4, 4);
  d.E.setIdentity();
  d.A = -d.E;
  d.B = Matrix::Ones(4, 1);
  d.C = Matrix::Ones(1, 4);
  const StabilityReport u = full_model_stability(Model(d), 2);
  EXPECT_EQ(u.verdict, Stability::Unknown);
  EXPECT_NE(u.reason.find("above the dense limit"), std::string::npos) << u.reason;
  EXPECT_EQ(full_model_stability(Model(d), 4).verdict, Stability::Asymptotic);
}

// Poles spread over twenty decades are each judged on their own scale: none of -1, -1e10, -1e20
// is "on the axis" (a tolerance relative to the largest pole would put -1 there).
TEST(FullModelStability, PolesOverManyDecadesAreJudgedOnTheirOwnScale) {
  DescriptorModel d;
  d.E = SparseMatrix(3, 3);
  d.E.setIdentity();
  d.A = SparseMatrix(3, 3);
  d.A.insert(0, 0) = -1.0;
  d.A.insert(1, 1) = -1e10;
  d.A.insert(2, 2) = -1e20;
  d.B = Matrix::Ones(3, 1);
  d.C = Matrix::Ones(1, 3);
  const StabilityReport r = full_model_stability(Model(d), 100);
  EXPECT_EQ(r.verdict, Stability::Asymptotic) << r.reason;
  EXPECT_DOUBLE_EQ(r.max_real_pole, -1.0);
  // An undamped pair +-i w next to them is on the axis; a pole at +1e-3 is unstable.
  DescriptorModel osc;
  osc.E = SparseMatrix(4, 4);
  osc.E.setIdentity();
  osc.A = SparseMatrix(4, 4);
  osc.A.insert(0, 1) = 5.0;
  osc.A.insert(1, 0) = -5.0;
  osc.A.insert(2, 2) = -1e10;
  osc.A.insert(3, 3) = -1e20;
  osc.B = Matrix::Ones(4, 1);
  osc.C = Matrix::Ones(1, 4);
  EXPECT_EQ(full_model_stability(Model(osc), 100).verdict, Stability::Marginal);
  osc.A.coeffRef(0, 0) = 1e-3;
  osc.A.coeffRef(1, 1) = 1e-3;
  EXPECT_EQ(full_model_stability(Model(osc), 100).verdict, Stability::Unstable);
}

// The shared peec model: a singular E and a badly scaled pencil on which Eigen's QZ does not
// converge until the pencil is equilibrated; it has a real pole in the right half-plane (the
// models' README: eigenvalues with Re up to +1.7e12 by LAPACK).
TEST(FullModelStability, PeecIsUnstableAfterEquilibration) {
  const StabilityReport r = full_model_stability(load_model("models/peec"), 1000);
  EXPECT_EQ(r.verdict, Stability::Unstable) << r.reason;
  EXPECT_GT(r.max_real_pole, 1e9);
}

// mna1: finite poles from 5.7e4 to 4.5e20 (E singular), all real and negative: asymptotically
// stable, although the slowest are 1e-16 of the fastest.
TEST(FullModelStability, Mna1IsAsymptoticallyStable) {
  const StabilityReport r = full_model_stability(load_model("models/mna1"), 1000);
  EXPECT_EQ(r.verdict, Stability::Asymptotic) << r.reason;
}

}  // namespace
}  // namespace ecmor
