// The estimate mode of the band error (band_error.hpp, reference_model.hpp): a reference model
// grown from full solves stands in for H where the full model was not solved. Checked against the
// dense mode (a full solve per sample) on a triple chain and an RC ladder, and for its cost.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "../../bench/triple_chain.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/response/reference_model.hpp"

namespace ecmor {
namespace {

double relative_difference(const ComplexMatrix& a, const ComplexMatrix& b) {
  return (a - b).norm() / b.norm();
}

// A candidate of order ~2k: the Galerkin projection onto P(s_j)^-1 B at k log-spaced points
// (real and imaginary parts), i.e. what a multipoint Krylov reducer would build.
ReducedModel krylov_candidate(const Model& model, ShiftedSolver& solver, const Band& band,
                              Index points) {
  Matrix V(size_of(model), 0);
  for (double f : log_grid(band.f_min_hz, band.f_max_hz, points)) {
    const auto P = solver.factorize(s_from_hz(f));
    const Matrix& B = std::visit([](const auto& m) -> const Matrix& { return m.B; }, model);
    const ComplexMatrix X = P->solve(ComplexMatrix(B.cast<Complex>()));
    Matrix parts(X.rows(), 2 * X.cols());
    parts << X.real(), X.imag();
    orthonormalize_append(V, parts);
  }
  return project(model, V, V);
}

// Three chains of 50 masses (N = 151), lightly damped; its band holds ~ a dozen resonances.
Model chain() { return bench::triple_chain(50, 0.002, 0.002, 0.5); }

// RC ladder: E = diag(c), A = tridiagonal conductances with a leak to ground (a stable, symmetric
// negative definite descriptor model); input current at node 1, output its voltage.
Model rc_ladder(Index n) {
  DescriptorModel d;
  std::vector<Eigen::Triplet<double>> e, a;
  for (Index i = 0; i < n; ++i) {
    e.emplace_back(i, i, 1e-3 * (1.0 + 0.5 * std::sin(static_cast<double>(i))));
    a.emplace_back(i, i, -(i == 0 || i == n - 1 ? 1.0 : 2.0) - 1e-3);
    if (i + 1 < n) {
      a.emplace_back(i, i + 1, 1.0);
      a.emplace_back(i + 1, i, 1.0);
    }
  }
  d.E.resize(n, n);
  d.E.setFromTriplets(e.begin(), e.end());
  d.A.resize(n, n);
  d.A.setFromTriplets(a.begin(), a.end());
  d.B = Matrix::Zero(n, 1);
  d.B(0, 0) = 1.0;
  d.C = Matrix::Zero(1, n);
  d.C(0, 0) = 1.0;  // driving-point voltage: |H| stays well above round-off over the band
  return d;
}

BandErrorOptions options(ErrorVerify mode) {
  BandErrorOptions o;
  o.verify = mode;
  return o;
}

// The reference model is exact where the full model was solved (interpolation), for both kinds.
TEST(ReferenceModel, InterpolatesTheFullModelWhereItWasSolved) {
  for (const Model& model : {chain(), rc_ladder(120)}) {
    auto solver = make_shifted_solver(model);
    ReferenceModel reference(model);
    const std::vector<double> f = {1e-3, 0.05, 0.3};
    Matrix V(size_of(model), 0);  // the same space, built independently
    for (double fj : f) {
      const auto P = solver->factorize(s_from_hz(fj));
      const Matrix& B = std::visit([](const auto& m) -> const Matrix& { return m.B; }, model);
      const ComplexMatrix X = P->solve(ComplexMatrix(B.cast<Complex>()));
      EXPECT_GT(reference.add(X), 0);
      Matrix parts(X.rows(), 2 * X.cols());
      parts << X.real(), X.imag();
      orthonormalize_append(V, parts);
    }
    EXPECT_EQ(reference.version(), 3);
    for (double fj : f) {
      const ComplexMatrix H = transfer_function(model, *solver, s_from_hz(fj));
      const ComplexMatrix Hr = transfer_function(reference.reduced(), s_from_hz(fj));
      EXPECT_LT(relative_difference(Hr, H), 1e-9) << to_string(kind_of(model)) << " at " << fj;
    }
    // The incrementally extended projection equals a projection from scratch on the same space:
    // compare the transfer functions away from the interpolation points.
    ASSERT_EQ(V.cols(), reference.order());
    const ReducedModel scratch = project(model, V, V);
    for (double fk : {2e-3, 0.1, 0.7}) {
      EXPECT_LT(relative_difference(transfer_function(reference.reduced(), s_from_hz(fk)),
                                    transfer_function(scratch, s_from_hz(fk))),
                1e-8)
          << fk;
    }
    const Index before = reference.order();
    EXPECT_EQ(reference.add(Matrix(Matrix::Zero(size_of(model), 1))), 0);  // deflated
    EXPECT_EQ(reference.order(), before);
  }
}

// A column offered again, bit for bit, is skipped (it is in the span already): offering a
// candidate's whole basis after its first blocks gives the same reference, bit for bit, as
// offering only its new columns, and offering the same basis twice changes nothing.
TEST(ReferenceModel, AColumnOfferedAgainIsSkippedAndTheNewOnesAreAdded) {
  const Model model = chain();
  auto solver = make_shifted_solver(model);
  const Matrix& B = std::get<SecondOrderModel>(model).B;
  auto parts_at = [&](double f) {
    const ComplexMatrix X =
        solver->factorize(s_from_hz(f))->solve(ComplexMatrix(B.cast<Complex>()));
    Matrix parts(X.rows(), 2 * X.cols());
    parts << X.real(), X.imag();
    return parts;
  };
  const Matrix X1 = parts_at(0.01), X2 = parts_at(0.2);
  Matrix X12(X1.rows(), X1.cols() + X2.cols());
  X12 << X1, X2;
  Matrix X21(X1.rows(), X1.cols() + X2.cols());  // the old columns after the new ones
  X21 << X2, X1;

  ReferenceModel whole(model), fresh(model), reordered(model);
  ASSERT_EQ(whole.add(X1), 2);
  ASSERT_EQ(fresh.add(X1), 2);
  ASSERT_EQ(reordered.add(X1), 2);
  EXPECT_EQ(whole.add(X1), 0);  // the same basis again: nothing added, same version
  EXPECT_EQ(whole.version(), 1);
  EXPECT_EQ(whole.add(X12), 2);
  EXPECT_EQ(fresh.add(X2), 2);
  EXPECT_EQ(reordered.add(X21), 2);
  for (const ReferenceModel* r : {&whole, &reordered}) {
    EXPECT_EQ(r->version(), fresh.version());
    ASSERT_EQ(r->order(), fresh.order());
    const auto& a = std::get<ReducedSecondOrderModel>(r->reduced());
    const auto& b = std::get<ReducedSecondOrderModel>(fresh.reduced());
    EXPECT_TRUE((a.K.array() == b.K.array()).all());
    EXPECT_TRUE((a.M.array() == b.M.array()).all());
    EXPECT_TRUE((a.D.array() == b.D.array()).all());
    EXPECT_TRUE((a.B.array() == b.B.array()).all());
    EXPECT_TRUE((a.C.array() == b.C.array()).all());
  }
  // A basis refused for a NaN leaves its good columns to be offered again.
  ReferenceModel refused(model);
  Matrix with_nan(X1.rows(), 2);
  with_nan << X1.col(0), X1.col(1);
  with_nan(3, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(refused.add(with_nan), NumericalError);
  EXPECT_EQ(refused.add(Matrix(X1.col(0))), 1);
  // A column that differs from an offered one in a single bit is new: orthogonalised, deflated.
  Matrix nudged = X1.col(0);
  nudged(0, 0) = std::nextafter(nudged(0, 0), 1e300);
  EXPECT_EQ(whole.add(nudged), 0);
  EXPECT_EQ(whole.order(), fresh.order());
}

TEST(ReferenceModel, RefusesABasisOfTheWrongSize) {
  const Model model = chain();
  ReferenceModel reference(model);
  try {
    reference.add(Matrix(Matrix::Ones(10, 2)));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("10 rows"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("N = 151"), std::string::npos) << e.what();
  }
}

// The certified value of the estimate mode is a true error (measured against the full model at a
// frequency it solved), and it does not fall short of the dense mode's supremum by more than the
// documented factor 2 (docs/error-measures.md); it costs a fraction of the dense mode's solves.
TEST(EstimateMode, AgreesWithTheDenseModeAtAFractionOfTheSolves) {
  struct Case {
    Model model;
    Band band;
    Index points;
  };
  const std::vector<Case> cases = {{chain(), Band{1e-3, 0.4}, 6},
                                   {chain(), Band{1e-3, 0.4}, 12},
                                   {rc_ladder(200), Band{1e-2, 1e2}, 3},
                                   {rc_ladder(200), Band{1e-2, 1e2}, 6}};
  for (const Case& c : cases) {
    auto solver = make_shifted_solver(c.model);
    const ReducedModel candidate = krylov_candidate(c.model, *solver, c.band, c.points);

    auto dense_solver = make_shifted_solver(c.model);
    ResponseCache dense_cache(c.model, *dense_solver);
    BandErrorEstimator dense(dense_cache, c.band, options(ErrorVerify::Dense));
    const BandError truth = dense.verify(candidate, 4);

    auto estimate_solver = make_shifted_solver(c.model);
    ResponseCache cache(c.model, *estimate_solver);
    BandErrorEstimator estimate(cache, c.band, options(ErrorVerify::Estimate));
    ASSERT_EQ(estimate.mode(), ErrorVerify::Estimate);
    const BandError guess = estimate.evaluate(candidate);
    const BandError checked = estimate.verify(candidate, 4);
    const std::string what = to_string(kind_of(c.model)) + " with " + std::to_string(c.points) +
                             " points: dense " + std::to_string(truth.sup_relative) +
                             ", estimate " + std::to_string(guess.sup_relative) + ", checked " +
                             std::to_string(checked.sup_relative) + "; " + checked.sampling();
    EXPECT_GE(guess.sup_relative, 0.5 * truth.sup_relative) << what;
    EXPECT_GE(checked.sup_relative, 0.5 * truth.sup_relative) << what;
    EXPECT_FALSE(checked.estimated) << what;
    // The reported value is the true error at its frequency: recompute it there independently.
    const ComplexMatrix H = transfer_function(c.model, *solver, s_from_hz(checked.f_peak_hz));
    const ComplexMatrix Hr = transfer_function(candidate, s_from_hz(checked.f_peak_hz));
    EXPECT_NEAR(matrix_norm(H - Hr, ErrorNorm::Spectral) / matrix_norm(H, ErrorNorm::Spectral),
                checked.sup_relative, 1e-6 * checked.sup_relative + 1e-14)
        << what;
    // Cost: the seeds, the probe and the checks, against a full solve per dense sample.
    const BandErrorOptions o = options(ErrorVerify::Estimate);
    const Index budget =
        o.reference_points + o.probe_solves + o.random_checks + o.check_peaks * o.check_rounds;
    EXPECT_LE(cache.size(), budget) << what;
    EXPECT_GT(dense_cache.size(), 5 * budget) << what;
    EXPECT_GT(checked.checked_samples, o.reference_points) << what;
  }
}

// A model that meets a tolerance by the estimate is re-checked against the full model; a
// candidate that is exact (the full model itself, projected on the identity) has zero error.
TEST(EstimateMode, TheFullModelProjectedOnItselfHasNoError) {
  const Model model = rc_ladder(40);
  auto solver = make_shifted_solver(model);
  ResponseCache cache(model, *solver);
  BandErrorEstimator estimate(cache, Band{1e-2, 1e2}, options(ErrorVerify::Estimate));
  const Matrix I = Matrix::Identity(40, 40);
  const ReducedModel same = project(model, I, I);
  const BandError e = estimate.verify(same, 4);
  EXPECT_LT(e.sup_relative, 1e-12);
  EXPECT_TRUE(e.within(1e-10));
}

// Auto chooses by the model size.
TEST(EstimateMode, AutoChoosesByTheModelSize) {
  const Model model = rc_ladder(40);
  auto solver = make_shifted_solver(model);
  ResponseCache cache(model, *solver);
  BandErrorOptions o;
  o.verify = ErrorVerify::Auto;
  o.dense_max_states = 40;
  EXPECT_EQ(BandErrorEstimator(cache, Band{1e-2, 1e2}, o).mode(), ErrorVerify::Dense);
  o.dense_max_states = 39;
  EXPECT_EQ(BandErrorEstimator(cache, Band{1e-2, 1e2}, o).mode(), ErrorVerify::Estimate);
  o.check_peaks = 0;
  EXPECT_THROW(BandErrorEstimator(cache, Band{1e-2, 1e2}, o), ConfigError);
  EXPECT_EQ(parse_error_verify("estimate"), ErrorVerify::Estimate);
  try {
    parse_error_verify("estimat");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'estimate'"), std::string::npos) << e.what();
  }
}

// Leaving the estimate mid-run (what auto does when the reference costs more than the dense
// sampling would): from then on the errors are the dense mode's, computed afresh from full solves.
TEST(EstimateMode, AfterASwitchTheErrorsAreTheDenseModes) {
  const Model model = chain();
  const Band band{1e-3, 0.4};
  auto solver = make_shifted_solver(model);
  const ReducedModel candidate = krylov_candidate(model, *solver, band, 6);
  const std::vector<double> f = log_grid(band.f_min_hz, band.f_max_hz, 37);

  auto dense_solver = make_shifted_solver(model);
  ResponseCache dense_cache(model, *dense_solver);
  BandErrorEstimator dense(dense_cache, band, options(ErrorVerify::Dense));
  const BandError truth = dense.evaluate_on(candidate, f);

  auto switch_solver = make_shifted_solver(model);
  ResponseCache cache(model, *switch_solver);
  BandErrorEstimator estimator(cache, band, options(ErrorVerify::Auto));
  ASSERT_EQ(estimator.mode(), ErrorVerify::Estimate);
  const BandError before = estimator.evaluate_on(candidate, f);
  EXPECT_LT(before.checked_samples, static_cast<Index>(f.size()));
  EXPECT_TRUE(estimator.switch_note().empty());
  estimator.use_dense("forced by the test");
  EXPECT_EQ(estimator.mode(), ErrorVerify::Dense);
  EXPECT_EQ(estimator.switch_note(), "forced by the test");
  EXPECT_EQ(estimator.reference_order(), 0);
  const BandError after = estimator.evaluate_on(candidate, f);
  ASSERT_EQ(after.relative.size(), truth.relative.size());
  for (std::size_t k = 0; k < f.size(); ++k)
    EXPECT_NEAR(after.relative[k], truth.relative[k], 1e-12 * truth.relative[k]) << f[k];
  EXPECT_TRUE(std::all_of(after.exact.begin(), after.exact.end(), [](char e) { return e != 0; }));
}

// A strategy whose estimated error stopped improving asks for more effort on the error (escalate).
// Auto mode takes the dense mode when its grids cost no more than the run has spent on full solves
// and the reference, or than 1e10 flops: on this chain (N = 151, ~1.5e6 flops per full solve) the
// ~1 000 solves of the default grids (G + 4 (G - 1) + 2, G = 200) are within that; the ~50 000 of
// G = 10 000 are not, and neither are they within the 40 seed solves spent. Otherwise, and with
// verify: estimate, the estimate probes more, once; never when the user turned probing off.
TEST(EstimateMode, AStalledRunEscalatesToTheDenseModeWhenAffordableElseToMoreProbes) {
  const Model model = chain();
  const Band band{1e-3, 0.4};
  BandErrorOptions o = options(ErrorVerify::Auto);
  o.dense_max_states = 0;
  o.reference_points = 40;
  enum class Outcome { Nothing, Dense, Probes };
  auto run = [&](const BandErrorOptions& opts) {
    auto solver = make_shifted_solver(model);
    ResponseCache cache(model, *solver);
    BandErrorEstimator estimator(cache, band, opts);
    EXPECT_EQ(estimator.mode(), ErrorVerify::Estimate);
    const bool escalated = estimator.escalate("stalled by the test");
    Outcome outcome = Outcome::Nothing;
    if (estimator.mode() == ErrorVerify::Dense) {
      outcome = Outcome::Dense;
      EXPECT_NE(estimator.switch_note().find("stalled by the test"), std::string::npos)
          << estimator.switch_note();
      EXPECT_TRUE(estimator.escalation_note().empty());
    } else if (escalated) {
      outcome = Outcome::Probes;
      EXPECT_TRUE(estimator.switch_note().empty());
      const std::string expected =
          "probe_solves " + std::to_string(opts.probe_solves) + " -> " +
          std::to_string(opts.probe_solves + BandErrorEstimator::kEscalatedProbes);
      EXPECT_NE(estimator.escalation_note().find(expected), std::string::npos)
          << estimator.escalation_note();
      EXPECT_NE(estimator.escalation_note().find("stalled by the test"), std::string::npos);
    } else {
      EXPECT_TRUE(estimator.switch_note().empty());
      EXPECT_TRUE(estimator.escalation_note().empty());
    }
    EXPECT_EQ(escalated, outcome != Outcome::Nothing);
    EXPECT_FALSE(estimator.escalate("again"));  // each step is taken once
    return outcome;
  };
  EXPECT_EQ(run(o), Outcome::Dense);  // the default grids
  o.grid_points = 10000;
  EXPECT_EQ(run(o), Outcome::Probes);
  o.verify = ErrorVerify::Estimate;  // the user's choice of mode stands
  EXPECT_EQ(run(o), Outcome::Probes);
  o.probe_solves = 0;  // and so does no probing
  EXPECT_EQ(run(o), Outcome::Nothing);
}

// The estimator accounts for its time: the dense mode has no reference model; the estimate mode's
// reference work is part of the estimator's time, and is kept after a switch to the dense mode.
TEST(EstimateMode, AccountsForItsTimeAndTheReferenceModelsShare) {
  const Model model = chain();
  const Band band{1e-3, 0.4};
  auto solver = make_shifted_solver(model);
  const ReducedModel candidate = krylov_candidate(model, *solver, band, 6);

  auto dense_solver = make_shifted_solver(model);
  ResponseCache dense_cache(model, *dense_solver);
  BandErrorEstimator dense(dense_cache, band, options(ErrorVerify::Dense));
  (void)dense.evaluate(candidate);
  EXPECT_GT(dense.seconds(), 0.0);
  EXPECT_EQ(dense.reference_seconds(), 0.0);

  auto estimate_solver = make_shifted_solver(model);
  ResponseCache cache(model, *estimate_solver);
  BandErrorEstimator estimate(cache, band, options(ErrorVerify::Estimate));
  const double seeded = estimate.seconds();
  EXPECT_GT(seeded, 0.0);  // the seed solves and the reference built from them
  // A basis offered is taken into the reference: the reference's time and the estimator's.
  const double reference_before = estimate.reference_seconds();
  Matrix basis = Matrix::Zero(size_of(model), 3);
  basis(0, 0) = basis(50, 1) = basis(100, 2) = 1.0;
  estimate.offer_basis(basis);
  EXPECT_EQ(estimate.reference_order(), 12 + 3);  // six seeds (real and imaginary parts) and these
  const double offered = estimate.reference_seconds() - reference_before;
  EXPECT_GT(offered, 0.0);
  EXPECT_GE(estimate.seconds() - seeded, offered);
  (void)estimate.evaluate(candidate);
  const double reference = estimate.reference_seconds();
  EXPECT_GT(reference, 0.0);
  EXPECT_GT(estimate.seconds(), seeded);
  EXPECT_LE(reference, estimate.seconds());
  // The full solves are the estimator's too, but not the reference model's.
  EXPECT_LE(reference + cache.seconds(), estimate.seconds() * (1.0 + 1e-9));
  estimate.use_dense("forced by the test");
  EXPECT_EQ(estimate.reference_seconds(), reference);
}

// A stop request ends a sweep of full-model responses within a round (two frequencies per
// thread), keeps what was computed, and the progress callback saw the rounds.
TEST(ResponseCache, AStopRequestEndsASweepAndKeepsWhatWasComputed) {
  const Model model = chain();
  auto solver = make_shifted_solver(model);
  ResponseCache cache(model, *solver, /*threads=*/2);
  std::vector<SweepProgress> seen;
  cache.set_progress([&](const SweepProgress& p) { seen.push_back(p); });
  cache.keep_solutions(true);
  const std::vector<double> f = log_grid(1e-3, 1.0, 40);
  {
    InterruptScope scope([&] { return solver->counters().factorizations >= 8; });
    EXPECT_THROW(cache.evaluate(f), Interrupted);
  }
  EXPECT_GE(cache.size(), 8);
  EXPECT_LE(cache.size(), 12);  // stopped before the round after the one that reached 8
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.back().done, cache.size());
  EXPECT_EQ(seen.back().total, 40);
  EXPECT_EQ(static_cast<Index>(cache.take_solutions().size()), cache.size());
  EXPECT_TRUE(cache.take_solutions().empty());
  // Nothing lost: the frequencies done are not factorised again.
  const Index done = cache.size();
  const Index before = solver->counters().factorizations;
  cache.evaluate(f);
  EXPECT_EQ(solver->counters().factorizations - before, 40 - done);
  EXPECT_EQ(cache.size(), 40);
}

}  // namespace
}  // namespace ecmor
