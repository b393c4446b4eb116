// Rigid-body modes by the null space of K (rigid_body.hpp) and the stability rule relative to the
// full model (reduced_model_stability, stability.hpp).
//
// References are independent of the code under test: the rigid-body motions of a 3-D solid built
// from its node coordinates (3 translations, 3 rotations u = w x r), the constant vector of a free
// chain, dense eigen-decompositions of small pencils, and Sylvester's law (a Cholesky
// factorisation that succeeds proves K positive definite). The long anchored chain is the case a
// relative eigenvalue threshold gets wrong: the test first shows that its lowest eigenvalue lies
// below the old threshold (1e-8 of max K_ii / M_ii), then that no rigid-body mode is reported.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <cmath>
#include <functional>
#include <string>
#include <tuple>
#include <vector>

#include "../../bench/solid.hpp"
#include "../../bench/triple_chain.hpp"
#include "common/small_models.hpp"
#include "ecmor/linalg/eigensolver.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/measures/stability.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace ecmor {
namespace {

bench::SolidOptions free_solid_options(Index nx, Index ny, Index nz) {
  bench::SolidOptions o;
  o.nx = nx;
  o.ny = ny;
  o.nz = nz;
  o.clamped = false;
  return o;
}

// The six rigid-body motions of the free solid, from the node coordinates of solid.hpp's
// numbering (node (i, j, k) at (i lx/nx, j ly/ny, k lz/nz), dof 3 n + c).
Matrix geometric_rigid_modes(const bench::SolidOptions& o) {
  const Index nodes = (o.nx + 1) * (o.ny + 1) * (o.nz + 1);
  Matrix R = Matrix::Zero(3 * nodes, 6);
  for (Index k = 0; k <= o.nz; ++k) {
    for (Index j = 0; j <= o.ny; ++j) {
      for (Index i = 0; i <= o.nx; ++i) {
        const Index n = i + (o.nx + 1) * (j + (o.ny + 1) * k);
        const double x = o.lx * static_cast<double>(i) / static_cast<double>(o.nx);
        const double y = o.ly * static_cast<double>(j) / static_cast<double>(o.ny);
        const double z = o.lz * static_cast<double>(k) / static_cast<double>(o.nz);
        for (Index c = 0; c < 3; ++c) R(3 * n + c, c) = 1.0;  // translations
        R(3 * n + 1, 3) = -z, R(3 * n + 2, 3) = y;            // rotation about x
        R(3 * n + 0, 4) = z, R(3 * n + 2, 4) = -x;            // about y
        R(3 * n + 0, 5) = -y, R(3 * n + 1, 5) = x;            // about z
      }
    }
  }
  return R;
}

// Largest sine of the principal angles between span(A) and span(B) (same column count).
double subspace_distance(const Matrix& A, const Matrix& B) {
  const Matrix Qa =
      Eigen::HouseholderQR<Matrix>(A).householderQ() * Matrix::Identity(A.rows(), A.cols());
  const Matrix Qb =
      Eigen::HouseholderQR<Matrix>(B).householderQ() * Matrix::Identity(B.rows(), B.cols());
  const Eigen::JacobiSVD<Matrix> svd(Qa.transpose() * Qb);
  const double c = svd.singularValues().minCoeff();
  return std::sqrt(std::max(0.0, 1.0 - c * c));
}

double m_orthonormality_loss(const Matrix& V, const SparseMatrix& M) {
  return (V.transpose() * (M * V) - Matrix::Identity(V.cols(), V.cols())).cwiseAbs().maxCoeff();
}

TEST(RigidBodyModes, FreeSolidHasExactlyTheSixRigidBodyMotions) {
  using Mesh = std::tuple<Index, Index, Index>;
  for (const auto& [nx, ny, nz] : {Mesh{6, 2, 1}, Mesh{20, 3, 2}}) {
    const bench::SolidOptions o = free_solid_options(nx, ny, nz);
    const Model model = bench::solid(o);
    const auto& so = std::get<SecondOrderModel>(model);
    const RigidBodyModes r = rigid_body_modes(model);
    SCOPED_TRACE(r.describe());
    EXPECT_TRUE(r.decided);
    EXPECT_FALSE(r.positive_definite);
    EXPECT_FALSE(r.indefinite);
    ASSERT_EQ(r.count, 6);
    ASSERT_EQ(r.basis.cols(), 6);
    // The span is that of the geometric rigid-body motions, which K annihilates.
    const Matrix R = geometric_rigid_modes(o);
    EXPECT_LE((so.K * R).norm(), 1e-12 * so.K.norm() * R.norm());
    EXPECT_LE(subspace_distance(r.basis, R), 1e-6);
    EXPECT_LE(m_orthonormality_loss(r.basis, so.M), 1e-10);
    // Default Rayleigh damping has alpha > 0: every rigid-body mode is damped (D r = alpha M r),
    // one pole at 0 each.
    EXPECT_EQ(r.zero_poles, 6);
    // The bound lies in the gap: above every rigid eigenvalue, below the first elastic one.
    EXPECT_GE(r.zero_bound, r.rigid_eigenvalues.cwiseAbs().maxCoeff());
    EXPECT_LT(r.zero_bound, r.first_elastic);
  }
}

TEST(RigidBodyModes, UndampedRigidBodyModesGiveTwoPolesAtZeroEach) {
  bench::SolidOptions o = free_solid_options(6, 2, 1);
  o.alpha = 0.0;  // D = beta K: D r = 0
  const RigidBodyModes r = rigid_body_modes(Model(bench::solid(o)));
  ASSERT_EQ(r.count, 6) << r.describe();
  EXPECT_EQ(r.zero_poles, 12);
}

TEST(RigidBodyModes, ClampedSolidIsPositiveDefiniteByCholesky) {
  bench::SolidOptions o = free_solid_options(6, 2, 1);
  o.clamped = true;
  const RigidBodyModes r = rigid_body_modes(Model(bench::solid(o)));
  EXPECT_TRUE(r.decided);
  EXPECT_TRUE(r.positive_definite) << r.describe();
  EXPECT_EQ(r.count, 0);
  EXPECT_EQ(r.basis.cols(), 0);
  EXPECT_NE(r.describe().find("no rigid-body mode"), std::string::npos) << r.describe();
}

// The triple chain with N = 1e5 (ecmor_bench_models triplechain 100000): anchored, K positive
// definite, but its lowest eigenvalue lies below 1e-8 max K_ii / M_ii, the threshold `ecmor info`
// and the modal reducer once used.
TEST(RigidBodyModes, LongAnchoredChainHasNoneAlthoughItsLowestModeIsTiny) {
  const Model model = bench::triple_chain(33333, 0.002, 0.002, 5.0);
  const auto& so = std::get<SecondOrderModel>(model);
  double scale = 0.0;
  for (Index i = 0; i < so.K.rows(); ++i)
    scale = std::max(scale, so.K.coeff(i, i) / so.M.coeff(i, i));
  auto solver = make_shifted_solver(model);
  const Complex w[3] = {1.0, 0.0, 0.0};
  EigenOptions eo;
  eo.nev = 1;
  const SymmetricEigenResult lowest =
      symmetric_shift_invert(*solver->factorize_combination(w), so.M, 0.0, eo);
  ASSERT_EQ(lowest.eigenvalues.size(), 1);
  EXPECT_LT(lowest.eigenvalues(0), 1e-8 * scale) << "not the hard case any more";

  const RigidBodyModes r = rigid_body_modes(model, *solver);
  EXPECT_TRUE(r.decided);
  EXPECT_TRUE(r.positive_definite) << r.describe();
  EXPECT_EQ(r.count, 0) << r.describe();
}

TEST(RigidBodyModes, FreeChainHasOneFreeTranslation) {
  // Short and long: the long chain's first elastic eigenvalue is about 5e-10 of the scale.
  for (Index n : {Index{200}, Index{100000}}) {
    const SecondOrderModel so = test::spring_chain(n, 0.0, 50.0, 0.05, 1e-3);
    const RigidBodyModes r = rigid_body_modes(Model(so));
    SCOPED_TRACE(r.describe());
    ASSERT_EQ(r.count, 1) << "n = " << n;
    EXPECT_LE(subspace_distance(r.basis, Matrix::Ones(n, 1)), 1e-6);
    EXPECT_LE(m_orthonormality_loss(r.basis, so.M), 1e-10);
  }
}

TEST(RigidBodyModes, NegativeStiffnessIsIndefiniteNotRigid) {
  const RigidBodyModes r = rigid_body_modes(Model(test::spring_chain(30, 20.0, -40.0, 0.05, 1e-3)));
  EXPECT_TRUE(r.decided);
  EXPECT_TRUE(r.indefinite) << r.describe();
  EXPECT_EQ(r.count, 0);
  EXPECT_NE(r.describe().find("indefinite"), std::string::npos) << r.describe();
}

TEST(RigidBodyModes, UnsymmetricStiffnessIsNotDecided) {
  SecondOrderModel so = test::spring_chain(30, 0.0, 50.0, 0.05, 1e-3);
  so.K.coeffRef(0, 1) += 5.0;  // a follower force: K no longer symmetric
  const RigidBodyModes r = rigid_body_modes(Model(so));
  EXPECT_FALSE(r.decided);
  EXPECT_EQ(r.count, 0);
  EXPECT_NE(r.method.find("not symmetric"), std::string::npos) << r.method;
}

// ---- the stability rule -----------------------------------------------------------------------

// The free solid 6 x 2 x 1 (N = 126) and its dense modal decomposition (an independent reference
// for the reduced models below: Galerkin projections on chosen eigenvectors).
struct FreeSolid {
  bench::SolidOptions options = free_solid_options(6, 2, 1);
  SecondOrderModel so = bench::solid(options);
  Model model{so};
  RigidBodyModes rigid = rigid_body_modes(model);
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> modes{Matrix(so.K), Matrix(so.M)};

  // Galerkin projection on `rigid` of the rigid-body modes and the first `elastic` elastic ones.
  ReducedSecondOrderModel reduced(Index rigid_kept, Index elastic) const {
    Matrix V(so.K.rows(), rigid_kept + elastic);
    V.leftCols(rigid_kept) = modes.eigenvectors().leftCols(rigid_kept);
    V.rightCols(elastic) = modes.eigenvectors().middleCols(6, elastic);
    return std::get<ReducedSecondOrderModel>(project(model, V, V));
  }
};

TEST(ReducedStability, KeptRigidBodyModesAreStableLikeTheFullModel) {
  const FreeSolid s;
  ASSERT_EQ(s.rigid.count, 6) << s.rigid.describe();
  const ReducedStability st = reduced_model_stability(s.reduced(6, 10), s.rigid);
  EXPECT_EQ(st.verdict, ReducedVerdict::RigidLikeFull) << st.reason;
  EXPECT_TRUE(st.accepted());
  EXPECT_EQ(st.rigid_modes, 6);
  EXPECT_EQ(st.full_rigid_modes, 6);
  EXPECT_EQ(st.label, "stable with 6 rigid-body modes like the full model");
  // Independently: the reduced poles of least modulus, 6 of them (alpha > 0: one per mode), lie
  // far below the first elastic frequency, the next far above.
  ComplexVector p = poles(ReducedModel(s.reduced(6, 10)));
  std::vector<double> mod;
  for (Index i = 0; i < p.size(); ++i) mod.push_back(std::abs(p(i)));
  std::sort(mod.begin(), mod.end());
  const double omega_1 = std::sqrt(s.modes.eigenvalues()(6));
  EXPECT_LT(mod[5], 1e-3 * omega_1);
  EXPECT_GT(mod[6], 1e-3 * omega_1);
}

TEST(ReducedStability, ElasticModesOnlyAreAsymptoticallyStable) {
  const FreeSolid s;
  const ReducedStability st = reduced_model_stability(s.reduced(0, 10), s.rigid);
  EXPECT_EQ(st.verdict, ReducedVerdict::Asymptotic) << st.reason;
  EXPECT_EQ(st.label, "asymptotically stable");
}

// Fewer rigid-body modes than the full model: named (RigidSubset), but not accepted, and never
// called stable (issue 28: "as stable as the full model" needs the same count).
TEST(ReducedStability, SomeRigidBodyModesAreASubsetAndNotAccepted) {
  const FreeSolid s;
  const ReducedStability st = reduced_model_stability(s.reduced(3, 10), s.rigid);
  EXPECT_EQ(st.verdict, ReducedVerdict::RigidSubset) << st.reason;
  EXPECT_FALSE(st.accepted());
  EXPECT_EQ(st.rigid_modes, 3);
  EXPECT_EQ(st.full_rigid_modes, 6);
  EXPECT_EQ(st.label, "not as stable as the full model: 3 of its 6 rigid-body modes");
  EXPECT_EQ(st.label.find("stable with"), std::string::npos) << st.label;
  EXPECT_NE(st.reason.find("where the full model has 6"), std::string::npos) << st.reason;
}

TEST(ReducedStability, AnExtraPoleAtZeroIsRefused) {
  const FreeSolid s;
  ReducedSecondOrderModel r = s.reduced(6, 10);
  // Modal coordinates: Kr is diagonal. Removing the stiffness of the first elastic mode (and its
  // stiffness-proportional damping) makes it a seventh rigid-body mode the full model lacks.
  r.K.row(6).setZero();
  r.K.col(6).setZero();
  const ReducedStability st = reduced_model_stability(ReducedModel(r), s.rigid);
  EXPECT_EQ(st.verdict, ReducedVerdict::Unstable);
  EXPECT_FALSE(st.accepted());
  EXPECT_EQ(st.rigid_modes, 7);
  EXPECT_NE(st.reason.find("an extra pole at s = 0"), std::string::npos) << st.reason;
}

TEST(ReducedStability, AnUndampedOrGrowingElasticPoleIsRefused) {
  const FreeSolid s;
  ReducedSecondOrderModel r = s.reduced(6, 10);
  r.D.row(8).setZero();
  r.D.col(8).setZero();
  r.D(8, 8) = -1e-3 * std::sqrt(r.K(8, 8));  // negative damping: a pole with Re > 0
  const ReducedStability st = reduced_model_stability(ReducedModel(r), s.rigid);
  EXPECT_EQ(st.verdict, ReducedVerdict::Unstable);
  EXPECT_EQ(st.right_poles, 2);  // the conjugate pair
  EXPECT_NE(st.reason.find("with Re >= 0 away from s = 0"), std::string::npos) << st.reason;
}

TEST(ReducedStability, APoleAtZeroOfAModelWithoutRigidBodyModesIsRefused) {
  FreeSolid s;
  s.options.clamped = true;
  const SecondOrderModel clamped = bench::solid(s.options);
  const RigidBodyModes none = rigid_body_modes(Model(clamped));
  ASSERT_EQ(none.count, 0);
  // The free solid's rigid-body modes judged against the clamped solid: not allowed.
  const ReducedStability st = reduced_model_stability(s.reduced(6, 4), none);
  EXPECT_EQ(st.verdict, ReducedVerdict::Unstable) << st.reason;
  EXPECT_EQ(st.zero_radius, 0.0);
}

}  // namespace
}  // namespace ecmor
