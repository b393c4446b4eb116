// Tests of the 3-D solid generator (bench/solid.hpp) against independent references: the mass of
// the box, the rigid-body null space of the free body, definiteness, an independent dense
// element-by-element assembly, the first axial eigenfrequency of a clamped bar against the
// continuum and the exact 1-D finite-element dispersion relation, the input and output locations,
// and the option rules.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "../../bench/solid.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/model.hpp"

namespace {

using ecmor::Index;
using ecmor::kPi;
using ecmor::Matrix;
using ecmor::SecondOrderModel;
using ecmor::Vector;
using ecmor::bench::solid;
using ecmor::bench::SolidOptions;

// The numbering documented in solid.hpp, written out again here: free node (i, j, k), component c.
Index dof(const SolidOptions& o, Index i, Index j, Index k, Index c) {
  const Index i0 = o.clamped ? 1 : 0;
  return 3 * ((i - i0) + (o.nx + 1 - i0) * (j + (o.ny + 1) * k)) + c;
}

// A field u(x, y, z) in R^3 sampled at every free node.
Vector sample(const SolidOptions& o,
              const std::function<Eigen::Vector3d(double, double, double)>& u) {
  const Index i0 = o.clamped ? 1 : 0;
  Vector v(3 * (o.nx + 1 - i0) * (o.ny + 1) * (o.nz + 1));
  for (Index k = 0; k <= o.nz; ++k)
    for (Index j = 0; j <= o.ny; ++j)
      for (Index i = i0; i <= o.nx; ++i) {
        const Eigen::Vector3d value = u(o.lx * static_cast<double>(i) / static_cast<double>(o.nx),
                                        o.ly * static_cast<double>(j) / static_cast<double>(o.ny),
                                        o.lz * static_cast<double>(k) / static_cast<double>(o.nz));
        for (Index c = 0; c < 3; ++c) v(dof(o, i, j, k, c)) = value(c);
      }
  return v;
}

// A small free box with unequal element edges and nu != 0, so that no entry is accidentally
// symmetric in x, y, z.
SolidOptions small_box(bool clamped) {
  SolidOptions o;
  o.nx = 4;
  o.ny = 3;
  o.nz = 2;
  o.lx = 0.7;
  o.ly = 0.25;
  o.lz = 0.11;
  o.nu = 0.3;
  o.alpha = 3.0;
  o.beta = 2e-6;
  o.clamped = clamped;
  return o;
}

TEST(SolidGenerator, SizesAndExactSymmetry) {
  for (bool clamped : {true, false}) {
    SCOPED_TRACE(clamped ? "clamped" : "free");
    const SolidOptions o = small_box(clamped);
    const SecondOrderModel m = solid(o);
    const Index nodes = (o.nx + 1 - (clamped ? 1 : 0)) * (o.ny + 1) * (o.nz + 1);
    ASSERT_EQ(m.size(), 3 * nodes);
    ASSERT_EQ(m.inputs(), o.inputs);
    ASSERT_EQ(m.outputs(), o.outputs);
    EXPECT_FALSE(m.has_velocity_output());
    EXPECT_NO_THROW(ecmor::validate(ecmor::Model(m)));
    // Assembled symmetric by construction: bit for bit, not merely to rounding.
    EXPECT_EQ(ecmor::relative_asymmetry(m.K), 0.0);
    EXPECT_EQ(ecmor::relative_asymmetry(m.M), 0.0);
    EXPECT_EQ(ecmor::relative_asymmetry(m.D), 0.0);
    EXPECT_TRUE(ecmor::is_positive_definite(m.M));
    EXPECT_EQ(m.K.nonZeros(), 3 * m.M.nonZeros());  // K: 3x3 node blocks, M: their diagonal
  }
}

// (a) u = e_c at every node is a rigid translation: u' M u is the total mass rho lx ly lz.
TEST(SolidGenerator, TotalMassOfTheFreeBox) {
  SolidOptions o = small_box(false);
  o.nx = 5;  // odd counts too
  const SecondOrderModel m = solid(o);
  const double mass = o.rho * o.lx * o.ly * o.lz;
  for (Index c = 0; c < 3; ++c) {
    const Vector u = sample(
        o, [&](double, double, double) { return Eigen::Vector3d(Eigen::Vector3d::Unit(c)); });
    EXPECT_NEAR(u.dot(m.M * u), mass, 1e-12 * mass) << "direction " << c;
  }
}

// (b) The free body: K annihilates the 6 rigid-body motions, 3 translations e_c and 3
// infinitesimal rotations e_c x r (zero strain; trilinear elements reproduce linear fields
// exactly, so only rounding remains). K is singular, hence not positive definite.
TEST(SolidGenerator, FreeBodyHasTheSixRigidBodyModesAsNullSpace) {
  const SolidOptions o = small_box(false);
  const SecondOrderModel m = solid(o);
  const double k_norm = m.K.norm();
  for (Index c = 0; c < 3; ++c) {
    const Eigen::Vector3d axis = Eigen::Vector3d::Unit(c);
    const Vector t = sample(o, [&](double, double, double) { return Eigen::Vector3d(axis); });
    const Vector r = sample(o, [&](double x, double y, double z) {
      // Centred rotation: keeps ||u|| comparable to the translation's.
      return Eigen::Vector3d(axis.cross(Eigen::Vector3d(x - o.lx / 2, y - o.ly / 2, z - o.lz / 2)));
    });
    EXPECT_LE((m.K * t).norm(), 1e-12 * k_norm * t.norm()) << "translation " << c;
    EXPECT_LE((m.K * r).norm(), 1e-12 * k_norm * r.norm()) << "rotation " << c;
  }
  EXPECT_FALSE(ecmor::is_positive_definite(m.K));
  // And they are the whole null space: exactly 6 eigenvalues of K at rounding level, the 7th
  // (the softest elastic mode) far above it.
  Eigen::SelfAdjointEigenSolver<Matrix> eig(Matrix(m.K), Eigen::EigenvaluesOnly);
  const Vector& lambda = eig.eigenvalues();
  EXPECT_LE(std::abs(lambda(5)), 1e-12 * lambda(lambda.size() - 1));
  EXPECT_GE(lambda(6), 1e-6 * lambda(lambda.size() - 1));
}

// (c) Clamping the face x = 0 removes the rigid-body modes: K and D become positive definite.
TEST(SolidGenerator, ClampedStiffnessIsPositiveDefinite) {
  const SecondOrderModel m = solid(small_box(true));
  EXPECT_TRUE(ecmor::is_positive_definite(m.K));
  EXPECT_TRUE(ecmor::is_positive_definite(m.D));
}

// Independent reference for the sparse assembly: a 1 x 1 x 1 free box is one element, so its K
// and M are the element matrices in the local node order l = a + 2 b + 4 c (the numbering of
// solid.hpp). Adding them element by element into dense matrices must give the generated model
// of a larger box with the same element, free and clamped (rows and columns of x = 0 removed).
TEST(SolidGenerator, MatchesDenseElementByElementAssembly) {
  for (bool clamped : {false, true}) {
    SCOPED_TRACE(clamped ? "clamped" : "free");
    const SolidOptions o = small_box(clamped);
    SolidOptions one = o;
    one.nx = one.ny = one.nz = 1;
    one.lx = o.lx / static_cast<double>(o.nx);
    one.ly = o.ly / static_cast<double>(o.ny);
    one.lz = o.lz / static_cast<double>(o.nz);
    one.clamped = false;
    const SecondOrderModel element = solid(one);
    const Matrix ke(element.K), me(element.M);
    ASSERT_EQ(ke.rows(), 24);

    SolidOptions all = o;
    all.clamped = false;  // assemble everything, then drop the clamped face
    const Index n_all = 3 * (o.nx + 1) * (o.ny + 1) * (o.nz + 1);
    Matrix K = Matrix::Zero(n_all, n_all), M = Matrix::Zero(n_all, n_all);
    for (Index ez = 0; ez < o.nz; ++ez)
      for (Index ey = 0; ey < o.ny; ++ey)
        for (Index ex = 0; ex < o.nx; ++ex)
          for (Index l = 0; l < 8; ++l)
            for (Index m = 0; m < 8; ++m)
              for (Index c = 0; c < 3; ++c)
                for (Index d = 0; d < 3; ++d) {
                  const Index gl = dof(all, ex + (l & 1), ey + ((l >> 1) & 1), ez + (l >> 2), c);
                  const Index gm = dof(all, ex + (m & 1), ey + ((m >> 1) & 1), ez + (m >> 2), d);
                  K(gl, gm) += ke(3 * l + c, 3 * m + d);
                  M(gl, gm) += me(3 * l + c, 3 * m + d);
                }
    std::vector<Index> keep;
    for (Index k = 0; k <= o.nz; ++k)
      for (Index j = 0; j <= o.ny; ++j)
        for (Index i = clamped ? 1 : 0; i <= o.nx; ++i)
          for (Index c = 0; c < 3; ++c) keep.push_back(dof(all, i, j, k, c));
    const Matrix K_ref = K(keep, keep), M_ref = M(keep, keep);
    const Matrix D_ref = o.alpha * M_ref + o.beta * K_ref;

    const SecondOrderModel gen = solid(o);
    ASSERT_EQ(gen.size(), static_cast<Index>(keep.size()));
    // Up to 8 element entries per global entry, summed in another order: a few roundings.
    EXPECT_LE((Matrix(gen.K) - K_ref).cwiseAbs().maxCoeff(), 1e-14 * K_ref.cwiseAbs().maxCoeff());
    EXPECT_LE((Matrix(gen.M) - M_ref).cwiseAbs().maxCoeff(), 1e-14 * M_ref.cwiseAbs().maxCoeff());
    EXPECT_LE((Matrix(gen.D) - D_ref).cwiseAbs().maxCoeff(), 1e-14 * D_ref.cwiseAbs().maxCoeff());
  }
}

// (d) First axial mode of a clamped-free bar. Continuum: f = c / (4 L), c = sqrt(E / rho).
// With nu = 0 the field u = (g(x), 0, 0) is stress-free laterally, and the trilinear elements
// reduce it exactly to 1-D linear elements with consistent mass: the eigenvector is
// u_i = sin(k x_i), k = pi / (2 L) (it meets the clamp and the free end's discrete condition), and
// the eigenvalue follows from the 1-D rows  (E/h)(2 - 2 cos kh) = w^2 (rho h / 6)(4 + 2 cos kh):
//     w_h^2 = (6 c^2 / h^2) (1 - cos t) / (2 + cos t),   t = k h.
// Expanding, w_h / w = 1 + t^2 / 24 + O(t^4) (the O(t^4) term is 3 t^4 / 640 > 0): consistent mass
// overestimates, by t^2 / 24 = 6.4e-5 for 40 elements. The test asserts both the continuum
// bound 0 < w_h / w - 1 <= (t^2 / 24)(1 + t^2) and the exact discrete value (1e-10 relative:
// the dense solver's accuracy for this eigenvalue is about eps lambda_max / lambda = 1e-12).
TEST(SolidGenerator, FirstAxialFrequencyOfAClampedBar) {
  SolidOptions o;
  o.nx = 40;
  o.ny = 1;
  o.nz = 1;
  o.lx = 1.0;
  o.ly = 0.05;
  o.lz = 0.05;
  o.nu = 0.0;
  o.clamped = true;
  const SecondOrderModel m = solid(o);
  ASSERT_EQ(m.size(), 3 * 40 * 4);
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> eig(Matrix(m.K), Matrix(m.M));
  ASSERT_EQ(eig.info(), Eigen::Success);

  // The axial mode: the lowest one whose kinetic energy is all in x (M couples equal components
  // only, so v' M v splits by component).
  const Matrix M(m.M);
  Index axial = -1;
  for (Index r = 0; r < m.size() && axial < 0; ++r) {
    const Vector v = eig.eigenvectors().col(r);
    Vector vx = Vector::Zero(v.size());
    for (Index d = 0; d < v.size(); d += 3) vx(d) = v(d);
    if (vx.dot(M * vx) >= (1.0 - 1e-8) * v.dot(M * v)) axial = r;
  }
  ASSERT_GE(axial, 0);
  const double omega_h = std::sqrt(eig.eigenvalues()(axial));

  const double c = std::sqrt(o.E / o.rho);
  const double h = o.lx / static_cast<double>(o.nx);
  const double k = kPi / (2.0 * o.lx);
  const double t = k * h;
  const double omega = c * k;
  const double relative_error = omega_h / omega - 1.0;
  EXPECT_GT(relative_error, 0.0);
  EXPECT_LE(relative_error, t * t / 24.0 * (1.0 + t * t));
  const double omega_fe =
      std::sqrt(6.0 * c * c / (h * h) * (1.0 - std::cos(t)) / (2.0 + std::cos(t)));
  EXPECT_NEAR(omega_h, omega_fe, 1e-10 * omega_fe);
}

// Inputs on the far face, in distinct (node, direction) pairs, as in the table of solid.hpp.
TEST(SolidGenerator, InputsAndOutputsFollowTheTable) {
  for (bool clamped : {true, false}) {
    SolidOptions o = small_box(clamped);
    o.inputs = ecmor::bench::kSolidMaxInputs;
    o.outputs = ecmor::bench::kSolidMaxOutputs;
    const SecondOrderModel m = solid(o);
    const Index nx = o.nx, ny = o.ny, nz = o.nz, jc = ny / 2, kc = nz / 2, im = (nx + 1) / 2;
    const std::vector<Index> in = {
        dof(o, nx, jc, kc, 0), dof(o, nx, jc, kc, 1), dof(o, nx, jc, kc, 2), dof(o, nx, ny, nz, 1),
        dof(o, nx, ny, 0, 2),  dof(o, nx, 0, nz, 0),  dof(o, nx, ny, nz, 2), dof(o, nx, ny, nz, 0)};
    const std::vector<Index> out = {
        dof(o, nx, jc, kc, 0), dof(o, nx, jc, kc, 1), dof(o, nx, jc, kc, 2), dof(o, nx, ny, nz, 1),
        dof(o, im, jc, kc, 1), dof(o, im, jc, kc, 2), dof(o, nx, ny, nz, 2), dof(o, im, jc, kc, 0)};
    for (Index q = 0; q < m.inputs(); ++q) {
      Vector e = Vector::Zero(m.size());
      e(in[static_cast<std::size_t>(q)]) = 1.0;
      EXPECT_EQ((m.B.col(q) - e).cwiseAbs().maxCoeff(), 0.0) << "input " << q;
      for (Index p = 0; p < q; ++p)
        EXPECT_NE(in[static_cast<std::size_t>(p)], in[static_cast<std::size_t>(q)]);
    }
    for (Index r = 0; r < m.outputs(); ++r) {
      Vector e = Vector::Zero(m.size());
      e(out[static_cast<std::size_t>(r)]) = 1.0;
      EXPECT_EQ((m.C.row(r).transpose() - e).cwiseAbs().maxCoeff(), 0.0) << "output " << r;
    }
  }
  // The defaults: 4 inputs, 6 outputs.
  const SecondOrderModel d = solid(SolidOptions{});
  EXPECT_EQ(d.inputs(), 4);
  EXPECT_EQ(d.outputs(), 6);
  // Even a one-element section keeps the inputs distinct (the centre is never a used corner).
  SolidOptions thin;
  thin.ny = thin.nz = 1;
  thin.inputs = ecmor::bench::kSolidMaxInputs;
  const Matrix b = solid(thin).B;
  EXPECT_EQ((b.transpose() * b - Matrix::Identity(b.cols(), b.cols())).cwiseAbs().maxCoeff(), 0.0);
}

// (e) Every rule: the error names the field, the value and the rule.
TEST(SolidGenerator, InvalidOptionsNameTheField) {
  struct Case {
    const char* expected;
    std::function<void(SolidOptions&)> spoil;
  };
  const double nan = std::nan("");
  const std::vector<Case> cases = {
      {"SolidOptions::nx = 0: must be >= 1", [](SolidOptions& o) { o.nx = 0; }},
      {"SolidOptions::ny = -2: must be >= 1", [](SolidOptions& o) { o.ny = -2; }},
      {"SolidOptions::nz = 0", [](SolidOptions& o) { o.nz = 0; }},
      {"SolidOptions::nx, ny, nz = 1000 x 1000 x 1000",
       [](SolidOptions& o) { o.nx = o.ny = o.nz = 1000; }},
      {"SolidOptions::lx = 0: must be finite and > 0", [](SolidOptions& o) { o.lx = 0.0; }},
      {"SolidOptions::ly = -1", [](SolidOptions& o) { o.ly = -1.0; }},
      {"SolidOptions::lz = inf",
       [](SolidOptions& o) { o.lz = std::numeric_limits<double>::infinity(); }},
      {"SolidOptions::E = nan", [&](SolidOptions& o) { o.E = nan; }},
      {"SolidOptions::nu = 0.5: must be in [0, 0.5)", [](SolidOptions& o) { o.nu = 0.5; }},
      {"SolidOptions::nu = -0.1", [](SolidOptions& o) { o.nu = -0.1; }},
      {"SolidOptions::rho = 0", [](SolidOptions& o) { o.rho = 0.0; }},
      {"SolidOptions::alpha = -1: must be finite and >= 0", [](SolidOptions& o) { o.alpha = -1; }},
      {"SolidOptions::beta = nan", [&](SolidOptions& o) { o.beta = nan; }},
      {"SolidOptions::inputs = 0: must be in [1, 8]", [](SolidOptions& o) { o.inputs = 0; }},
      {"SolidOptions::outputs = 9: must be in [1, 8]", [](SolidOptions& o) { o.outputs = 9; }},
  };
  EXPECT_NO_THROW(SolidOptions{}.validate());
  for (const Case& c : cases) {
    SolidOptions o;
    c.spoil(o);
    try {
      o.validate();
      ADD_FAILURE() << "no error for " << c.expected;
    } catch (const ecmor::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos)
          << "got: " << e.what() << "\nexpected to contain: " << c.expected;
    }
    EXPECT_THROW(solid(o), ecmor::ConfigError) << c.expected;
  }
}

}  // namespace
