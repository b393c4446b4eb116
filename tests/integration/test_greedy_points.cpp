// greedy_points against the plain interpolation reducer (tests/common) on models built here, and,
// when it is built, the krylov plugin.
//
// Main model: a chain of kN unit masses between two walls, springs k, Rayleigh damping
// D = alpha M + beta K, force on the first mass, position of the last one measured. Its
// undamped frequencies are omega_j = 2 sqrt(k) sin(j pi / (2 (kN + 1))); k is chosen so that
// f_1 = 1 Hz, hence the band [0.2, 5.5] Hz holds the five lowest resonances, [0.2, 15] Hz 15 of
// them. Damping ratios zeta_j = alpha / (2 omega_j) + beta omega_j / 2 are 0.22 % (f_1), 0.35 %
// (f_5), 0.93 % (f_15): lightly damped, so the relative error has sharp peaks. The end-to-end
// transfer function of a chain has no zeros on the imaginary axis, so the relative error is defined
// everywhere in the band.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "common/dense_reference.hpp"
#include "common/interpolation_reducer.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/strategies/strategy.hpp"

namespace ecmor {
namespace {

using test::InterpolationReducer;
using test::message_of;

constexpr Index kN = 60;
constexpr double kAlpha = 0.02;   // mass-proportional damping
constexpr double kBeta = 2e-4;    // stiffness-proportional damping
const Band kBand{0.2, 5.5};       // the five lowest resonances
const Band kWideBand{0.2, 15.0};  // 15 resonances (f_15 = 14.6 Hz, f_16 = 15.6 Hz)

double chain_stiffness() {
  // omega_1 = 2 sqrt(k) sin(pi / (2 (N + 1))) = 2 pi (1 Hz).
  const double s = std::sin(kPi / (2.0 * static_cast<double>(kN + 1)));
  return (kPi / s) * (kPi / s);
}

SecondOrderModel chain_model() { return test::spring_chain(kN, chain_stiffness(), kAlpha, kBeta); }

// sup over `samples` log-spaced frequencies of the band of |H - Hr| / |H|, by dense LU.
std::pair<double, double> dense_sup_error(const SecondOrderModel& full, const ReducedModel& reduced,
                                          Index samples, const Band& band = kBand) {
  return test::dense_sup_error(full, reduced, band, samples);
}

struct Fixture {
  explicit Fixture(Model m = chain_model(), Band b = kBand, BandErrorOptions o = {})
      : model(std::move(m)), band(b), options(o) {}
  Model model;
  Band band;
  BandErrorOptions options;
  std::unique_ptr<ShiftedSolver> solver = make_shifted_solver(model);
  ResponseCache cache{model, *solver};
  BandErrorEstimator estimator{cache, band, options};
  std::vector<IterationRecord> seen;

  StrategyResult run(Reducer& reducer, double tolerance, const ParameterMap& params,
                     int stop_after = -1, bool uses_points = true) {
    ReductionContext rc{&model, solver.get(), band};
    reducer.setup(rc);
    auto strategy = make_strategy("greedy_points", params);
    EXPECT_TRUE(strategy->moves_points());
    StrategyContext ctx;
    ctx.reducer = &reducer;
    ctx.reducer_info.name = "interpolation";
    ctx.reducer_info.uses_expansion_points = uses_points;
    ctx.estimator = &estimator;
    ctx.tolerance = tolerance;
    ctx.on_iteration = [this, stop_after](const IterationRecord& r) {
      seen.push_back(r);
      return stop_after < 0 || static_cast<int>(seen.size()) < stop_after;
    };
    return strategy->run(ctx);
  }
};

double hz_of(const ExpansionPoint& p) { return p.s.imag() / kTwoPi; }

// Every record carries points, each of them s0 = i 2 pi f with f in the band.
void expect_points_in_band(const StrategyResult& r, const Band& band = kBand) {
  for (const IterationRecord& rec : r.history) {
    EXPECT_FALSE(rec.points.empty()) << "record " << rec.iteration << " (" << rec.phase << ")";
    for (const ExpansionPoint& p : rec.points) {
      EXPECT_EQ(p.s.real(), 0.0);
      EXPECT_GE(hz_of(p), band.f_min_hz * (1 - 1e-12)) << "record " << rec.iteration;
      EXPECT_LE(hz_of(p), band.f_max_hz * (1 + 1e-12)) << "record " << rec.iteration;
      EXPECT_GE(p.moments, 1);
    }
  }
}

ParameterMap params(std::initializer_list<std::pair<const char*, ParameterValue>> kv = {}) {
  ParameterMap p("strategy 'greedy_points'");
  for (const auto& [k, v] : kv) p.set(k, v);
  return p;
}
ParameterValue num(double v) { return ParameterValue{v, {}}; }
ParameterValue integer(long long v) { return ParameterValue{v, {}}; }
ParameterValue list(std::vector<double> v) { return ParameterValue{std::move(v), {}}; }

TEST(GreedyPoints, MeetsToleranceOnALightlyDampedChainCheckedIndependently) {
  Fixture fx(chain_model(), kWideBand);
  const double tol = 1e-6;
  InterpolationReducer reducer;
  const StrategyResult r = fx.run(reducer, tol, params());
  ASSERT_EQ(r.termination, Termination::Converged) << r.message;
  ASSERT_TRUE(r.best.has_value());
  const Index n = r.best->V.cols();
  EXPECT_LT(n, kN) << "no reduction: " << r.message;
  // The tolerance holds on 5000 log points with H from dense solves (not the estimator's grid).
  const auto [sup, f_sup] =
      dense_sup_error(std::get<SecondOrderModel>(fx.model), r.best->model, 5000, kWideBand);
  EXPECT_LE(sup, tol) << "at " << f_sup << " Hz; " << r.message;
  // More than one point was needed: 15 resonances, one starting point at the band centre.
  EXPECT_GE(r.best->points.size(), 3u) << r.message;
  ASSERT_EQ(fx.seen.size(), r.history.size());
  EXPECT_EQ(r.history.front().phase, "initial");
  ASSERT_EQ(r.history.front().points.size(), 1u);
  EXPECT_NEAR(hz_of(r.history.front().points[0]),
              std::sqrt(kWideBand.f_min_hz * kWideBand.f_max_hz), 1e-12);
  EXPECT_EQ(r.history.front().points[0].moments, 2);
  std::set<std::string> phases;
  for (const auto& rec : r.history) {
    phases.insert(rec.phase);
    EXPECT_EQ(rec.meets_tolerance, rec.band_error <= tol) << rec.iteration;
  }
  EXPECT_TRUE(phases.count("add_point")) << r.message;
  EXPECT_TRUE(phases.count("verify")) << r.message;
  // Pruning ran; its trials appear as "prune" rows only when they screen below the tolerance
  // (here every removal and moment reduction may be ruled out by the screen alone).
  EXPECT_NE(r.message.find("pruning: "), std::string::npos) << r.message;
  EXPECT_NE(r.message.find(" trials screened on "), std::string::npos) << r.message;
  expect_points_in_band(r, kWideBand);
  // Each added point sits where the previous model's error peaked: the record of an addition
  // names a frequency that is the previous record's peak (a "verify" record's when one failed).
  for (std::size_t i = 1; i < r.history.size(); ++i) {
    const auto& rec = r.history[i];
    if (rec.phase != "add_point") continue;
    ASSERT_TRUE(rec.diagnostics.count("added_point_hz"));
    EXPECT_DOUBLE_EQ(rec.diagnostics.at("added_point_hz"), r.history[i - 1].f_peak_hz);
  }
  EXPECT_NE(r.message.find("order " + std::to_string(n)), std::string::npos) << r.message;
}

// The smallest passing model is no larger with pruning than without, and a deliberately useless
// extra starting point is dropped.
TEST(GreedyPoints, PruningDropsASuperfluousPoint) {
  const double tol = 1e-4;
  // First the plain greedy run without pruning: its passing point set.
  Fixture plain;
  InterpolationReducer r0;
  const StrategyResult unpruned =
      plain.run(r0, tol, params({{"prune", ParameterValue{false, {}}}}));
  ASSERT_EQ(unpruned.termination, Termination::Converged) << unpruned.message;
  for (const auto& rec : unpruned.history) EXPECT_NE(rec.phase, "prune");
  std::vector<double> start;
  for (const auto& p : unpruned.best->points) start.push_back(hz_of(p));
  // Add a point far (in log f) from all of them, at the band's lower edge.
  const double extra = kBand.f_min_hz * 1.01;
  for (double f : start) ASSERT_GT(std::abs(std::log(f / extra)), 0.1);
  // And one more in the middle of the lowest gap between points (in log f): two superfluous
  // points, so that pruning accepts more than one smaller set.
  ASSERT_GE(start.size(), 2u);
  std::vector<double> sorted = start;
  std::sort(sorted.begin(), sorted.end());
  const double middle = std::sqrt(sorted[0] * sorted[1]);
  start.push_back(extra);
  start.push_back(middle);

  Fixture fx;
  InterpolationReducer reducer;
  const StrategyResult r = fx.run(reducer, tol, params({{"initial_points", list(start)}}));
  ASSERT_EQ(r.termination, Termination::Converged) << r.message;
  // The starting set passes at once (it contains a passing set), so everything after it is prune.
  ASSERT_GE(r.history.size(), 2u);
  EXPECT_EQ(r.history[0].phase, "initial");
  EXPECT_TRUE(r.history[0].meets_tolerance);
  const Index start_order = r.history[0].order;
  bool pruned = false;
  for (std::size_t i = 1; i < r.history.size(); ++i) {
    EXPECT_TRUE(r.history[i].phase == "prune" || r.history[i].phase == "verify")
        << r.history[i].phase;
    pruned = pruned || r.history[i].phase == "prune";
  }
  EXPECT_TRUE(pruned);
  // The re-check is made once, for the last set accepted on the estimate, not for each one: a
  // "verify" row follows a trial that met the tolerance on its estimate only as that last check
  // (or after a step back to an earlier set, marked step_back). Before, each accepted set had its
  // own re-check, the most full solves of a pruning.
  int accepted = 0, rechecks_of_accepted = 0;
  for (std::size_t i = 1; i < r.history.size(); ++i) {
    const IterationRecord& before = r.history[i - 1];
    if (r.history[i].phase == "prune" && r.history[i].meets_tolerance) ++accepted;
    if (r.history[i].phase == "verify" && before.phase == "prune" && before.meets_tolerance &&
        !before.diagnostics.count("step_back"))
      ++rechecks_of_accepted;
  }
  EXPECT_GE(accepted, 2) << r.message;
  EXPECT_EQ(rechecks_of_accepted, 1) << accepted << " sets accepted; " << r.message;
  ASSERT_TRUE(r.best.has_value());
  EXPECT_LT(r.best->points.size(), start.size()) << r.message;
  EXPECT_LT(r.best->V.cols(), start_order) << r.message;
  EXPECT_LE(r.best->V.cols(), unpruned.best->V.cols()) << r.message;
  const auto [sup, f_sup] =
      dense_sup_error(std::get<SecondOrderModel>(fx.model), r.best->model, 5000);
  EXPECT_LE(sup, tol) << "at " << f_sup << " Hz; " << r.message;
  EXPECT_NE(r.message.find("pruning"), std::string::npos) << r.message;
  expect_points_in_band(r);
}

// Pruning screens each candidate set on frequencies whose full response is cached and assesses only
// those that screen below the tolerance. Checked against an independent reference: a point whose
// removal leaves a dense-LU error (5000 frequencies) above 10x the tolerance is never assessed
// (its error at the passing model's resonance samples is far above the tolerance), while a
// superfluous point added to the greedy set makes some removal pass. Every assessed trial carries
// its screened error.
TEST(GreedyPoints, ScreeningAssessesOnlyRemovalsThatCanPass) {
  const double tol = 1e-4;
  Fixture plain;
  InterpolationReducer r0;
  const StrategyResult unpruned =
      plain.run(r0, tol, params({{"prune", ParameterValue{false, {}}}}));
  ASSERT_EQ(unpruned.termination, Termination::Converged) << unpruned.message;
  std::vector<double> start;
  for (const auto& p : unpruned.best->points) start.push_back(hz_of(p));
  const double extra = kBand.f_min_hz * 1.01;
  start.push_back(extra);

  Fixture fx;
  InterpolationReducer reducer;
  const StrategyResult r = fx.run(reducer, tol, params({{"initial_points", list(start)}}));
  ASSERT_EQ(r.termination, Termination::Converged) << r.message;
  const std::vector<ExpansionPoint> set = r.history.front().points;
  ASSERT_EQ(set.size(), start.size());

  // Independent errors of the single removals.
  const auto& full = std::get<SecondOrderModel>(fx.model);
  InterpolationReducer independent;
  independent.setup(ReductionContext{&fx.model, fx.solver.get(), kBand});
  std::set<double> needed;  // removals that clearly fail
  for (std::size_t i = 0; i < set.size(); ++i) {
    std::vector<ExpansionPoint> without = set;
    without.erase(without.begin() + static_cast<std::ptrdiff_t>(i));
    const ReducerResult m = independent.reduce(ReductionRequest{0, without});
    const double sup = dense_sup_error(full, m.model, 5000).first;
    if (sup > 10.0 * tol) needed.insert(hz_of(set[i]));
  }
  ASSERT_FALSE(needed.empty()) << "the greedy points should matter";
  EXPECT_FALSE(needed.count(hz_of(set.back()))) << "the extra point should be superfluous";

  Index prune_rows = 0;
  for (const IterationRecord& rec : r.history) {
    if (rec.phase != "prune") continue;
    ++prune_rows;
    ASSERT_TRUE(rec.diagnostics.count("screened_error")) << rec.iteration;
    EXPECT_LE(rec.diagnostics.at("screened_error"), tol) << rec.iteration;
    // The screening set holds at least the estimator's grid.
    EXPECT_GE(rec.diagnostics.at("screen_samples"), 200.0) << rec.iteration;
    if (rec.diagnostics.count("removed_point_hz")) {
      const double f = rec.diagnostics.at("removed_point_hz");
      EXPECT_FALSE(needed.count(f)) << "assessed a removal that cannot pass: " << f << " Hz";
    }
  }
  // Pruning did remove something (which point depends on the order of trials: the removal
  // leaving the smaller model goes first), and the result holds independently.
  EXPECT_GE(prune_rows, 1) << r.message;
  EXPECT_LT(r.best->points.size(), set.size()) << r.message;
  const auto [sup, f_sup] = dense_sup_error(full, r.best->model, 5000);
  EXPECT_LE(sup, tol) << "at " << f_sup << " Hz; " << r.message;
  // The message accounts for the trials: every single removal was screened, and the assessed
  // ones are exactly the prune rows.
  const std::string key = " trials screened on ";
  const auto at = r.message.find(key);
  ASSERT_NE(at, std::string::npos) << r.message;
  const auto in = r.message.rfind(" in ", at);
  const long long trials = std::stoll(r.message.substr(in + 4, at - in - 4));
  EXPECT_GE(trials, static_cast<long long>(set.size())) << r.message;
  EXPECT_NE(r.message.find(", " + std::to_string(prune_rows) + " of them assessed"),
            std::string::npos)
      << r.message;
}

TEST(GreedyPoints, PruningWithoutExtraPointIsNoLargerAndStillPasses) {
  const double tol = 1e-4;
  Fixture a, b;
  InterpolationReducer ra, rb;
  const StrategyResult unpruned = a.run(ra, tol, params({{"prune", ParameterValue{false, {}}}}));
  const StrategyResult pruned = b.run(rb, tol, params());
  ASSERT_EQ(unpruned.termination, Termination::Converged) << unpruned.message;
  ASSERT_EQ(pruned.termination, Termination::Converged) << pruned.message;
  EXPECT_LE(pruned.best->V.cols(), unpruned.best->V.cols());
  // Every prune trial recorded as such, and the reported model is the smallest passing one.
  for (const auto& rec : pruned.history) {
    if (rec.meets_tolerance && rec.phase == "verify" && rec.stable) {
      EXPECT_GE(rec.order, pruned.best->V.cols());
    }
  }
}

// A peak that is always "at" the nearest point (min_separation covering the band) adds moments
// there instead of new points.
TEST(GreedyPoints, PeakAtAnExistingPointAddsAMoment) {
  Fixture fx;
  InterpolationReducer reducer;
  const StrategyResult r = fx.run(reducer, 1e-4,
                                  params({{"min_separation", num(0.99)},
                                          {"max_iterations", integer(6)},
                                          {"prune", ParameterValue{false, {}}}}));
  ASSERT_GE(r.history.size(), 2u) << r.message;
  Index last_moments = 0;
  for (const auto& rec : r.history) {
    ASSERT_EQ(rec.points.size(), 1u) << rec.phase;
    if (rec.phase == "add_moment") {
      EXPECT_EQ(rec.points[0].moments, last_moments + 1);
      EXPECT_DOUBLE_EQ(rec.diagnostics.at("added_moment_hz"), hz_of(rec.points[0]));
    }
    if (rec.phase != "verify") last_moments = rec.points[0].moments;
    EXPECT_NE(rec.phase, "add_point");
  }
  EXPECT_EQ(r.history.back().phase == "verify" ? r.history[r.history.size() - 2].phase
                                               : r.history.back().phase,
            "add_moment");
}

// A point within 2 % of 5 Hz (the chain's fifth resonance, the band's largest error after the
// first step) gives a model with an undamped pole at 1 Hz, its first resonance, which the
// estimator samples: a band error of 1e7 there, as a Krylov model that lost its damping has.
class PoleOnTheBandNear5Hz final : public Reducer {
 public:
  static bool poisons(const ExpansionPoint& p) { return std::abs(hz_of(p) / 5.0 - 1.0) < 0.02; }
  void setup(const ReductionContext& ctx) override { m_inner.setup(ctx); }
  ReducerResult reduce(const ReductionRequest& request) override {
    ReducerResult r = m_inner.reduce(request);
    const bool poisoned = std::any_of(request.points.begin(), request.points.end(), poisons);
    if (!poisoned) return r;
    ++poisoned_calls;
    auto& m = std::get<ReducedSecondOrderModel>(r.model);
    const Index n = m.size();
    auto grow = [n](Matrix& a) {
      a.conservativeResize(n + 1, n + 1);
      a.row(n).setZero();
      a.col(n).setZero();
    };
    grow(m.M);
    grow(m.D);
    grow(m.K);
    m.M(n, n) = 1.0;
    m.K(n, n) = kTwoPi * kTwoPi;  // omega = 2 pi rad/s: f = 1 Hz, undamped
    m.B.conservativeResize(n + 1, Eigen::NoChange);
    m.B.row(n).setOnes();
    m.C.conservativeResize(Eigen::NoChange, n + 1);
    m.C.col(n).setOnes();
    return r;
  }
  int poisoned_calls = 0;

 private:
  InterpolationReducer m_inner;
};

TEST(GreedyPoints, AStepThatPutsAPoleOnTheBandIsNotTaken) {
  Fixture fx;
  PoleOnTheBandNear5Hz reducer;
  const StrategyResult r = fx.run(reducer, 1e-3, params());
  ASSERT_GT(reducer.poisoned_calls, 0) << "the test never reached the band top: " << r.message;
  bool saw_spoiled = false;
  for (const auto& rec : r.history) {
    const bool poisoned =
        std::any_of(rec.points.begin(), rec.points.end(), PoleOnTheBandNear5Hz::poisons);
    if (poisoned) {
      EXPECT_GT(rec.band_error, 1.0) << "record " << rec.iteration << " (" << rec.phase << ")";
      saw_spoiled = true;
    } else {
      EXPECT_TRUE(std::isfinite(rec.band_error)) << "record " << rec.iteration;
    }
  }
  EXPECT_TRUE(saw_spoiled);
  // Growth went on from the model before each such step and met the tolerance without a point
  // near 5 Hz, checked independently.
  ASSERT_EQ(r.termination, Termination::Converged) << r.message;
  ASSERT_TRUE(r.best.has_value());
  for (const ExpansionPoint& p : r.best->points) EXPECT_FALSE(PoleOnTheBandNear5Hz::poisons(p));
  EXPECT_LE(dense_sup_error(std::get<SecondOrderModel>(fx.model), r.best->model, 400).first, 1e-3);
}

TEST(GreedyPoints, UnreachableToleranceStopsWithAReason) {
  Fixture fx;
  InterpolationReducer reducer;
  const StrategyResult r = fx.run(reducer, 1e-15, params());
  EXPECT_NE(r.termination, Termination::Converged) << r.message;
  EXPECT_NE(r.termination, Termination::Failed) << r.message;
  EXPECT_TRUE(
      r.termination == Termination::Stagnated || r.termination == Termination::ReducerExhausted ||
      r.termination == Termination::MaxOrderReached || r.termination == Termination::IterationLimit)
      << to_string(r.termination) << ": " << r.message;
  EXPECT_LE(r.history.size(), 200u);
  ASSERT_TRUE(r.best.has_value());  // the most accurate model is kept
  EXPECT_GT(r.best_error.sup_relative, 1e-15);
  EXPECT_NE(r.message.find("1.000e-15"), std::string::npos) << r.message;
  expect_points_in_band(r);
}

// The chain plus `extra` uncoupled masses that the input does not move and the output does not
// see: columns in their coordinates leave the reduced transfer function exactly unchanged.
SecondOrderModel chain_with_spectators(Index extra) {
  const SecondOrderModel chain = chain_model();
  const Index n = kN + extra;
  SecondOrderModel m;
  auto widen = [&](const SparseMatrix& A, double diag) {
    std::vector<Eigen::Triplet<double, int>> t;
    for (int j = 0; j < A.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(A, j); it; ++it)
        t.emplace_back(it.row(), it.col(), it.value());
    for (Index i = kN; i < n; ++i) t.emplace_back(static_cast<int>(i), static_cast<int>(i), diag);
    SparseMatrix W(n, n);
    W.setFromTriplets(t.begin(), t.end());
    return W;
  };
  m.M = widen(chain.M, 1.0);
  m.D = widen(chain.D, 0.1);
  m.K = widen(chain.K, 50.0);
  m.B = Matrix::Zero(n, 1);
  m.B.topRows(kN) = chain.B;
  m.C = Matrix::Zero(1, n);
  m.C.leftCols(kN) = chain.C;
  return m;
}

// Builds the subspace of the first point only and spends one spectator coordinate on every
// further point: new columns every time, never a better model.
class SpectatorColumns final : public Reducer {
 public:
  void setup(const ReductionContext& ctx) override {
    m_inner.setup(ctx);
    m_model = ctx.model;
  }
  ReducerResult reduce(const ReductionRequest& request) override {
    // The first point with the moments it had in the first request; one spectator column for
    // every moment added since, anywhere.
    if (m_first_moments == 0) m_first_moments = request.points.at(0).moments;
    ReductionRequest first = request;
    first.points.resize(1);
    first.points[0].moments = m_first_moments;
    ReducerResult r = m_inner.reduce(first);
    Matrix V = r.V;
    Index added = -m_first_moments;
    for (const auto& p : request.points) added += p.moments;
    for (Index j = 0; j < added; ++j) {
      Matrix e = Matrix::Zero(V.rows(), 1);
      e(kN + j, 0) = 1.0;
      orthonormalize_append(V, e);
    }
    r.V = V;
    r.W = V;
    r.model = project(*m_model, r.V, r.W);
    r.points = request.points;
    return r;
  }

 private:
  InterpolationReducer m_inner;
  const Model* m_model = nullptr;
  Index m_first_moments = 0;
};

TEST(GreedyPoints, StagnationIsDetected) {
  struct Case {
    Index window;
    double ratio;
  };
  // The dense mode: a stagnation ends the run (in the estimate mode it escalates first, below).
  BandErrorOptions dense;
  dense.verify = ErrorVerify::Dense;
  for (const Case c : {Case{6, 0.99} /* the defaults */, Case{2, 0.5}}) {
    Fixture fx{Model(chain_with_spectators(30)), kBand, dense};
    SpectatorColumns reducer;
    ParameterMap p = params();
    if (c.window != 6) {
      p.set("stagnation_window", static_cast<long long>(c.window));
      p.set("stagnation_ratio", c.ratio);
    }
    const StrategyResult r = fx.run(reducer, 1e-8, p);
    ASSERT_EQ(r.termination, Termination::Stagnated) << r.message;
    EXPECT_NE(r.message.find("over the last " + std::to_string(c.window) + " additions"),
              std::string::npos)
        << r.message;
    // Stopped as soon as the rule allows: the initial model and `window` additions, each of
    // them larger than the one before and no better.
    ASSERT_EQ(r.history.size(), static_cast<std::size_t>(c.window + 1)) << r.message;
    for (std::size_t i = 1; i < r.history.size(); ++i) {
      EXPECT_NE(r.history[i].phase, "verify");
      EXPECT_GT(r.history[i].order, r.history[i - 1].order);
      EXPECT_GE(r.history[i].band_error, c.ratio * r.history[0].band_error);
    }
    expect_points_in_band(r);
  }
}

// In the estimate mode a stagnation first escalates (BandErrorEstimator::escalate): `auto` takes
// the dense mode, affordable on this small model, and `verify: estimate` probes more. Either way
// the run re-assesses its model (phase "escalate") and goes on, and the next stagnation ends it:
// the initial model, `window` additions, the re-assessment and `window` more additions.
TEST(GreedyPoints, AStagnationInTheEstimateModeEscalatesOnceAndGoesOn) {
  for (const ErrorVerify mode : {ErrorVerify::Auto, ErrorVerify::Estimate}) {
    BandErrorOptions o;
    o.verify = mode;
    Fixture fx{Model(chain_with_spectators(30)), kBand, o};
    ASSERT_EQ(fx.estimator.mode(), ErrorVerify::Estimate);
    SpectatorColumns reducer;
    const StrategyResult r = fx.run(reducer, 1e-8, params());
    ASSERT_EQ(r.termination, Termination::Stagnated) << r.message;
    constexpr std::size_t kWindow = 6;  // the default stagnation_window
    ASSERT_EQ(r.history.size(), 2 * kWindow + 2) << r.message;
    EXPECT_EQ(r.history[kWindow + 1].phase, "escalate");
    EXPECT_EQ(r.history[kWindow + 1].order, r.history[kWindow].order);
    EXPECT_GT(r.history[kWindow + 2].order, r.history[kWindow + 1].order);
    if (mode == ErrorVerify::Auto) {
      EXPECT_EQ(fx.estimator.mode(), ErrorVerify::Dense);
      EXPECT_NE(fx.estimator.switch_note().find("the band error stagnated at"), std::string::npos)
          << fx.estimator.switch_note();
      EXPECT_TRUE(fx.estimator.escalation_note().empty());
    } else {
      EXPECT_EQ(fx.estimator.mode(), ErrorVerify::Estimate);
      EXPECT_NE(fx.estimator.escalation_note().find("probe_solves 1 -> 3"), std::string::npos)
          << fx.estimator.escalation_note();
    }
    expect_points_in_band(r);
  }
}

TEST(GreedyPoints, BudgetsEndTheRunWithNamedReasons) {
  {
    Fixture fx;
    InterpolationReducer reducer;
    const StrategyResult r = fx.run(reducer, 1e-12, params({{"max_points", integer(1)}}));
    EXPECT_EQ(r.termination, Termination::MaxOrderReached) << r.message;
    EXPECT_NE(r.message.find("max_points = 1"), std::string::npos) << r.message;
    EXPECT_EQ(r.history.size(), 1u);
  }
  {
    Fixture fx;
    InterpolationReducer reducer;
    const StrategyResult r = fx.run(reducer, 1e-12, params({{"max_order", integer(10)}}));
    EXPECT_EQ(r.termination, Termination::MaxOrderReached) << r.message;
    EXPECT_NE(r.message.find("max_order = 10"), std::string::npos) << r.message;
    for (const auto& rec : r.history) EXPECT_LE(rec.order, 10);
    ASSERT_TRUE(r.best.has_value());
    EXPECT_LE(r.best->V.cols(), 10);
  }
  {
    Fixture fx;
    InterpolationReducer reducer;
    const StrategyResult r = fx.run(reducer, 1e-12, params({{"max_iterations", integer(3)}}));
    EXPECT_EQ(r.termination, Termination::IterationLimit) << r.message;
    EXPECT_NE(r.message.find("max_iterations = 3"), std::string::npos) << r.message;
    EXPECT_EQ(r.history.size(), 3u);
  }
}

TEST(GreedyPoints, ObserverCanStopTheRun) {
  Fixture fx;
  InterpolationReducer reducer;
  const StrategyResult r = fx.run(reducer, 1e-12, params(), 2);
  EXPECT_EQ(r.termination, Termination::Interrupted) << r.message;
  EXPECT_EQ(r.history.size(), 2u);
  EXPECT_TRUE(r.best.has_value());
}

// A reducer that ignores every point but the first gives no new columns for a new point.
TEST(GreedyPoints, ReducerGivingNoNewColumnsIsExhausted) {
  class FirstPointOnly final : public Reducer {
   public:
    void setup(const ReductionContext& ctx) override { m_inner.setup(ctx); }
    ReducerResult reduce(const ReductionRequest& request) override {
      ReductionRequest first = request;
      first.points.resize(1);
      return m_inner.reduce(first);
    }

   private:
    InterpolationReducer m_inner;
  } reducer;
  Fixture fx;
  const StrategyResult r = fx.run(reducer, 1e-12, params());
  EXPECT_EQ(r.termination, Termination::ReducerExhausted) << r.message;
  EXPECT_NE(r.message.find("no new columns"), std::string::npos) << r.message;
  EXPECT_EQ(r.history.size(), 1u);
  EXPECT_TRUE(r.best.has_value());
}

TEST(GreedyPoints, NumericalBreakdownFailsAndKeepsTheBestModel) {
  class BreaksOnSecondCall final : public Reducer {
   public:
    void setup(const ReductionContext& ctx) override { m_inner.setup(ctx); }
    ReducerResult reduce(const ReductionRequest& request) override {
      if (++m_calls == 2) throw NumericalError("test reducer: breakdown at the second request");
      return m_inner.reduce(request);
    }

   private:
    InterpolationReducer m_inner;
    int m_calls = 0;
  } reducer;
  Fixture fx;
  const StrategyResult r = fx.run(reducer, 1e-12, params());
  EXPECT_EQ(r.termination, Termination::Failed);
  EXPECT_NE(r.message.find("breakdown at the second request"), std::string::npos) << r.message;
  // Named where it happened: the first request made iteration 1, the second broke down.
  EXPECT_EQ(r.message.rfind("reduction failed in iteration 2 (interpolation): ", 0), 0u)
      << r.message;
  EXPECT_TRUE(r.best.has_value());
}

// Pruning never turns a converged run into a failure: a trial that breaks down counts as failed.
TEST(GreedyPoints, PruneTrialBreakdownKeepsTheConvergedModel) {
  class BreaksOnFewerPoints final : public Reducer {
   public:
    void setup(const ReductionContext& ctx) override { m_inner.setup(ctx); }
    ReducerResult reduce(const ReductionRequest& request) override {
      if (request.points.size() < m_most) {
        throw NumericalError("test reducer: breakdown with " +
                             std::to_string(request.points.size()) + " points");
      }
      m_most = request.points.size();
      return m_inner.reduce(request);
    }

   private:
    InterpolationReducer m_inner;
    std::size_t m_most = 0;
  } reducer;
  Fixture fx;
  const StrategyResult r = fx.run(reducer, 1e-4, params());
  ASSERT_EQ(r.termination, Termination::Converged) << r.message;
  EXPECT_NE(r.message.find("a trial failed: test reducer: breakdown with"), std::string::npos)
      << r.message;
  ASSERT_TRUE(r.best.has_value());
  const auto [sup, f_sup] =
      dense_sup_error(std::get<SecondOrderModel>(fx.model), r.best->model, 2000);
  EXPECT_LE(sup, 1e-4) << "at " << f_sup << " Hz; " << r.message;
}

// The iteration budget or the observer cut pruning short; the passing model stays the result.
// The start has more points than needed (eight, log-spaced over the band), so that pruning
// assesses several trials (removals that screen below the tolerance).
TEST(GreedyPoints, PruningCutShortStillConverges) {
  std::vector<double> spread;
  for (int i = 0; i < 8; ++i) {
    spread.push_back(kBand.f_min_hz * std::pow(kBand.f_max_hz / kBand.f_min_hz, (i + 0.5) / 8.0));
  }
  auto with = [&](std::initializer_list<std::pair<const char*, ParameterValue>> kv) {
    ParameterMap p = params(kv);
    p.set("initial_points", list(spread));
    return p;
  };
  Fixture plain;
  InterpolationReducer r0;
  const StrategyResult full = plain.run(r0, 1e-4, with({}));
  ASSERT_EQ(full.termination, Termination::Converged) << full.message;
  std::size_t first_prune = 0;
  while (first_prune < full.history.size() && full.history[first_prune].phase != "prune")
    ++first_prune;
  ASSERT_LT(first_prune + 1, full.history.size()) << "needs at least two prune trials";
  {
    // Budget for exactly one prune trial.
    Fixture fx;
    InterpolationReducer reducer;
    const auto budget = static_cast<long long>(first_prune + 1);
    const StrategyResult r = fx.run(reducer, 1e-4, with({{"max_iterations", integer(budget)}}));
    ASSERT_EQ(r.termination, Termination::Converged) << r.message;
    EXPECT_NE(r.message.find("cut short by max_iterations"), std::string::npos) << r.message;
    EXPECT_LE(r.history.size(), static_cast<std::size_t>(budget) + 1);
  }
  {
    Fixture fx;
    InterpolationReducer reducer;
    const StrategyResult r = fx.run(reducer, 1e-4, with({}), static_cast<int>(first_prune + 1));
    ASSERT_EQ(r.termination, Termination::Converged) << r.message;
    EXPECT_NE(r.message.find("cut short by request"), std::string::npos) << r.message;
    EXPECT_EQ(r.history.size(), first_prune + 1);
  }
}

TEST(GreedyPoints, ReducerWithoutPointsIsRefused) {
  Fixture fx;
  InterpolationReducer reducer;
  const std::string msg =
      message_of<ConfigError>([&] { fx.run(reducer, 1e-4, params(), -1, /*uses_points=*/false); });
  EXPECT_NE(msg.find("greedy_points"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'interpolation'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("does not use expansion points"), std::string::npos) << msg;
  EXPECT_EQ(reducer.calls, 0);
}

TEST(GreedyPoints, InitialPointsOutsideTheBandOrTooCloseAreRefused) {
  {
    Fixture fx;
    InterpolationReducer reducer;
    const std::string msg = message_of<ConfigError>([&] {
      fx.run(reducer, 1e-4, params({{"initial_points", list({1.0, 7.0})}}));
    });
    EXPECT_NE(msg.find("initial_points[1] = 7 Hz"), std::string::npos) << msg;
    EXPECT_NE(msg.find("outside the band"), std::string::npos) << msg;
    EXPECT_EQ(reducer.calls, 0);
  }
  {
    Fixture fx;
    InterpolationReducer reducer;
    const std::string msg = message_of<ConfigError>([&] {
      fx.run(reducer, 1e-4, params({{"initial_points", list({1.0, 1.0001})}}));
    });
    EXPECT_NE(msg.find("initial_points[1]"), std::string::npos) << msg;
    EXPECT_NE(msg.find("min_separation"), std::string::npos) << msg;
  }
}

TEST(GreedyPoints, InvalidOptionsAreNamed) {
  struct Case {
    const char* key;
    ParameterValue value;
    const char* expect;  // substring of the message
  };
  const std::vector<Case> cases = {
      {"moments", integer(0), "moments = 0: must be >= 1"},
      {"min_separation", num(1.0), "min_separation = 1: must be in [0, 1)"},
      {"min_separation", num(-0.1), "min_separation = -0.1: must be in [0, 1)"},
      {"max_points", integer(0), "max_points = 0: must be >= 1"},
      {"max_order", integer(-3), "max_order = -3: must be >= 1"},
      {"max_iterations", integer(0), "max_iterations = 0: must be >= 1"},
      {"stagnation_window", integer(-1), "stagnation_window = -1: must be >= 0"},
      {"stagnation_ratio", num(0.0), "stagnation_ratio = 0: must be in (0, 1]"},
      {"stagnation_ratio", num(1.5), "stagnation_ratio = 1.5: must be in (0, 1]"},
      {"initial_points", list({1.0, -2.0}), "initial_points[1] = -2: must be > 0 and finite"},
      {"initial_points", ParameterValue{std::string("centre"), {}}, "initial_points"},
      {"prune", integer(1), "prune"},
      {"max_point", integer(3), "did you mean 'max_points'"},
  };
  for (const Case& c : cases) {
    ParameterMap p("strategy 'greedy_points'");
    p.set(c.key, ParameterValue{c.value.value, "run.yaml:7"});
    const std::string msg = message_of<ConfigError>([&] { make_strategy("greedy_points", p); });
    EXPECT_NE(msg.find(c.expect), std::string::npos) << c.key << ": " << msg;
    EXPECT_NE(msg.find("greedy_points"), std::string::npos) << c.key << ": " << msg;
    EXPECT_NE(msg.find("run.yaml:7"), std::string::npos) << c.key << ": " << msg;
  }
  ParameterMap p("strategy 'greedy_points'");
  p.set("initial_points", ParameterValue{std::vector<double>{1.0, 2.0, 3.0}, {}});
  p.set("max_points", 2);
  const std::string msg = message_of<ConfigError>([&] { make_strategy("greedy_points", p); });
  EXPECT_NE(msg.find("max_points = 2: must be >= the number of initial_points (3)"),
            std::string::npos)
      << msg;
  // The name is listed among the strategies.
  const auto names = strategy_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "greedy_points"), names.end());
}

// Also on a first-order model: H(s) = sum_i 1/(s + i) has no resonances; the error is smooth and
// a few points suffice.
TEST(GreedyPoints, WorksOnADescriptorModel) {
  DescriptorModel m;
  const Index n = 40;
  m.E = SparseMatrix(n, n);
  m.E.setIdentity();
  m.A = SparseMatrix(n, n);
  for (Index i = 0; i < n; ++i) m.A.insert(i, i) = -kTwoPi * static_cast<double>(i + 1) * 0.2;
  m.A.makeCompressed();
  m.B = Matrix::Ones(n, 1);
  m.C = Matrix::Ones(1, n);
  Fixture fx{Model(m)};
  InterpolationReducer reducer;
  const double tol = 1e-6;
  const StrategyResult r = fx.run(reducer, tol, params());
  ASSERT_EQ(r.termination, Termination::Converged) << r.message;
  EXPECT_LT(r.best->V.cols(), n);
  // Independent check: |H - Hr| / |H| from the closed form of H and a dense solve for Hr.
  double sup = 0.0;
  for (int k = 0; k < 5000; ++k) {
    const double f = kBand.f_min_hz * std::pow(kBand.f_max_hz / kBand.f_min_hz, k / 4999.0);
    const Complex s(0.0, kTwoPi * f);
    Complex h = 0.0;
    for (Index i = 0; i < n; ++i) h += 1.0 / (s + kTwoPi * static_cast<double>(i + 1) * 0.2);
    const Complex hr = test::dense_reduced_h(r.best->model, s);
    sup = std::max(sup, std::abs(h - hr) / std::abs(h));
  }
  EXPECT_LE(sup, tol) << r.message;
  expect_points_in_band(r);
}

// With the krylov plugin (always built; its absence is a failure, not a skip).
TEST(GreedyPoints, KrylovPluginMeetsTheTolerance) {
  const auto lib = std::filesystem::path(ECMOR_TEST_PLUGIN_DIR) / "libecmor_krylov.so";
  ASSERT_TRUE(std::filesystem::exists(lib)) << "no krylov plugin in this build: " << lib;
  Registry registry;
  registry.load_plugin(lib);
  bool uses_points = false;
  for (const auto& e : registry.entries())
    if (e.info.name == "krylov") uses_points = e.info.uses_expansion_points;
  ASSERT_TRUE(uses_points) << "the krylov plugin does not take expansion points";
  auto reducer = registry.create("krylov", ParameterMap("reducer 'krylov'"));
  Fixture fx;
  const double tol = 1e-4;
  const StrategyResult r = fx.run(*reducer, tol, params());
  ASSERT_EQ(r.termination, Termination::Converged) << r.message;
  const auto [sup, f_sup] =
      dense_sup_error(std::get<SecondOrderModel>(fx.model), r.best->model, 5000);
  EXPECT_LE(sup, tol) << "at " << f_sup << " Hz; " << r.message;
  expect_points_in_band(r);
}

}  // namespace
}  // namespace ecmor
