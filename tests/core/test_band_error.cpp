// Band error estimator against closed-form cases (seed Eqs. 20-23).
#include <gtest/gtest.h>

#include <cmath>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/measures/band_error.hpp"

namespace ecmor {
namespace {

// One mass-spring-damper: H(s) = 1 / (m s^2 + d s + k).
SecondOrderModel oscillator(double m, double d, double k) {
  SecondOrderModel s;
  auto one = [](double v) {
    SparseMatrix A(1, 1);
    A.insert(0, 0) = v;
    A.makeCompressed();
    return A;
  };
  s.M = one(m);
  s.D = one(d);
  s.K = one(k);
  s.B = Matrix::Ones(1, 1);
  s.C = Matrix::Ones(1, 1);
  return s;
}

// These tests are about the sampling itself: every sample a full-model response (dense mode). The
// estimate mode is tested in test_error_estimate.cpp.
BandErrorOptions dense_mode() {
  BandErrorOptions o;
  o.verify = ErrorVerify::Dense;
  return o;
}

ReducedSecondOrderModel dense(const SecondOrderModel& s) {
  ReducedSecondOrderModel r;
  r.M = Matrix(s.M);
  r.D = Matrix(s.D);
  r.K = Matrix(s.K);
  r.B = s.B;
  r.C = s.C;
  return r;
}

TEST(BandError, IdenticalModelsHaveZeroError) {
  const Model full = oscillator(1.0, 0.01, 4.0);
  auto solver = make_shifted_solver(full);
  ResponseCache cache(full, *solver);
  BandErrorEstimator est(cache, Band{0.01, 10.0}, dense_mode());
  const BandError e = est.evaluate(dense(std::get<SecondOrderModel>(full)));
  // Sparse (UMFPACK) and dense (LU) evaluations of the same H agree to round-off.
  EXPECT_LT(e.sup_relative, 1e-14);
  EXPECT_LT(e.hinf_absolute, 1e-14 * 100.0);  // |H| peaks at 1/(d w) = 50 at resonance
  EXPECT_TRUE(e.undefined_f_hz.empty());
}

// An undamped model (D = 0): H is singular at its resonance. Samples next to the pole must neither
// inflate the "H vanishes" threshold (which once discarded most of the band) nor break the run.
TEST(BandError, UndampedModelsAreHandled) {
  const Model full = oscillator(1.0, 0.0, 4.0);  // resonance at 1/pi Hz, inside the band
  auto solver = make_shifted_solver(full);
  ResponseCache cache(full, *solver);
  BandErrorEstimator est(cache, Band{0.01, 10.0}, dense_mode());
  const BandError same = est.evaluate(dense(std::get<SecondOrderModel>(full)));
  EXPECT_TRUE(same.undefined_f_hz.empty()) << same.sampling();
  EXPECT_LT(same.sup_relative, 1e-8);
  // A detuned reduced model: |H - Hr| / |H| = dk / |kr - w^2| has no finite supremum near the
  // reduced resonance; the estimator must report a large error there, not a small one.
  auto detuned = dense(std::get<SecondOrderModel>(full));
  detuned.K(0, 0) = 4.04;
  const BandError e = est.verify(detuned);
  EXPECT_GT(e.sup_relative, 1.0);
  EXPECT_NEAR(e.f_peak_hz, std::sqrt(4.04) / kTwoPi, 1e-3);
}

// A pole sample near a frequency the cache already holds (within zeta / 32) reuses it: a
// slightly moved reduced model costs no new full-model factorisation at its resonance.
TEST(BandError, PoleSamplesReuseNearbyCachedFrequencies) {
  const double m = 1.0, d = 0.02, k = 4.0;  // zeta = d / (2 sqrt(k m)) = 5e-3
  const Model full = oscillator(m, d, k);
  auto solver = make_shifted_solver(full);
  ResponseCache cache(full, *solver);
  BandErrorOptions no_refine;
  no_refine.verify = ErrorVerify::Dense;  // the dense mode's sampling is tested here
  no_refine.refine_peaks = 0;             // count pole samples alone
  BandErrorEstimator est(cache, Band{0.01, 10.0}, no_refine);
  auto reduced = dense(std::get<SecondOrderModel>(full));
  reduced.K(0, 0) = k * (1.0 + 1e-3);
  const BandError first = est.evaluate(reduced);
  ASSERT_EQ(first.pole_samples, 1);
  const Index after_first = cache.size();
  // The pole moves by 1e-5 relative (zeta / 500): the cached sample is reused.
  reduced.K(0, 0) = k * (1.0 + 1e-3) * (1.0 + 2e-5);
  const BandError near = est.evaluate(reduced);
  EXPECT_EQ(near.pole_samples, 1);
  EXPECT_EQ(cache.size(), after_first);
  // Moved by 1e-3 relative (zeta / 5): too far, sampled anew.
  reduced.K(0, 0) = k * (1.0 + 1e-3) * (1.0 + 2e-3);
  est.evaluate(reduced);
  EXPECT_EQ(cache.size(), after_first + 1);

  // nearest_cached itself: the nearest stored frequency within the relative distance, or none.
  const double f0 = first.f_hz.front();
  ASSERT_TRUE(cache.nearest_cached(f0 * (1.0 + 1e-9), 1e-8).has_value());
  EXPECT_EQ(*cache.nearest_cached(f0 * (1.0 + 1e-9), 1e-8), f0);
  EXPECT_FALSE(cache.nearest_cached(f0 * (1.0 + 1e-6), 1e-8).has_value());
}

// With light damping the relative error |dk| / |k_r - m w^2 + i d w| peaks in a resonance far
// narrower than the grid spacing; the pole samples and the refinement must find the true supremum.
TEST(BandError, LocalisesANarrowResonancePeak) {
  const double m = 1.0, d = 1e-4, k = 4.0, dk = 1e-3;
  const Model full = oscillator(m, d, k);
  auto reduced = dense(std::get<SecondOrderModel>(full));
  reduced.K(0, 0) = k + dk;
  // Exact supremum: H - Hr = dk / (P Pr) and |H - Hr| / |H| = dk / |Pr(i w)|; minimise |Pr| in w
  // by a dense scan plus the closed-form stationary point of |Pr|^2 in w^2.
  const double kr = k + dk;
  const double w2 = kr / m - d * d / (2.0 * m * m);
  const double min_pr = std::sqrt(std::pow(kr - m * w2, 2) + d * d * w2);
  const double exact_sup = dk / min_pr;

  auto solver = make_shifted_solver(full);
  ResponseCache cache(full, *solver);
  BandErrorOptions grid_only;
  grid_only.verify = ErrorVerify::Dense;  // the dense mode's sampling is tested here
  grid_only.pole_samples = false;
  grid_only.refine_peaks = 0;
  BandErrorEstimator coarse(cache, Band{0.01, 10.0}, grid_only);
  const BandError plain = coarse.evaluate(reduced);
  // A plain 200-point grid misses the peak by orders of magnitude (this is why we refine).
  EXPECT_LT(plain.sup_relative, 0.1 * exact_sup);

  BandErrorEstimator est(cache, Band{0.01, 10.0}, dense_mode());
  const BandError e = est.evaluate(reduced);
  EXPECT_NEAR(e.sup_relative, exact_sup, 1e-6 * exact_sup);
  EXPECT_NEAR(e.f_peak_hz, std::sqrt(w2) / kTwoPi, 1e-6 * std::sqrt(w2) / kTwoPi);

  // Without pole samples the golden-section refinement alone still has to climb the peak from the
  // nearest grid maximum; it gets within a factor that the pole samples then close.
  BandErrorOptions refine_only;
  refine_only.verify = ErrorVerify::Dense;  // the dense mode's sampling is tested here
  refine_only.pole_samples = false;
  refine_only.refine_evaluations = 60;
  BandErrorEstimator est2(cache, Band{0.01, 10.0}, refine_only);
  EXPECT_NEAR(est2.evaluate(reduced).sup_relative, exact_sup, 1e-3 * exact_sup);
}

// verify_near on the narrow resonance above, with the full model itself as the neighbour (so the
// departure is the candidate's true relative error): the re-check's own grid misses the peak, one
// full solve at the departure's refined maximum finds it exactly, and a tolerance the triangle
// bound settles costs no solve at all.
TEST(BandError, VerifyNearSolvesAtTheDeparturePeaksWithinItsBudget) {
  const double m = 1.0, d = 1e-4, k = 4.0, dk = 1e-3;
  const Model full = oscillator(m, d, k);
  const ReducedSecondOrderModel neighbour = dense(std::get<SecondOrderModel>(full));
  ReducedSecondOrderModel candidate = neighbour;
  candidate.K(0, 0) = k + dk;
  const double kr = k + dk;
  const double w2 = kr / m - d * d / (2.0 * m * m);
  const double exact_sup = dk / std::sqrt(std::pow(kr - m * w2, 2) + d * d * w2);
  auto check = [&](double tolerance, Index budget) {
    auto solver = make_shifted_solver(full);
    ResponseCache cache(full, *solver);
    BandErrorEstimator est(cache, Band{0.01, 10.0}, dense_mode());
    est.verify(neighbour, 4);  // as the neighbour was: verify()'s grid is solved
    const Index before = cache.size();
    BandError e = est.verify_near(candidate, neighbour, 0.0, tolerance, 4, budget);
    EXPECT_EQ(e.new_full_solves, cache.size() - before);
    return e;
  };
  const BandError blind = check(1e-6, 0);
  EXPECT_EQ(blind.new_full_solves, 0);
  EXPECT_LT(blind.sup_relative, 0.1 * exact_sup) << "verify()'s grid alone misses the peak";
  const BandError found = check(1e-6, 3);
  EXPECT_EQ(found.new_full_solves, 1) << "one departure maximum above the bound";
  EXPECT_NEAR(found.sup_relative, exact_sup, 1e-6 * exact_sup);
  EXPECT_FALSE(found.within(1e-6));
  const BandError settled = check(10.0 * exact_sup, 3);
  EXPECT_EQ(settled.new_full_solves, 0) << "e_n + (1 + e_n) d <= tolerance everywhere";
  EXPECT_TRUE(settled.within(10.0 * exact_sup));

  auto solver = make_shifted_solver(full);
  ResponseCache cache(full, *solver);
  BandErrorEstimator est(cache, Band{0.01, 10.0}, dense_mode());
  EXPECT_THROW(est.verify_near(candidate, neighbour, 0.0, 1e-3, 0, 1), ConfigError);
  EXPECT_THROW(est.verify_near(candidate, neighbour, 0.0, 1e-3, 4, -1), ConfigError);
  EXPECT_THROW(est.verify_near(candidate, neighbour, 0.0, 0.0, 4, 1), ConfigError);
}

// H = diag(1/(s + a1), 1/(s + a2)); the reduced model keeps the first state only, so
// H - Hr = diag(0, 1/(s + a2)): spectral and Frobenius relative errors in closed form.
struct DiagonalCase {
  double a1 = 1.0, a2 = 30.0;
  DescriptorModel full() const {
    DescriptorModel m;
    m.E = SparseMatrix(2, 2);
    m.E.setIdentity();
    m.A = SparseMatrix(2, 2);
    m.A.insert(0, 0) = -a1;
    m.A.insert(1, 1) = -a2;
    m.A.makeCompressed();
    m.B = Matrix::Identity(2, 2);
    m.C = Matrix::Identity(2, 2);
    return m;
  }
  ReducedDescriptorModel reduced() const {
    ReducedDescriptorModel r;
    r.E = Matrix::Ones(1, 1);
    r.A = -a1 * Matrix::Ones(1, 1);
    r.B = Matrix::Zero(1, 2);
    r.B(0, 0) = 1.0;
    r.C = Matrix::Zero(2, 1);
    r.C(0, 0) = 1.0;
    return r;
  }
};

TEST(BandError, SpectralAndFrobeniusRelativeErrorsMatchClosedForm) {
  const DiagonalCase c;
  const Model full = c.full();
  auto solver = make_shifted_solver(full);
  ResponseCache cache(full, *solver);
  BandErrorEstimator est(cache, Band{0.01, 100.0}, dense_mode());
  const BandError e = est.evaluate(c.reduced());
  ASSERT_GE(e.f_hz.size(), 200u);
  for (std::size_t k = 0; k < e.f_hz.size(); ++k) {
    const double w = kTwoPi * e.f_hz[k];
    const double g1 = 1.0 / std::hypot(w, c.a1), g2 = 1.0 / std::hypot(w, c.a2);
    EXPECT_NEAR(e.relative_spectral[k], g2 / std::max(g1, g2), 1e-12);
    EXPECT_NEAR(e.relative_frobenius[k], g2 / std::hypot(g1, g2), 1e-12);
    EXPECT_NEAR(e.absolute[k], g2, 1e-12 * g2);
  }
  // eps2 = g2/g1 = |s + a1| / |s + a2| grows to 1 at f_max: the supremum is at the band edge.
  const double w = kTwoPi * 100.0;
  EXPECT_NEAR(e.sup_relative, std::hypot(w, c.a1) / std::hypot(w, c.a2), 1e-12);
  EXPECT_DOUBLE_EQ(e.f_peak_hz, 100.0);
}

TEST(BandError, BandH2MatchesTheIntegralInClosedForm) {
  const DiagonalCase c;
  const Model full = c.full();
  auto solver = make_shifted_solver(full);
  ResponseCache cache(full, *solver);
  BandErrorOptions fine;
  fine.verify = ErrorVerify::Dense;  // the dense mode's sampling is tested here
  fine.grid_points = 20000;
  fine.pole_samples = false;
  fine.refine_peaks = 0;
  const double f0 = 0.01, f1 = 100.0;
  BandErrorEstimator est(cache, Band{f0, f1}, fine);
  const BandError e = est.evaluate(c.reduced());
  // ||E||_F^2 = 1/(w^2 + a2^2); 2 * int_f0^f1 df / (4 pi^2 f^2 + a2^2)
  //   = 2 / (2 pi a2) * [atan(2 pi f / a2)]_f0^f1.
  const double exact_sq =
      2.0 / (kTwoPi * c.a2) * (std::atan(kTwoPi * f1 / c.a2) - std::atan(kTwoPi * f0 / c.a2));
  EXPECT_NEAR(e.h2_absolute, std::sqrt(exact_sq), 1e-6 * std::sqrt(exact_sq));
}

// H(s) = (s^2 + w0^2) / ((s + 1)(s + 2)(s + 3)) vanishes at f0 = w0 / 2pi on the band.
TEST(BandError, ReportsWhereTheRelativeErrorIsUndefined) {
  const double w0 = kTwoPi * 1.0;
  DescriptorModel m;  // controllable canonical form of the transfer function above
  m.E = SparseMatrix(3, 3);
  m.E.setIdentity();
  Matrix A = Matrix::Zero(3, 3);
  A(0, 1) = 1.0;
  A(1, 2) = 1.0;
  A(2, 0) = -6.0;
  A(2, 1) = -11.0;
  A(2, 2) = -6.0;
  m.A = A.sparseView();
  m.B = Matrix::Zero(3, 1);
  m.B(2, 0) = 1.0;
  m.C = Matrix::Zero(1, 3);
  m.C(0, 0) = w0 * w0;
  m.C(0, 2) = 1.0;
  const Model full = m;
  auto solver = make_shifted_solver(full);
  ResponseCache cache(full, *solver);
  BandErrorOptions opt;
  opt.verify = ErrorVerify::Dense;  // the dense mode's sampling is tested here
  opt.grid_points = 3;              // 0.1, 1, 10 Hz: the zero sits on the grid
  opt.refine_peaks = 0;
  opt.zero_threshold = 1e-10;
  BandErrorEstimator est(cache, Band{0.1, 10.0}, opt);
  ReducedDescriptorModel r;
  r.E = Matrix(m.E);
  r.A = A;
  r.A(2, 2) = -6.5;  // perturbed
  r.B = m.B;
  r.C = m.C;
  const BandError e = est.evaluate_on(r, {0.1, 1.0, 10.0});
  ASSERT_EQ(e.undefined_f_hz.size(), 1u);
  EXPECT_NEAR(e.undefined_f_hz[0], 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(e.relative[1]));
  EXPECT_TRUE(std::isfinite(e.sup_relative));
  EXPECT_NE(e.sampling().find("H vanishes"), std::string::npos);
}

TEST(BandError, VerifyGridIsDenserAndSharesNoInteriorFrequency) {
  const Model full = oscillator(1.0, 0.1, 4.0);
  auto solver = make_shifted_solver(full);
  ResponseCache cache(full, *solver);
  BandErrorOptions opt;
  opt.verify = ErrorVerify::Dense;  // the dense mode's sampling is tested here
  opt.grid_points = 50;
  opt.pole_samples = false;
  opt.refine_peaks = 0;
  BandErrorEstimator est(cache, Band{0.01, 10.0}, opt);
  auto reduced = dense(std::get<SecondOrderModel>(full));
  reduced.K(0, 0) *= 1.01;
  const BandError v = est.verify(reduced, 4);
  EXPECT_EQ(v.grid_samples, 4 * 49 + 2);
  std::size_t shared = 0;
  for (double f : v.f_hz) {
    for (double g : est.grid()) {
      if (std::abs(f - g) <= 1e-9 * g) ++shared;
    }
  }
  EXPECT_EQ(shared, 2u);  // only the band edges
}

TEST(BandError, InvalidBandAndOptionsAreNamed) {
  try {
    Band{-1.0, 10.0}.validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("f_min_hz = -1"), std::string::npos);
  }
  try {
    Band{10.0, 1.0}.validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("f_max_hz"), std::string::npos);
  }
  EXPECT_THROW(Band({1.0, 1.0}).validate(), ConfigError);  // zero-width band
  BandErrorOptions o;
  o.grid_points = 1;
  try {
    o.validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("grid_points = 1"), std::string::npos);
  }
  EXPECT_THROW(parse_error_norm("spectrall"), ConfigError);
  EXPECT_EQ(parse_error_norm("frobenius"), ErrorNorm::Frobenius);
}

}  // namespace
}  // namespace ecmor
