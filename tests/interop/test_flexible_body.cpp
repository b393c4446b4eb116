// Tests of the mass invariants of the reduced elastic body (flexible_body.hpp) against analytic
// values derived here, independently of the code: a homogeneous box [o, o + l] of density rho has
//   m = rho lx ly lz,  c = o + l / 2,
//   J (about the frame origin) = J_c + m (|c|^2 I - c c'),  J_c = m / 12 diag(ly^2 + lz^2,
//   lx^2 + lz^2, lx^2 + ly^2)                                  (parallel-axis theorem).
// The models are the bench solid (bench/solid.hpp): affine 8-node hexahedra with the consistent
// mass integrated exactly (2 x 2 x 2 Gauss points on a polynomial of degree <= 2 per coordinate
// with a constant Jacobian). The fields 1, x, y, z lie in the element space (isoparametric), so
// int x_a x_b dm = X_a' M X_b is exact: m, c and J agree with the continuum up to rounding. The
// tolerance 1e-12 (relative to the largest entry) covers the rounding of sums of a few thousand
// terms of one sign; a lumped mass would miss J by O(h^2) and fail it.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "../../bench/solid.hpp"
#include "../../bench/solid_geometry.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/interop/flexible_body.hpp"
#include "ecmor/linalg/rigid_body.hpp"

namespace {

using ecmor::BodyInvariants;
using ecmor::BodyModel;
using ecmor::Index;
using ecmor::Matrix;
using ecmor::Vector;
using ecmor::bench::SolidOptions;

constexpr double kRounding = 1e-12;

struct Box {
  double m;
  Eigen::Vector3d c;
  Eigen::Matrix3d J;  // about the origin of the coordinates
};

Box analytic(const SolidOptions& o, const Eigen::Vector3d& offset) {
  Box b;
  b.m = o.rho * o.lx * o.ly * o.lz;
  b.c = offset + 0.5 * Eigen::Vector3d(o.lx, o.ly, o.lz);
  Eigen::Matrix3d Jc = Eigen::Matrix3d::Zero();
  Jc(0, 0) = b.m * (o.ly * o.ly + o.lz * o.lz) / 12.0;
  Jc(1, 1) = b.m * (o.lx * o.lx + o.lz * o.lz) / 12.0;
  Jc(2, 2) = b.m * (o.lx * o.lx + o.ly * o.ly) / 12.0;
  b.J = Jc + b.m * (b.c.squaredNorm() * Eigen::Matrix3d::Identity() - b.c * b.c.transpose());
  return b;
}

Eigen::Matrix3d tilde(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v(2), v(1), v(2), 0, -v(0), -v(1), v(0), 0;
  return s;
}

// A body of the solid, its geometry shifted by `offset` (M does not depend on the position).
BodyModel body_of(const SolidOptions& o, const Eigen::Vector3d& offset, const Matrix& V) {
  const ecmor::SecondOrderModel model = ecmor::bench::solid(o);
  BodyModel b;
  b.geometry = ecmor::bench::solid_geometry(o);
  for (ecmor::FeNode& p : b.geometry.nodes) {
    p.x += offset(0);
    p.y += offset(1);
    p.z += offset(2);
  }
  b.M = model.M;
  b.D = model.D;
  b.K = model.K;
  b.V = V;
  b.W = V;
  return b;
}

SolidOptions block() {
  SolidOptions o;
  o.nx = 4;
  o.ny = 3;
  o.nz = 2;
  o.lx = 0.7;
  o.ly = 0.25;
  o.lz = 0.11;
  o.rho = 2700.0;
  o.clamped = false;
  return o;
}

SolidOptions beam() {
  SolidOptions o;  // the default bar 1.0 x 0.1 x 0.05 m of 20 x 2 x 1 elements
  o.clamped = false;
  return o;
}

void expect_rigid_invariants(const BodyInvariants& inv, const Box& box) {
  const double mscale = box.m, jscale = box.J.cwiseAbs().maxCoeff();
  EXPECT_NEAR(inv.mass, box.m, kRounding * mscale);
  for (double md : inv.mass_by_direction) EXPECT_NEAR(md, box.m, kRounding * mscale);
  const double cscale = box.m * box.c.cwiseAbs().maxCoeff();
  for (Index a = 0; a < 3; ++a) EXPECT_NEAR(inv.mc.a0(a, 0), box.m * box.c(a), kRounding * cscale);
  for (Index a = 0; a < 3; ++a)
    for (Index b = 0; b < 3; ++b)
      EXPECT_NEAR(inv.J.a0(a, b), box.J(a, b), kRounding * jscale) << "J(" << a << "," << b << ")";
}

class AnalyticBody : public ::testing::TestWithParam<int> {};

// V = I (the unreduced model): the invariants of the body are those of the continuum box.
TEST_P(AnalyticBody, UnreducedModelHasTheBoxsMassCentreAndInertia) {
  const SolidOptions o = GetParam() == 0 ? block() : beam();
  const Eigen::Vector3d offset(0.3, -0.2, 0.1);
  const Index N = ecmor::bench::solid(o).M.rows();
  const BodyInvariants inv =
      ecmor::compute_body_invariants(body_of(o, offset, Matrix::Identity(N, N)));
  expect_rigid_invariants(inv, analytic(o, offset));
  EXPECT_EQ(inv.constrained_dofs, 0);
  EXPECT_EQ(inv.missing_translations, 0);
  EXPECT_EQ(inv.vw_coupling_difference, 0.0);
  // With V = W = I the reduced matrices are the model's.
  EXPECT_EQ(inv.Me, Matrix(ecmor::bench::solid(o).M));
}

INSTANTIATE_TEST_SUITE_P(BlockAndBeam, AnalyticBody, ::testing::Values(0, 1),
                         [](const ::testing::TestParamInfo<int>& p) {
                           return p.param == 0 ? "Block" : "Beam";
                         });

// The six rigid-body motions as V = W: the couplings are the rigid-body mass matrix
//   [C_t C_r] = Gamma' M [Gamma_t Gamma_r] = [m I, m c~'; m c~, J],
// and the terms linear in q are those of a shifted / turned rigid body (docs/multibody.md):
//   mc.a1[k] = m e_k (translation k), Cr.a1[k](i, a) = m e_i . (e_a x e_k) (i, k translations),
//   J.a1[k] = 2 (e_k . m c) I - (m c e_k' + e_k m c') (translation k), Gr_k + Gr_k' = 2 J.a1[k].
TEST(FlexibleBody, RigidBodyMotionsGiveTheRigidBodyMassMatrix) {
  const SolidOptions o = block();
  const Eigen::Vector3d offset(-0.4, 0.15, 0.05);
  BodyModel b = body_of(o, offset, Matrix());
  const Matrix Gamma = ecmor::rigid_body_modes(b.geometry);
  b.V = b.W = Gamma;
  const BodyInvariants inv = ecmor::compute_body_invariants(b);
  const Box box = analytic(o, offset);
  expect_rigid_invariants(inv, box);

  Matrix expected_Ct(6, 3), expected_Cr(6, 3);
  expected_Ct << box.m * Eigen::Matrix3d::Identity(), box.m * tilde(box.c);
  expected_Cr << box.m * tilde(box.c).transpose(), box.J;
  const double scale = box.J.cwiseAbs().maxCoeff() + box.m;
  EXPECT_LE((inv.Ct_v - expected_Ct).cwiseAbs().maxCoeff(), kRounding * scale) << inv.Ct_v;
  EXPECT_LE((inv.Cr_v.a0 - expected_Cr).cwiseAbs().maxCoeff(), kRounding * scale) << inv.Cr_v.a0;
  Matrix expected_Me(6, 6);
  expected_Me << expected_Ct, expected_Cr;
  EXPECT_LE((inv.Me - expected_Me).cwiseAbs().maxCoeff(), kRounding * scale);
  // K annihilates rigid motions: W' K V is round-off of K's entries times the coordinates.
  const ecmor::SecondOrderModel model = ecmor::bench::solid(o);
  const double kscale = Matrix(model.K).cwiseAbs().maxCoeff() * Gamma.cwiseAbs().maxCoeff() *
                        Gamma.cwiseAbs().maxCoeff() * static_cast<double>(model.K.rows());
  EXPECT_LE(inv.Ke.cwiseAbs().maxCoeff(), 1e-12 * kscale);

  const Eigen::Vector3d mc = box.m * box.c;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d ek = Eigen::Vector3d::Unit(k);
    EXPECT_LE((inv.mc.a1[static_cast<std::size_t>(k)] - box.m * ek).cwiseAbs().maxCoeff(),
              kRounding * box.m);
    const Eigen::Matrix3d J1 = 2.0 * ek.dot(mc) * Eigen::Matrix3d::Identity() -
                               (mc * ek.transpose() + ek * mc.transpose());
    EXPECT_LE((inv.J.a1[static_cast<std::size_t>(k)] - J1).cwiseAbs().maxCoeff(), kRounding * scale)
        << "J.a1[" << k << "]";
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 3; ++a) {
        const double expected =
            box.m * Eigen::Vector3d::Unit(i).dot(Eigen::Vector3d::Unit(a).cross(ek));
        EXPECT_NEAR(inv.Cr_v.a1[static_cast<std::size_t>(k)](i, a), expected, kRounding * box.m);
      }
  }
  // Gyroscopic terms of a translation k: Gr_k = -2 int R~ e_k~ dm = -2 m c~ e_k~, and
  // Ge_k(i, a) = 2 int e_i . (e_a x e_k) dm for the translations i.
  for (int k = 0; k < 3; ++k) {
    const Eigen::Matrix3d Gr = -2.0 * box.m * tilde(box.c) * tilde(Eigen::Vector3d::Unit(k));
    EXPECT_LE((inv.Gr[static_cast<std::size_t>(k)] - Gr).cwiseAbs().maxCoeff(), kRounding * scale);
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 3; ++a)
        EXPECT_NEAR(inv.Ge[static_cast<std::size_t>(k)](i, a),
                    2.0 * box.m *
                        Eigen::Vector3d::Unit(i).dot(
                            Eigen::Vector3d::Unit(a).cross(Eigen::Vector3d::Unit(k))),
                    kRounding * box.m);
  }
  // Centrifugal force on the translations: psi_i = e_i, r = R: int e_i . w x (w x R) dm =
  // (w x (w x m c))_i, whose coefficient of w_a^2 is m (c_a delta_ia - c_i) and of w_a w_b
  // (a != b) m (c_b delta_ia + c_a delta_ib).
  for (int i = 0; i < 3; ++i)
    for (std::size_t p = 0; p < 6; ++p) {
      const int a = ecmor::kOmegaPairs[p][0], d = ecmor::kOmegaPairs[p][1];
      const double expected =
          a == d ? (i == a ? mc(a) : 0.0) - mc(i) : (i == a ? mc(d) : 0.0) + (i == d ? mc(a) : 0.0);
      EXPECT_NEAR(inv.Oe.a0(i, static_cast<Index>(p)), expected, kRounding * scale);
    }
}

// Petrov-Galerkin: the rigid rows follow V and the elastic rows W. With W = 2 V every W-side
// invariant doubles and the V-side ones stay.
TEST(FlexibleBody, TheTestBasisEntersOnlyTheElasticRows) {
  const SolidOptions o = block();
  BodyModel b = body_of(o, Eigen::Vector3d::Zero(), Matrix());
  const Index N = b.M.rows();
  b.V = Matrix::Random(N, 4);
  b.W = b.V;
  const BodyInvariants galerkin = ecmor::compute_body_invariants(b);
  b.W = 2.0 * b.V;
  const BodyInvariants pg = ecmor::compute_body_invariants(b);
  EXPECT_EQ(pg.Ct_v, galerkin.Ct_v);
  EXPECT_EQ(pg.Cr_v.a0, galerkin.Cr_v.a0);
  EXPECT_EQ(pg.Ct_w, 2.0 * galerkin.Ct_w);
  EXPECT_EQ(pg.Cr_w.a0, 2.0 * galerkin.Cr_w.a0);
  EXPECT_EQ(pg.Oe.a1[2], 2.0 * galerkin.Oe.a1[2]);
  EXPECT_EQ(pg.J.a1[1], galerkin.J.a1[1]);
  EXPECT_EQ(pg.Gr[3], galerkin.Gr[3]);
  EXPECT_EQ(galerkin.vw_coupling_difference, 0.0);
  EXPECT_NEAR(pg.vw_coupling_difference, 0.5, 1e-15);  // |v - 2v| / |2v|
  EXPECT_LE((pg.Me - 2.0 * galerkin.Me).cwiseAbs().maxCoeff(),
            1e-14 * galerkin.Me.cwiseAbs().maxCoeff());
}

// A clamped body: the model lacks the clamped face's rows. With the free box as mass model (T_BC)
// the rigid invariants are the whole box's, and the clamped rows are zero in every shape; without
// it, the missing translations are counted (the app warns).
TEST(FlexibleBody, BoundaryConditionsThroughTheMassModel) {
  SolidOptions clamped = block();
  clamped.clamped = true;
  const Index N = ecmor::bench::solid(clamped).M.rows();
  BodyModel b = body_of(clamped, Eigen::Vector3d::Zero(), Matrix::Identity(N, N));
  const Index face = 3 * (clamped.ny + 1) * (clamped.nz + 1);
  const BodyInvariants without = ecmor::compute_body_invariants(b);
  EXPECT_EQ(without.missing_translations, face);
  EXPECT_LT(without.mass, analytic(block(), Eigen::Vector3d::Zero()).m);

  const SolidOptions free = block();
  b.mass_model = ecmor::MassModel{ecmor::bench::solid_geometry(free), ecmor::bench::solid(free).M};
  const BodyInvariants inv = ecmor::compute_body_invariants(b);
  expect_rigid_invariants(inv, analytic(free, Eigen::Vector3d::Zero()));
  EXPECT_EQ(inv.constrained_dofs, face);
  EXPECT_EQ(inv.missing_translations, 0);
  // T_BC: with V = I, row r of C_t is the free box's (M Gamma_t) at the row of the same (node,
  // direction); the clamped rows enter no shape.
  const Matrix Gamma = ecmor::rigid_body_modes(ecmor::bench::solid_geometry(free));
  const Matrix MGt = ecmor::bench::solid(free).M * Gamma.leftCols(3);
  const ecmor::FeGeometry gc = ecmor::bench::solid_geometry(clamped);
  const ecmor::FeGeometry gf = ecmor::bench::solid_geometry(free);
  const double scale = MGt.cwiseAbs().maxCoeff();
  for (const ecmor::FeDof& d : gc.dofs) {
    Index free_row = -1;
    for (const ecmor::FeDof& e : gf.dofs)
      if (e.node == d.node && e.direction == d.direction) free_row = e.row - 1;
    ASSERT_GE(free_row, 0);
    for (Index a = 0; a < 3; ++a)
      EXPECT_NEAR(inv.Ct_v(d.row - 1, a), MGt(free_row, a), kRounding * scale);
  }
}

TEST(FlexibleBody, RejectsInconsistentInput) {
  const SolidOptions o = block();
  BodyModel b = body_of(o, Eigen::Vector3d::Zero(), Matrix());
  const Index N = b.M.rows();
  b.V = Matrix::Identity(N - 1, 2);
  b.W = b.V;
  EXPECT_THROW(
      {
        try {
          ecmor::compute_body_invariants(b);
        } catch (const ecmor::InputError& e) {
          EXPECT_NE(std::string(e.what()).find("V is " + std::to_string(N - 1) + " x 2"),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      ecmor::InputError);

  b.V = b.W = Matrix::Identity(N, 2);
  SolidOptions clamped = o;
  clamped.clamped = true;
  b.mass_model =
      ecmor::MassModel{ecmor::bench::solid_geometry(clamped), ecmor::bench::solid(clamped).M};
  try {
    ecmor::compute_body_invariants(b);
    ADD_FAILURE() << "a mass model without the model's rows was accepted";
  } catch (const ecmor::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the mass model has no row for node 1, direction 1"),
              std::string::npos)
        << e.what();
  }

  b.mass_model = ecmor::MassModel{ecmor::bench::solid_geometry(o), ecmor::bench::solid(o).M};
  b.mass_model->geometry.nodes[5].y += 1e-3;
  try {
    ecmor::compute_body_invariants(b);
    ADD_FAILURE() << "a mass model of another mesh was accepted";
  } catch (const ecmor::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("node 6 is at"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("same mesh"), std::string::npos) << e.what();
  }
}

// Free-floating bodies (elastic_bases): the body frame carries the rigid-body motion, so the
// elastic coordinates must not. The references are dense eigenpairs of the free block computed
// here: six zero eigenvalues (the rigid motions), then the elastic ones; elastic modes of a free
// body are M-orthogonal to the rigid motions, so removing the rigid part leaves them unchanged.
struct FreeBlock {
  BodyModel body;
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> modes;
  Index rigid_modes = 0;  // dim null(K) by the driver's analysis (rigid_body.hpp)
};

FreeBlock free_block(bool clamped = false) {
  SolidOptions o = block();
  o.clamped = clamped;
  FreeBlock f{body_of(o, Eigen::Vector3d(0.3, -0.2, 0.1), Matrix()), {}, 0};
  f.modes.compute(Matrix(f.body.K), Matrix(f.body.M));
  f.rigid_modes = ecmor::rigid_body_modes(ecmor::Model(ecmor::bench::solid(o))).count;
  return f;
}

// Relative agreement of the eigenvalues of the reduced pencil (W' K V, W' M V) with `expected`.
void expect_pencil_eigenvalues(const ecmor::ElasticBases& e, const BodyModel& b,
                               const std::vector<double>& expected) {
  const Matrix Me = e.W.transpose() * (b.M * e.V), Ke = e.W.transpose() * (b.K * e.V);
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> reduced(Ke, Me);
  ASSERT_EQ(reduced.eigenvalues().size(), static_cast<Index>(expected.size()));
  for (std::size_t k = 0; k < expected.size(); ++k)
    EXPECT_NEAR(reduced.eigenvalues()(static_cast<Index>(k)), expected[k], 1e-9 * expected[k]) << k;
}

TEST(ElasticBases, AModalBasisOfAFreeBodyLosesItsRigidModesAndKeepsItsElasticOnes) {
  FreeBlock f = free_block();
  const Vector& lambda = f.modes.eigenvalues();
  ASSERT_LT(std::abs(lambda(5)), 1e-8 * lambda(6));  // six rigid-body modes, then elastic ones
  f.body.V = f.body.W = f.modes.eigenvectors().leftCols(10);
  ASSERT_EQ(f.rigid_modes, 6);
  const ecmor::ElasticBases e = ecmor::elastic_bases(f.body, f.rigid_modes);
  EXPECT_EQ(e.free_motions, 6);
  EXPECT_EQ(e.removed, 6);
  ASSERT_EQ(e.V.cols(), 4);
  EXPECT_EQ(e.T.rows(), 10);
  EXPECT_TRUE(e.W == e.V);
  // Mass-normalised elastic modes in ascending order: Me = I, Ke = diag(lambda_7..10).
  const Matrix Me = e.V.transpose() * (f.body.M * e.V), Ke = e.V.transpose() * (f.body.K * e.V);
  EXPECT_LT((Me - Matrix::Identity(4, 4)).cwiseAbs().maxCoeff(), 1e-10);
  for (Index k = 0; k < 4; ++k) EXPECT_NEAR(Ke(k, k), lambda(6 + k), 1e-9 * lambda(6 + k)) << k;
  // Mean axes: no elastic coordinate moves the centre of mass or turns the body (C_t = 0,
  // C_r(0) = 0), to rounding of sqrt(m) (a mass-normalised coordinate's coupling scale).
  f.body.V = e.V;
  f.body.W = e.W;
  const BodyInvariants inv = ecmor::compute_body_invariants(f.body);
  const double scale = std::sqrt(inv.mass) * 1e-9;
  EXPECT_LT(inv.Ct_v.cwiseAbs().maxCoeff(), scale);
  EXPECT_LT(inv.Cr_v.a0.cwiseAbs().maxCoeff(), scale * 10.0);  // times lengths of order 1 m
}

TEST(ElasticBases, AClampedBodyKeepsItsBasis) {
  FreeBlock f = free_block(/*clamped=*/true);
  ASSERT_EQ(f.rigid_modes, 0);
  f.body.V = f.body.W = f.modes.eigenvectors().leftCols(5);
  const ecmor::ElasticBases e = ecmor::elastic_bases(f.body, f.rigid_modes);
  EXPECT_EQ(e.free_motions, 0);
  EXPECT_EQ(e.removed, 0);
  EXPECT_TRUE(e.V == f.body.V);
  EXPECT_TRUE(e.W == f.body.W);
  EXPECT_TRUE(e.T == Matrix::Identity(5, 5));
  // A clamped block's restricted rigid motions strain the elements at the clamp: they are not
  // free, and a null space of K claimed for them is refused.
  try {
    ecmor::elastic_bases(f.body, 1);
    ADD_FAILURE() << "a clamped block was given a free rigid-body motion";
  } catch (const ecmor::InputError& err) {
    EXPECT_NE(
        std::string(err.what()).find("only 0 of the 6 rigid motions of the geometry are free"),
        std::string::npos)
        << err.what();
  }
}

TEST(ElasticBases, PartlyRigidColumnsLoseTheirRigidPartOnly) {
  FreeBlock f = free_block();
  const Matrix Gamma = ecmor::rigid_body_modes(f.body.geometry);
  const Matrix& phi = f.modes.eigenvectors();
  // A translation, an elastic mode with a rotation added, another elastic mode.
  Matrix V(phi.rows(), 3);
  V.col(0) = 0.7 * Gamma.col(0);
  V.col(1) = phi.col(7) + 0.5 * Gamma.col(5) * phi.col(7).norm() / Gamma.col(5).norm();
  V.col(2) = phi.col(9) - 0.2 * Gamma.col(1) * phi.col(9).norm() / Gamma.col(1).norm();
  f.body.V = f.body.W = V;
  const ecmor::ElasticBases e = ecmor::elastic_bases(f.body, f.rigid_modes);
  EXPECT_EQ(e.free_motions, 6);
  EXPECT_EQ(e.removed, 1);
  expect_pencil_eigenvalues(e, f.body, {f.modes.eigenvalues()(7), f.modes.eigenvalues()(9)});

  // Petrov-Galerkin (W != V): W gets the same transformation, and no rotation to modes.
  f.body.W = 2.0 * V;
  const ecmor::ElasticBases pg = ecmor::elastic_bases(f.body, f.rigid_modes);
  EXPECT_EQ(pg.removed, 1);
  EXPECT_LT((pg.W - 2.0 * pg.V).cwiseAbs().maxCoeff(), 1e-12 * pg.W.cwiseAbs().maxCoeff());
  expect_pencil_eigenvalues(pg, f.body, {f.modes.eigenvalues()(7), f.modes.eigenvalues()(9)});
}

TEST(ElasticBases, DependentColumnsAreRefusedByName) {
  FreeBlock f = free_block();
  Matrix V = f.modes.eigenvectors().middleCols(6, 3);
  V.col(2) = V.col(0) + V.col(1);
  f.body.V = f.body.W = V;
  try {
    ecmor::elastic_bases(f.body, f.rigid_modes);
    ADD_FAILURE() << "dependent columns were accepted";
  } catch (const ecmor::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("V has rank 2 of 3 columns"), std::string::npos)
        << e.what();
  }
}

}  // namespace
