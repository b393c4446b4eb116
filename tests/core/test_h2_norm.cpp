// H2 norms: closed forms, the poles/residues formula (an independent eigen-decomposition) on
// benchmark models, the quadrature for large models against the dense Gramian formula, the unstable
// model refused, and the dense balanced truncation reference with its H-infinity bound.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <variant>
#include <vector>

#include "common/builders.hpp"
#include "common/dense_balanced_truncation.hpp"
#include "common/small_models.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/measures/h2_norm.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/response/reduced_response.hpp"

namespace ecmor {
namespace {

using test::sparse;

using test::first_order;
using test::message_of;
using test::oscillator;

const std::string kModels = "models/";

/// <G1, G2>_H2 for Gi = 1 / (s^2 + di s + ki), by the residues of G1(-s) G2(s) in the left
/// half-plane (derived by hand, checked by a 2e6-point quadrature: 0.210526315789 for
/// (0.3, 4, 0.5, 5)): (d1 + d2) / ((k1 - k2)^2 + (d1 + d2)(d1 k2 + d2 k1)).
double oscillator_inner(double d1, double k1, double d2, double k2) {
  return (d1 + d2) / ((k1 - k2) * (k1 - k2) + (d1 + d2) * (d1 * k2 + d2 * k1));
}

double rel(double x, double ref) { return std::abs(x - ref) / std::abs(ref); }

TEST(H2Analytic, FirstOrderLowPass) {
  // G = c b / (s + a): ||G||^2 = (1/2pi) int (cb)^2 / (w^2 + a^2) dw = (cb)^2 / (2a).
  const double a = 3.0, b = 2.0, c = -0.7;
  EXPECT_LT(rel(h2_norm(first_order(1.0, -a, b, c)), std::sqrt(c * b * c * b / (2.0 * a))), 1e-14);
  // The same with E = 2: G = c b / (2 s + a) = (c b / 2) / (s + a / 2).
  EXPECT_LT(
      rel(h2_norm(first_order(2.0, -a, b, c)), std::sqrt(0.25 * c * b * c * b / (2.0 * 0.5 * a))),
      1e-14);
}

TEST(H2Analytic, DampedOscillatorBothKinds) {
  // G = 1 / (m s^2 + d s + k): ||G||^2 = 1 / (2 d k), whatever m.
  const double m = 2.5, d = 0.03, k = 40.0;
  const double ref = std::sqrt(1.0 / (2.0 * d * k));
  EXPECT_LT(rel(h2_norm(oscillator(m, d, k)), ref), 1e-12);
  EXPECT_LT(rel(h2_norm(first_order_realization(oscillator(m, d, k))), ref), 1e-12);
  // The quadrature on the sparse 1-DOF model: a lightly damped peak (zeta = 1.5e-3).
  SecondOrderModel full;
  full.M = sparse(Matrix::Constant(1, 1, m));
  full.D = sparse(Matrix::Constant(1, 1, d));
  full.K = sparse(Matrix::Constant(1, 1, k));
  full.B = Matrix::Ones(1, 1);
  full.C = Matrix::Ones(1, 1);
  const auto solver = make_shifted_solver(full);
  const H2Result q = h2_error_quadrature(full, *solver, nullptr);
  EXPECT_TRUE(q.converged) << q.method;
  EXPECT_LT(rel(q.value, ref), 1e-9) << q.method << " evaluations " << q.evaluations;
  // The error against a detuned oscillator, in closed form: 1 / (m s^2 + d s + k) is 1/m times
  // the unit-mass oscillator with d/m, k/m, whose inner products are given by oscillator_inner.
  const double d2 = 1.2 * d, k2 = 1.01 * k;
  const double e2 = (oscillator_inner(d / m, k / m, d / m, k / m) +
                     oscillator_inner(d2 / m, k2 / m, d2 / m, k2 / m) -
                     2.0 * oscillator_inner(d / m, k / m, d2 / m, k2 / m)) /
                    (m * m);
  const ReducedModel r = oscillator(m, d2, k2);
  const H2Result qe = h2_error_quadrature(full, *solver, &r);
  EXPECT_TRUE(qe.converged) << qe.method;
  // The closed form subtracts terms of size 1/(2dk) to get an error ~0.1 of it: 1e-14 -> 1e-12.
  EXPECT_LT(rel(qe.value, std::sqrt(e2)), 1e-9) << qe.method;
  EXPECT_LT(rel(h2_error_norm(oscillator(m, d, k), r), std::sqrt(e2)), 1e-11);
}

TEST(H2Analytic, InnerProductOfTwoOscillators) {
  const double d1 = 0.3, k1 = 4.0, d2 = 0.5, k2 = 5.0;
  EXPECT_LT(rel(h2_inner_product(oscillator(1.0, d1, k1), oscillator(1.0, d2, k2)),
                oscillator_inner(d1, k1, d2, k2)),
            1e-13);
  // d1 = d2, k1 = k2 gives 1 / (2 d k).
  EXPECT_LT(rel(oscillator_inner(d1, k1, d1, k1), 1.0 / (2.0 * d1 * k1)), 1e-15);
  EXPECT_LT(rel(h2_inner_product(oscillator(1.0, d1, k1), oscillator(1.0, d1, k1)),
                1.0 / (2.0 * d1 * k1)),
            1e-13);
}

TEST(H2Analytic, DiagonalMimoIsASum) {
  // G = diag(2 s / (s^2 + s + 0.5), 1 / (s^2 + 0.2 s + 9)): DOF 1 observed by its velocity, DOF 2
  // by its position. ||s / (s^2 + d s + k)||^2 = 1 / (2 d) and ||1 / (s^2 + d s + k)||^2 =
  // 1 / (2 d k) (the diagonal of the Gramian diag(1 / (2 d k), 1 / (2 d))), and the squared norm
  // of a diagonal transfer matrix is the sum of its entries'.
  ReducedSecondOrderModel s;
  s.M = Matrix::Identity(2, 2);
  s.D = Matrix::Zero(2, 2);
  s.K = Matrix::Zero(2, 2);
  s.D.diagonal() << 1.0, 0.2;
  s.K.diagonal() << 0.5, 9.0;
  s.B = Matrix::Zero(2, 2);
  s.B.diagonal() << 2.0, 1.0;
  s.C = Matrix::Zero(2, 2);
  s.C(1, 1) = 1.0;
  s.Cv = Matrix::Zero(2, 2);
  s.Cv(0, 0) = 1.0;
  const double ref = std::sqrt(4.0 / (2.0 * 1.0) + 1.0 / (2.0 * 0.2 * 9.0));
  EXPECT_LT(rel(h2_norm(s), ref), 1e-12);
  EXPECT_LT(rel(h2_norm(first_order_realization(s)), ref), 1e-12);
}

TEST(H2Analytic, SecondOrderEqualsAnIndependentFirstOrderRealisation) {
  // A random 6-DOF model with SPD M, D, K and both outputs, against the realisation with E = I:
  // A = [[0, I], [-M^-1 K, -M^-1 D]], B = [0; M^-1 B], C = [C, Cv] (built here, not by the
  // library).
  const Index n = 6;
  const Matrix R1 = Matrix::Random(n, n), R2 = Matrix::Random(n, n), R3 = Matrix::Random(n, n);
  ReducedSecondOrderModel s;
  s.M = Matrix::Identity(n, n) + R1 * R1.transpose() / 6.0;
  s.D = 0.1 * (Matrix::Identity(n, n) + R2 * R2.transpose() / 6.0);
  s.K = 10.0 * (Matrix::Identity(n, n) + R3 * R3.transpose() / 6.0);
  s.B = Matrix::Random(n, 2);
  s.C = Matrix::Random(3, n);
  s.Cv = Matrix::Random(3, n);
  const Matrix Minv = s.M.inverse();
  ReducedDescriptorModel f;
  f.E = Matrix::Identity(2 * n, 2 * n);
  f.A = Matrix::Zero(2 * n, 2 * n);
  f.A.topRightCorner(n, n).setIdentity();
  f.A.bottomLeftCorner(n, n) = -Minv * s.K;
  f.A.bottomRightCorner(n, n) = -Minv * s.D;
  f.B = Matrix::Zero(2 * n, 2);
  f.B.bottomRows(n) = Minv * s.B;
  f.C.resize(3, 2 * n);
  f.C << s.C, s.Cv;
  EXPECT_LT(rel(h2_norm(s), h2_norm(f)), 1e-12);
  const H2Comparison c = h2_compare(s, f);
  EXPECT_LT(rel(c.norm_a, h2_norm(s)), 1e-14);
  EXPECT_LT(rel(c.norm_b, h2_norm(f)), 1e-14);
  EXPECT_LT(h2_error_norm(s, f) / h2_norm(f), 1e-6);  // the difference loses half the digits
}

/// ||G||^2 = sum_k trace(G(-lambda_k)^T R_k) over the poles lambda_k of G with residues R_k, from
/// Eigen's EigenSolver on E^-1 A and dense LU solves (nothing of the Lyapunov code).
double h2_by_residues(const ReducedDescriptorModel& m) {
  const Eigen::PartialPivLU<Matrix> elu(m.E);
  const Eigen::EigenSolver<Matrix> es(Matrix(elu.solve(m.A)));
  const ComplexMatrix V = es.eigenvectors();
  const ComplexMatrix Vinv = V.inverse();
  const ComplexMatrix CV = m.C.cast<Complex>() * V;
  const ComplexMatrix VB = Vinv * elu.solve(m.B).cast<Complex>();
  Complex sum = 0.0;
  for (Index k = 0; k < V.cols(); ++k) {
    const Complex lambda = es.eigenvalues()(k);
    const ComplexMatrix Rk = CV.col(k) * VB.row(k);
    const ComplexMatrix P = -lambda * m.E.cast<Complex>() - m.A.cast<Complex>();
    const ComplexMatrix G = m.C.cast<Complex>() * P.partialPivLu().solve(m.B.cast<Complex>());
    sum += (G.transpose() * Rk).trace();
  }
  EXPECT_LT(std::abs(sum.imag()), 1e-10 * std::abs(sum.real()));
  return std::sqrt(sum.real());
}

class H2Residues : public ::testing::TestWithParam<const char*> {};

TEST_P(H2Residues, AgreesWithGramianFormula) {
  const ReducedModel dense = densify(load_model(kModels + GetParam()));
  const double by_gramian = h2_norm(dense);
  const double by_residues = h2_by_residues(first_order_realization(dense));
  std::printf("[ residues ] %s: ||G||_H2 = %.15g (Gramian), %.15g (residues), rel diff %.2e\n",
              GetParam(), by_gramian, by_residues, rel(by_gramian, by_residues));
  EXPECT_LT(rel(by_gramian, by_residues), 1e-8);
}

// Not here: lf10 (mass matrix of condition 2e6). This reference forms E^-1 A = [[0, I],
// [-M^-1 K, -M^-1 D]] and its eigenvectors, and disagrees with the Gramians by 4.3e-5 relative
// (measured); the Gramians work on the pencil without inverting M, so the reference is the
// suspect: the two M^-1-free routes agree with each other to 1.1e-9 on lf10
// (H2Quadrature.Lf10GramiansAgreeWithTheQuadrature).
INSTANTIATE_TEST_SUITE_P(SharedModels, H2Residues,
                         ::testing::Values("build", "cdplayer", "iss", "build_so", "iss_so", "beam",
                                           "random200"));

/// The band H2 norm squared, (1/pi) int_{w1}^{w2} ||G(i w)||_F^2 dw, from the modal expansion
/// G(s) = sum_k c_k b_k^T / (s - lambda_k) (Eigen's EigenSolver on E^-1 A, nothing of the
/// library): with 1 / ((i w - a)(-i w - conj b)) = -(1 / (a + conj b)) (1 / (i w - a) +
/// 1 / (-i w - conj b)) every pair integrates in closed form to logarithms (both arguments keep a
/// positive real part for stable poles, so the principal branch is continuous on the band).
double band_h2_squared_by_modes(const ReducedDescriptorModel& m, double w1, double w2) {
  const Eigen::PartialPivLU<Matrix> elu(m.E);
  const Eigen::EigenSolver<Matrix> es(Matrix(elu.solve(m.A)));
  const ComplexMatrix V = es.eigenvectors();
  const ComplexMatrix CV = m.C.cast<Complex>() * V;                       // columns c_k
  const ComplexMatrix VB = V.inverse() * elu.solve(m.B).cast<Complex>();  // rows b_k^T
  const ComplexMatrix CC = CV.adjoint() * CV, BB = VB.conjugate() * VB.transpose();
  const ComplexVector& lambda = es.eigenvalues();
  const Complex i(0.0, 1.0);
  Complex sum = 0.0;
  for (Index k = 0; k < V.cols(); ++k)
    for (Index l = 0; l < V.cols(); ++l) {
      const Complex a = lambda(l), bc = std::conj(lambda(k));
      const Complex integral = -i * (std::log(i * w2 - a) - std::log(i * w1 - a)) +
                               i * (std::log(-i * w2 - bc) - std::log(-i * w1 - bc));
      sum += CC(k, l) * BB(k, l) * (-integral / (a + bc));
    }
  EXPECT_LT(std::abs(sum.imag()), 1e-8 * std::abs(sum.real()));
  return sum.real() / kPi;
}

class BandH2Modes : public ::testing::TestWithParam<const char*> {};

// The band quadrature (h2_error_quadrature with options.band) against the modal closed form on a
// band around the median pole magnitude, [|lambda|_med / 3, 3 |lambda|_med].
TEST_P(BandH2Modes, QuadratureAgreesWithModalClosedForm) {
  const Model full = load_model(kModels + GetParam());
  const ReducedDescriptorModel dense = first_order_realization(densify(full));
  const ComplexVector p = poles(ReducedModel(dense));
  std::vector<double> mag;
  for (const Complex& z : p) mag.push_back(std::abs(z));
  std::nth_element(mag.begin(), mag.begin() + mag.size() / 2, mag.end());
  const double w_med = mag[mag.size() / 2];
  const Band band{w_med / 3.0 / kTwoPi, 3.0 * w_med / kTwoPi};
  const double ref =
      band_h2_squared_by_modes(dense, kTwoPi * band.f_min_hz, kTwoPi * band.f_max_hz);
  H2QuadratureOptions o;
  o.band = band;
  o.max_evaluations = 12000;
  const auto solver = make_shifted_solver(full);
  const H2Result q = h2_error_quadrature(full, *solver, nullptr, o);
  std::printf(
      "[ band h2  ] %s band [%.4g, %.4g] Hz: quadrature %.15g (%ld evals), modes %.15g, "
      "rel diff %.2e\n",
      GetParam(), band.f_min_hz, band.f_max_hz, q.integral, static_cast<long>(q.evaluations), ref,
      rel(q.integral, ref));
  EXPECT_TRUE(q.converged) << q.method;
  EXPECT_LT(rel(q.integral, ref), 1e-8) << q.method;
}

// Not here: lf10, for the reason given at H2Residues (measured: the quadrature, by sparse solves
// of the pencil, differs from this modal reference through M^-1 K by 3.2e-4 on its band).
INSTANTIATE_TEST_SUITE_P(SharedModels, BandH2Modes,
                         ::testing::Values("build", "cdplayer", "iss", "build_so", "iss_so"));

/// A stable reduced model of a benchmark model built here with Eigen:
///  * first order with unsymmetric A (build, cdplayer, iss): Galerkin projection onto the
///    invariant subspace of the r poles of smallest |lambda| (a modal truncation: the reduced
///    poles are exactly those poles);
///  * symmetric A, SPD E (rail): one-sided block Krylov [A^-1 B, A^-1 E A^-1 B] (V'EV SPD, V'AV
///    negative definite: stable);
///  * second order with SPD M, D, K (triple chain): Krylov [K^-1 B, (K^-1 M)^j K^-1 B] (stable).
ReducedModel reduced_for(const Model& full, const ReducedModel& dense, Index r) {
  Matrix V;
  if (const auto* s = std::get_if<ReducedSecondOrderModel>(&dense)) {
    const Eigen::PartialPivLU<Matrix> klu(s->K);
    Matrix X(s->size(), r);
    X.col(0) = klu.solve(s->B.col(0));
    for (Index j = 1; j < r; ++j) X.col(j) = klu.solve(Vector(s->M * X.col(j - 1)));
    V = Eigen::HouseholderQR<Matrix>(X).householderQ() * Matrix::Identity(X.rows(), r);
  } else {
    const auto& d = std::get<ReducedDescriptorModel>(dense);
    if (relative_asymmetry(d.A) == 0.0) {
      const Eigen::PartialPivLU<Matrix> alu(d.A);
      const Matrix X0 = alu.solve(d.B);
      Matrix X(d.size(), 2 * X0.cols());
      X << X0, alu.solve(Matrix(d.E * X0));
      V = Eigen::HouseholderQR<Matrix>(X).householderQ() * Matrix::Identity(X.rows(), X.cols());
    } else {
      const Eigen::EigenSolver<Matrix> es(Matrix(Eigen::PartialPivLU<Matrix>(d.E).solve(d.A)));
      std::vector<Index> idx(static_cast<std::size_t>(d.size()));
      for (Index i = 0; i < d.size(); ++i) idx[static_cast<std::size_t>(i)] = i;
      std::sort(idx.begin(), idx.end(), [&](Index a, Index b) {
        return std::abs(es.eigenvalues()(a)) < std::abs(es.eigenvalues()(b));
      });
      std::vector<Vector> cols;
      for (Index i : idx) {
        if (static_cast<Index>(cols.size()) >= r) break;
        const Complex lambda = es.eigenvalues()(i);
        if (lambda.imag() < 0.0) continue;  // its conjugate brings the pair
        cols.push_back(es.eigenvectors().col(i).real());
        if (lambda.imag() > 0.0) cols.push_back(es.eigenvectors().col(i).imag());
      }
      Matrix X(d.size(), static_cast<Index>(cols.size()));
      for (std::size_t j = 0; j < cols.size(); ++j) X.col(static_cast<Index>(j)) = cols[j];
      V = Eigen::HouseholderQR<Matrix>(X).householderQ() * Matrix::Identity(X.rows(), X.cols());
    }
  }
  return project(full, V, V);
}

struct QuadCase {
  const char* name;
  Index r;
  Index budget;  // max_evaluations: iss's 135 lightly damped modes need about 8000 (measured)
};

class H2Quadrature : public ::testing::TestWithParam<QuadCase> {};

// The quadrature's target is 1e-10 relative on the integral (about 5e-11 on the norm); the dense
// formula itself is accurate to about 1e-12 relative on ||G|| and loses log10(||G|| / ||G - Gr||)^2
// digits on the error (reduced models here have relative errors 1e-3..1e-1). 1e-8 relative
// therefore leaves room only for the rounding of the two methods.
TEST_P(H2Quadrature, AgreesWithDenseGramians) {
  const auto [name, r, budget] = GetParam();
  H2QuadratureOptions options;
  options.max_evaluations = budget;
  const Model full = load_model(kModels + name);
  const ReducedModel dense = densify(full);
  const ReducedModel red = reduced_for(full, dense, r);
  const auto t0 = std::chrono::steady_clock::now();
  const H2Comparison cmp = h2_compare(dense, red);
  const double norm = cmp.norm_a, err = cmp.error;
  const auto t1 = std::chrono::steady_clock::now();
  const auto solver = make_shifted_solver(full);
  const H2Result qn = h2_error_quadrature(full, *solver, nullptr, options);
  const auto t2 = std::chrono::steady_clock::now();
  const H2Result qe = h2_error_quadrature(full, *solver, &red, options);
  const auto t3 = std::chrono::steady_clock::now();
  const auto secs = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  std::printf(
      "[ quadrature ] %s (order %ld): ||G|| dense %.12g quad %.12g rel %.1e (%ld evals, %ld "
      "intervals, est %.1e, %s) | ||G-Gr|| dense %.12g quad %.12g rel %.1e (rel err %.1e; %ld "
      "evals, %ld intervals, est %.1e, %s) | dense %.2f s, quad %.2f + %.2f s\n",
      name, static_cast<long>(size_of(red)), norm, qn.value, rel(qn.value, norm),
      static_cast<long>(qn.evaluations), static_cast<long>(qn.intervals),
      qn.error_estimate / qn.value, qn.converged ? "converged" : "NOT converged", err, qe.value,
      rel(qe.value, err), err / norm, static_cast<long>(qe.evaluations),
      static_cast<long>(qe.intervals), qe.error_estimate / qe.value,
      qe.converged ? "converged" : "NOT converged", secs(t0, t1), secs(t1, t2), secs(t2, t3));
  // The reduced model is a real approximation, neither exact nor useless.
  EXPECT_GT(err / norm, 1e-4);
  EXPECT_LT(err / norm, 1.0);
  EXPECT_TRUE(qn.converged) << qn.method;
  EXPECT_TRUE(qe.converged) << qe.method;
  EXPECT_LT(rel(qn.value, norm), 1e-8) << qn.method;
  EXPECT_LT(rel(qe.value, err), 1e-8) << qe.method;
}

INSTANTIATE_TEST_SUITE_P(SharedModels, H2Quadrature,
                         ::testing::Values(QuadCase{"build", 10, 4000},
                                           QuadCase{"cdplayer", 16, 4000},
                                           QuadCase{"iss", 20, 12000},
                                           QuadCase{"rail_1357", 0, 4000},
                                           QuadCase{"triplechain_cmess_n301", 6, 4000}),
                         [](const auto& c) { return std::string(c.param.name); });

// lf10 (mass matrix of condition 2e6), which the residue and modal references above cannot check
// because they form M^-1 K: the two library routes that never invert M are independent of each
// other: the Gramians of the descriptor pencil (dense, generalised Lyapunov) and the quadrature of
// ||G(i w)||_F^2 by sparse solves of (K - w^2 M + i w D).
TEST(H2Quadrature, Lf10GramiansAgreeWithTheQuadrature) {
  const Model full = load_model(kModels + "lf10");
  const double by_gramian = h2_norm(densify(full));
  const auto solver = make_shifted_solver(full);
  H2QuadratureOptions options;
  const H2Result q = h2_error_quadrature(full, *solver, nullptr, options);
  std::printf(
      "[ quadrature ] lf10: ||G||_H2 = %.15g (Gramian), %.15g (quadrature, %ld evals), "
      "rel diff %.2e\n",
      by_gramian, q.value, static_cast<long>(q.evaluations), rel(by_gramian, q.value));
  EXPECT_TRUE(q.converged) << q.method;
  EXPECT_LT(rel(by_gramian, q.value), 1e-8);
}

TEST(H2Quadrature, BudgetExhaustedIsAResultNotAnError) {
  const Model full = load_model(kModels + "build");
  const auto solver = make_shifted_solver(full);
  H2QuadratureOptions o;
  o.max_evaluations = 30;
  o.initial_intervals = 1;
  const H2Result q = h2_error_quadrature(full, *solver, nullptr, o);
  EXPECT_FALSE(q.converged);
  EXPECT_LE(q.evaluations, 30);
  EXPECT_GT(q.error_estimate, 0.0);
}

TEST(H2Quadrature, BadOptionsAndInputsAreNamed) {
  const Model full = load_model(kModels + "build");
  const auto solver = make_shifted_solver(full);
  const auto config_msg = [&](auto change) {
    H2QuadratureOptions o;
    change(o);
    return message_of<ConfigError>([&] { h2_error_quadrature(full, *solver, nullptr, o); });
  };
  EXPECT_NE(config_msg([](auto& o) {
              o.relative_tolerance = 0.0;
            }).find("H2QuadratureOptions: relative_tolerance = 0: must be in (0, 1)"),
            std::string::npos);
  EXPECT_NE(config_msg([](auto& o) { o.absolute_tolerance = -1.0; }).find("absolute_tolerance"),
            std::string::npos);
  EXPECT_NE(config_msg([](auto& o) {
              o.max_evaluations = 14;
            }).find("max_evaluations = 14: must be >= 15"),
            std::string::npos);
  EXPECT_NE(config_msg([](auto& o) { o.scale_rad_s = -2.0; }).find("scale_rad_s = -2"),
            std::string::npos);
  EXPECT_NE(config_msg([](auto& o) { o.initial_intervals = 0; }).find("initial_intervals = 0"),
            std::string::npos);
  EXPECT_NE(config_msg([](auto& o) {
              o.breakpoints_rad_s = {1.0, -3.0};
            }).find("breakpoints_rad_s = -3"),
            std::string::npos);
  const ReducedDescriptorModel two_inputs = [] {
    ReducedDescriptorModel m = first_order(1.0, -1.0, 1.0, 1.0);
    m.B = Matrix::Ones(1, 2);
    return m;
  }();
  const ReducedModel r2 = two_inputs;
  EXPECT_NE(message_of<InputError>([&] {
              h2_error_quadrature(full, *solver, &r2);
            }).find("the reduced model has a 1 x 2 transfer matrix, the full model 1 x 1"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] {
              h2_error_norm(first_order(1.0, -1.0, 1.0, 1.0), two_inputs);
            }).find("1 x 1 and 1 x 2 transfer matrices"),
            std::string::npos);
  const ReducedModel unstable = first_order(1.0, 0.5, 1.0, 1.0);
  EXPECT_NE(message_of<InputError>([&] {
              h2_error_quadrature(full, *solver, &unstable);
            }).find("1 poles with Re >= 0 (largest real part 0.5)"),
            std::string::npos);
}

TEST(H2Refusals, UnstableModelsNameTheirPoles) {
  const std::string msg = message_of<InputError>([] { h2_norm(first_order(1.0, 2.0, 1.0, 1.0)); });
  EXPECT_NE(msg.find("H2 norm / Gramians undefined: the model has 1 poles with Re >= 0 (largest "
                     "real part 2)"),
            std::string::npos)
      << msg;
  // An undamped oscillator: poles on the imaginary axis (Re = 0 exactly).
  EXPECT_NE(message_of<InputError>([] {
              gramians(oscillator(1.0, 0.0, 4.0));
            }).find("2 poles with Re >= 0"),
            std::string::npos);
}

TEST(H2Refusals, PeecIsRefused) {
  // SLICOT peec: singular E (238 zero rows and columns), a DAE of index > 1. The shared README
  // reports finite eigenvalues with Re up to +1.7e12; with QZ converged and infinite eigenvalues
  // dropped at |beta| <= n eps ||E||_F (as ecmor::poles does), the 198 finite poles are all
  // stable (the one at +3.0e10 has |beta| = 6e-14 ||E||, below the threshold): peec is refused
  // for its singular E, and the message says so.
  const ReducedModel peec = densify(load_model(kModels + "peec"));
  const std::string msg = message_of<InputError>([&] { h2_norm(peec); });
  EXPECT_NE(msg.find("E is numerically singular"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not supported"), std::string::npos) << msg;
}

TEST(H2Refusals, MirroredIssIsUnstable) {
  // iss with A -> -A: every pole mirrored into the right half-plane (a real model, made
  // unstable): all 270 are named, with the largest real part equal to minus the smallest one of
  // iss itself.
  ReducedModel iss = densify(load_model(kModels + "iss"));
  auto& d = std::get<ReducedDescriptorModel>(iss);
  d.A = -d.A;
  const std::string msg = message_of<InputError>([&] { h2_norm(iss); });
  EXPECT_NE(msg.find("H2 norm / Gramians undefined: the model has 270 poles with Re >= 0 "
                     "(largest real part"),
            std::string::npos)
      << msg;
}

TEST(H2Refusals, SingularEIsNotSupported) {
  // A stable DAE: E = diag(1, 0), A = -I (one finite pole at -1).
  ReducedDescriptorModel m;
  m.E = Matrix::Zero(2, 2);
  m.E(0, 0) = 1.0;
  m.A = -Matrix::Identity(2, 2);
  m.B = Matrix::Ones(2, 1);
  m.C = Matrix::Ones(1, 2);
  const std::string msg = message_of<InputError>([&] { h2_norm(m); });
  EXPECT_NE(msg.find("E is numerically singular"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not supported"), std::string::npos) << msg;
}

TEST(H2Refusals, DensifyLimit) {
  DescriptorModel big;
  const Index n = kMaxDenseStates + 1;
  big.E = sparse(Matrix::Identity(1, 1));
  big.E.resize(n, n);
  big.E.setIdentity();
  big.A = -big.E;
  big.B = Matrix::Ones(n, 1);
  big.C = Matrix::Ones(1, n);
  EXPECT_NE(message_of<InputError>([&] {
              densify(big);
            }).find("the model has 6001 first-order states: at most kMaxDenseStates = 6000"),
            std::string::npos);
  SecondOrderModel so;
  so.M.resize(3001, 3001);
  so.M.setIdentity();
  so.D = so.M;
  so.K = so.M;
  so.B = Matrix::Ones(3001, 1);
  so.C = Matrix::Ones(1, 3001);
  EXPECT_NE(message_of<InputError>([&] { densify(so); }).find("6002 first-order states"),
            std::string::npos);
}

// Balanced truncation reference: stable, and ||G - Gr||_inf <= 2 * sum of the discarded Hankel
// singular values (Glover), on a dense frequency grid plus the poles' frequencies.
class BalancedTruncationReference : public ::testing::TestWithParam<const char*> {};

TEST_P(BalancedTruncationReference, HinfBoundAndStability) {
  const ReducedModel dense = densify(load_model(kModels + GetParam()));
  const Index r = 10;
  const test::BalancedTruncation bt = test::dense_balanced_truncation(dense, r);
  const double tail = bt.hankel.tail(bt.hankel.size() - r).sum();
  EXPECT_GT(bt.hankel(r - 1), bt.hankel(r));
  const ComplexVector p = poles(ReducedModel(bt.model));
  EXPECT_LT(p.real().maxCoeff(), 0.0);
  EXPECT_LT((bt.model.E - Matrix::Identity(r, r)).norm(), 1e-8);
  // Frequencies: a log grid over the model's whole range and the imaginary parts of its poles.
  std::vector<double> omega;
  for (int i = 0; i <= 3000; ++i) omega.push_back(std::pow(10.0, -3.0 + 10.0 * i / 3000.0));
  for (const Complex& z : poles(dense))
    if (z.imag() > 0.0) omega.push_back(z.imag());
  const ReducedResponse g(dense), gr{ReducedModel(bt.model)};
  double hinf = 0.0;
  for (double w : omega) {
    const ComplexMatrix e = g(Complex(0.0, w)) - gr(Complex(0.0, w));
    hinf = std::max(hinf, Eigen::JacobiSVD<ComplexMatrix>(e).singularValues()(0));
  }
  std::printf(
      "[ bt ] %s r = %ld: sampled ||G - Gr||_inf = %.6g <= 2 tail = %.6g (s_r %.3g, "
      "s_r+1 %.3g)\n",
      GetParam(), static_cast<long>(r), hinf, 2.0 * tail, bt.hankel(r - 1), bt.hankel(r));
  EXPECT_LE(hinf, 2.0 * tail);
  // The bound is not vacuous: the sampled error is at least the first discarded value s_{r+1}
  // (the H-infinity error of any order-r model is >= s_{r+1}).
  EXPECT_GE(hinf, bt.hankel(r) * (1.0 - 1e-3));
}

INSTANTIATE_TEST_SUITE_P(SharedModels, BalancedTruncationReference,
                         ::testing::Values("build", "cdplayer"));

}  // namespace
}  // namespace ecmor
