// Adaptive matrix quadrature, the band integrals of the resolvent, band_pole_integral and the band
// H2 option of h2_error_quadrature, against analytic values and dense eigendecompositions.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>
#include <filesystem>
#include <iostream>

#include "ecmor/base/error.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/gramians/quadrature.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/measures/h2_norm.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/model/model_io.hpp"

namespace ecmor {
namespace {

TEST(IntegrateAdaptive, MatchesAnalyticIntegralsOfAMatrixFunction) {
  const MatrixIntegrand f = [](const std::vector<double>& x) {
    std::vector<Matrix> out;
    for (double t : x) {
      Matrix m(2, 2);
      m << std::exp(t), 1.0 / (1.0 + t * t), std::sin(10.0 * t), std::pow(t, 5);
      out.push_back(m);
    }
    return out;
  };
  AdaptiveQuadratureOptions o;
  o.relative_tolerance = 1e-12;
  const MatrixQuadrature q = integrate_adaptive(f, 0.0, 3.0, o);
  Matrix exact(2, 2);
  exact << std::exp(3.0) - 1.0, std::atan(3.0), (1.0 - std::cos(30.0)) / 10.0,
      std::pow(3.0, 6) / 6.0;
  EXPECT_TRUE(q.converged);
  EXPECT_LT((q.integral - exact).norm(), 1e-11 * exact.norm());
  // The returned rule integrates the same function to the same value.
  Matrix again = Matrix::Zero(2, 2);
  const std::vector<Matrix> values = f(q.nodes);
  for (std::size_t k = 0; k < q.nodes.size(); ++k) again += q.weights[k] * values[k];
  EXPECT_LT((again - q.integral).norm(), 1e-13 * exact.norm());
}

TEST(IntegrateAdaptive, ReportsAnExhaustedBudgetAsNotConverged) {
  // 1 / sqrt(x) on [1e-12, 1]: the endpoint singularity needs far more than 45 nodes.
  const MatrixIntegrand f = [](const std::vector<double>& x) {
    std::vector<Matrix> out;
    for (double t : x) out.push_back(Matrix::Constant(1, 1, 1.0 / std::sqrt(t)));
    return out;
  };
  AdaptiveQuadratureOptions o;
  o.max_evaluations = 45;
  o.initial_intervals = 1;
  const MatrixQuadrature q = integrate_adaptive(f, 1e-12, 1.0, o);
  EXPECT_FALSE(q.converged);
  EXPECT_LE(q.evaluations, 45);
  EXPECT_GT(q.error_estimate, o.relative_tolerance * q.integral.norm());
}

TEST(IntegrateAdaptive, NamesBadInput) {
  const MatrixIntegrand nan = [](const std::vector<double>& x) {
    return std::vector<Matrix>(x.size(), Matrix::Constant(1, 1, std::nan("")));
  };
  try {
    integrate_adaptive(nan, 0.0, 1.0);
    FAIL() << "no error for a NaN integrand";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not finite at x ="), std::string::npos) << e.what();
  }
  AdaptiveQuadratureOptions o;
  o.max_evaluations = 10;
  try {
    integrate_adaptive(nan, 0.0, 1.0, o);
    FAIL() << "no error for max_evaluations = 10";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("max_evaluations"), std::string::npos) << e.what();
  }
  EXPECT_THROW(integrate_adaptive(nan, 1.0, 1.0), ConfigError);
}

TEST(BandPoleIntegral, MatchesQuadratureAndRefusesTheLeftHalfPlane) {
  const Band band{0.5, 20.0};
  for (const Complex s : {Complex(3.0, 0.0), Complex(0.4, 25.0), Complex(2.0, -60.0)}) {
    // integral over [w1, w2] and its mirror of 1 / (s - i w), real and imaginary parts.
    const MatrixIntegrand f = [&](const std::vector<double>& x) {
      std::vector<Matrix> out;
      for (double w : x) {
        const Complex v = 1.0 / (s - Complex(0.0, w)) + 1.0 / (s + Complex(0.0, w));
        out.push_back((Matrix(1, 2) << v.real(), v.imag()).finished());
      }
      return out;
    };
    AdaptiveQuadratureOptions o;
    o.relative_tolerance = 1e-13;
    const Matrix q =
        integrate_adaptive(f, kTwoPi * band.f_min_hz, kTwoPi * band.f_max_hz, o).integral;
    const Complex beta = band_pole_integral(s, band);
    EXPECT_NEAR(beta.real(), q(0, 0), 1e-11 * std::abs(beta));
    EXPECT_NEAR(beta.imag(), q(0, 1), 1e-11 * std::abs(beta));
  }
  EXPECT_THROW(band_pole_integral(Complex(0.0, 10.0), band), InputError);
}

/// L_B and L_C from the dense pencil's eigendecomposition: with E^-1 A = X diag(lambda) X^-1,
/// integral_{w1}^{w2} (i w E - A)^-1 dw = X diag(-i (log(i w2 - lambda) - log(i w1 - lambda)))
/// X^-1 E^-1 (principal logarithm: Re(i w - lambda) > 0 for stable lambda, no branch crossing).
void expect_band_integrals_match_dense(const Model& model, const Band& band) {
  const ReducedDescriptorModel fo = first_order_realization(densify(model));
  const Eigen::PartialPivLU<Matrix> elu(fo.E);
  const Matrix F = elu.solve(fo.A);
  const Eigen::ComplexEigenSolver<ComplexMatrix> es(F.cast<Complex>());
  const ComplexMatrix& X = es.eigenvectors();
  const Eigen::PartialPivLU<ComplexMatrix> xlu(X);
  ComplexVector d(F.rows());
  const double w1 = kTwoPi * band.f_min_hz, w2 = kTwoPi * band.f_max_hz;
  for (Index k = 0; k < d.size(); ++k) {
    const Complex l = es.eigenvalues()(k);
    d(k) = Complex(0.0, -1.0) * (std::log(Complex(0.0, w2) - l) - std::log(Complex(0.0, w1) - l));
  }
  const ComplexMatrix R = X * d.asDiagonal() * xlu.inverse();  // integral of (i w - F)^-1
  const Matrix LB = 2.0 * (R * elu.solve(fo.B).cast<Complex>()).real();
  // (i w E - A)^-T C' = E^-T (i w - F)^-T C'.
  const Eigen::PartialPivLU<Matrix> etlu(fo.E.transpose());
  const Matrix LC =
      2.0 * etlu.solve(Matrix((R.transpose() * fo.C.transpose().cast<Complex>()).real()));

  auto solver = make_shifted_solver(model);
  FirstOrderView view(model, *solver);
  AdaptiveQuadratureOptions o;
  o.relative_tolerance = 1e-10;
  o.max_evaluations = 20000;
  const BandResolventIntegrals q = band_resolvent_integrals(view, band, o);
  ASSERT_TRUE(q.quadrature.converged);
  std::cout << "[ band-integrals ] " << q.quadrature.evaluations << " nodes on " << q.variable
            << ": relative difference L_B " << (q.input - LB).norm() / LB.norm() << ", L_C "
            << (q.output - LC).norm() / LC.norm() << "\n";
  // Quadrature at 1e-10 (measured 1e-12) against an eigenvector basis of modest conditioning.
  EXPECT_LT((q.input - LB).norm(), 1e-9 * LB.norm());
  EXPECT_LT((q.output - LC).norm(), 1e-9 * LC.norm());
}

TEST(BandResolventIntegrals, MatchTheDenseEigendecompositionOnBuild) {
  expect_band_integrals_match_dense(load_model("models/build"), Band{0.5, 20.0});
}

TEST(BandResolventIntegrals, MatchTheDenseEigendecompositionOnASecondOrderChain) {
  expect_band_integrals_match_dense(load_model("models/triplechain_cmess_n301"), Band{0.01, 0.3});
}

TEST(BandH2, QuadratureMatchesTheAnalyticBandNormOfAFirstOrderLag) {
  // G(s) = c / (s + a): ||G||^2 over the band = c^2 (atan(w2 / a) - atan(w1 / a)) / (pi a).
  const double a = 3.0, c = 2.0;
  DescriptorModel m;
  m.E = SparseMatrix(1, 1);
  m.E.insert(0, 0) = 1.0;
  m.A = SparseMatrix(1, 1);
  m.A.insert(0, 0) = -a;
  m.B = Matrix::Constant(1, 1, 1.0);
  m.C = Matrix::Constant(1, 1, c);
  const Model model(m);
  const Band band{0.1, 2.0};
  const double w1 = kTwoPi * band.f_min_hz, w2 = kTwoPi * band.f_max_hz;
  const double exact = c * c * (std::atan(w2 / a) - std::atan(w1 / a)) / (kPi * a);
  auto solver = make_shifted_solver(model);
  H2QuadratureOptions o;
  o.band = band;
  const H2Result q = h2_error_quadrature(model, *solver, nullptr, o);
  EXPECT_TRUE(q.converged);
  EXPECT_NEAR(q.integral, exact, 1e-10 * exact);
  // The band integrals' own rule gives the same norm.
  FirstOrderView view(model, *solver);
  const BandResolventIntegrals bi = band_resolvent_integrals(view, band);
  EXPECT_NEAR(band_h2_squared_error(bi, nullptr), exact, 1e-8 * exact);
  o.band = Band{2.0, 1.0};
  EXPECT_THROW(h2_error_quadrature(model, *solver, nullptr, o), ConfigError);
}

}  // namespace
}  // namespace ecmor
