// grow_order against a reducer whose error is known in closed form.
//
// Model: H(s) = sum_{i=1..N} 1/(s + i) (diagonal, E = I, A = -diag(i), B = C' = ones). The fake
// reducer truncates to the first n states: H - Hr = sum_{i>n} 1/(s + i). All terms lie in one
// quadrant of the complex plane, so |H - Hr| decreases with n at every frequency: the smallest
// order meeting a tolerance is well defined, and computed here independently of the estimator.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/strategies/strategy.hpp"
#include "support.hpp"

namespace ecmor {
namespace {

constexpr Index kN = 40;

DescriptorModel diagonal_model() {
  DescriptorModel m;
  m.E = SparseMatrix(kN, kN);
  m.E.setIdentity();
  m.A = SparseMatrix(kN, kN);
  for (Index i = 0; i < kN; ++i) m.A.insert(i, i) = -static_cast<double>(i + 1);
  m.A.makeCompressed();
  m.B = Matrix::Ones(kN, 1);
  m.C = Matrix::Ones(1, kN);
  return m;
}

// sup over a fine log grid of |sum_{i>n} 1/(s+i)| / |sum_i 1/(s+i)|, in closed form.
double exact_sup_error(Index n, double f0, double f1) {
  double sup = 0.0;
  for (int k = 0; k <= 20000; ++k) {
    const double f = f0 * std::pow(f1 / f0, k / 20000.0);
    const Complex s(0.0, kTwoPi * f);
    Complex tail = 0.0, all = 0.0;
    for (Index i = 1; i <= kN; ++i) {
      const Complex t = 1.0 / (s + static_cast<double>(i));
      all += t;
      if (i > n) tail += t;
    }
    sup = std::max(sup, std::abs(tail) / std::abs(all));
  }
  return sup;
}

class Truncation final : public Reducer {
 public:
  explicit Truncation(Index cap = kN) : m_cap(cap) {}
  void setup(const ReductionContext& ctx) override { m_model = ctx.model; }
  ReducerResult reduce(const ReductionRequest& request) override {
    const Index n = std::min(request.order, m_cap);
    ReducerResult r;
    r.V = Matrix::Identity(kN, n);
    r.W = r.V;
    r.model = project(*m_model, r.V, r.W);
    r.note = "first " + std::to_string(n) + " states";
    ++calls;
    return r;
  }
  Index max_order() const override { return m_cap; }
  int calls = 0;

 private:
  Index m_cap;
  const Model* m_model = nullptr;
};

struct Fixture {
  Model model = diagonal_model();
  std::unique_ptr<ShiftedSolver> solver = make_shifted_solver(model);
  ResponseCache cache{model, *solver};
  Band band{0.01, 10.0};
  BandErrorEstimator estimator{cache, band, BandErrorOptions{}};
  std::vector<IterationRecord> seen;

  StrategyResult run(Reducer& reducer, double tolerance, ParameterMap params, int stop_after = -1) {
    ReductionContext rc{&model, solver.get(), band};
    reducer.setup(rc);
    auto strategy = make_strategy("grow_order", params);
    StrategyContext ctx;
    ctx.reducer = &reducer;
    ctx.estimator = &estimator;
    ctx.tolerance = tolerance;
    ctx.on_iteration = [&](const IterationRecord& r) {
      seen.push_back(r);
      return stop_after < 0 || static_cast<int>(seen.size()) < stop_after;
    };
    return strategy->run(ctx);
  }
};

TEST(GrowOrder, FindsTheSmallestOrderMeetingTheTolerance) {
  Fixture fx;
  const Index target = 13;
  const double e_target = exact_sup_error(target, 0.01, 10.0);
  const double e_before = exact_sup_error(target - 1, 0.01, 10.0);
  ASSERT_LT(e_target, e_before);
  const double tol = std::sqrt(e_target * e_before);  // well inside the gap
  Truncation reducer;
  const StrategyResult r = fx.run(reducer, tol, ParameterMap("strategy"));
  ASSERT_EQ(r.termination, Termination::Converged) << r.message;
  ASSERT_TRUE(r.best.has_value());
  EXPECT_EQ(r.best->V.cols(), target) << r.message;
  EXPECT_LE(r.best_error.sup_relative, tol);
  EXPECT_NEAR(r.best_error.sup_relative, e_target, 1e-3 * e_target);
  // The history is complete and was observed record by record; phases appear in order.
  ASSERT_EQ(fx.seen.size(), r.history.size());
  EXPECT_EQ(r.history.front().phase, "grow");
  bool verified = false, shrunk = false;
  for (const auto& rec : r.history) {
    verified = verified || rec.phase == "verify";
    shrunk = shrunk || rec.phase == "shrink";
    EXPECT_EQ(rec.meets_tolerance, rec.band_error <= tol);
  }
  EXPECT_TRUE(verified);
  EXPECT_TRUE(shrunk);
  EXPECT_NE(r.message.find("order 13"), std::string::npos) << r.message;
}

// A reducer that adds states in pairs (like complex-conjugate modes) delivers only even orders:
// the strategy must keep raising its request and still find the smallest passing even order.
TEST(GrowOrder, ReducerDeliveringPairsStillYieldsTheSmallestPassingOrder) {
  class Pairs final : public Reducer {
   public:
    void setup(const ReductionContext& ctx) override { m_model = ctx.model; }
    ReducerResult reduce(const ReductionRequest& request) override {
      const Index n = std::min<Index>(request.order / 2 * 2, kN);
      ReducerResult r;
      r.V = Matrix::Identity(kN, n);
      r.W = r.V;
      r.model = project(*m_model, r.V, r.W);
      return r;
    }
    Index max_order() const override { return kN; }

   private:
    const Model* m_model = nullptr;
  };
  for (Index target : {7, 13, 20}) {
    Fixture fx;
    const double e_target = exact_sup_error(target, 0.01, 10.0);
    const double e_before = exact_sup_error(target - 1, 0.01, 10.0);
    const double tol = std::sqrt(e_target * e_before);
    Pairs reducer;
    const StrategyResult r = fx.run(reducer, tol, ParameterMap("strategy"));
    ASSERT_EQ(r.termination, Termination::Converged) << r.message;
    const Index smallest_even = (target + 1) / 2 * 2;
    EXPECT_EQ(r.best->V.cols(), smallest_even) << "target " << target << ": " << r.message;
  }
}

TEST(GrowOrder, OrderBudgetEndsWithTheMostAccurateModel) {
  Fixture fx;
  ParameterMap p("strategy");
  p.set("max_order", 6);
  Truncation reducer;
  const StrategyResult r = fx.run(reducer, 1e-8, p);
  EXPECT_EQ(r.termination, Termination::MaxOrderReached) << r.message;
  ASSERT_TRUE(r.best.has_value());
  EXPECT_EQ(r.best->V.cols(), 6);
  EXPECT_GT(r.best_error.sup_relative, 1e-8);
}

TEST(GrowOrder, ReducerThatCannotGrowIsReportedExhausted) {
  Fixture fx;
  Truncation reducer(5);
  const StrategyResult r = fx.run(reducer, 1e-8, ParameterMap("strategy"));
  EXPECT_EQ(r.termination, Termination::ReducerExhausted) << r.message;
  EXPECT_EQ(r.best->V.cols(), 5);
}

TEST(GrowOrder, ObserverCanStopTheRun) {
  Fixture fx;
  Truncation reducer;
  const StrategyResult r = fx.run(reducer, 1e-8, ParameterMap("strategy"), 2);
  EXPECT_EQ(r.termination, Termination::Interrupted);
  EXPECT_EQ(r.history.size(), 2u);
  EXPECT_TRUE(r.best.has_value());  // nothing lost: the best model so far is kept
}

// A stop request that takes effect inside a reducer call (the driver's InterruptScope; a long
// ARPACK run checks it between operator applications) ends the run as interrupted with the best
// model so far, and the message says where it stopped.
TEST(GrowOrder, StopInsideAReducerCallKeepsTheBestModel) {
  struct SlowTruncation final : Reducer {
    Truncation inner;
    void setup(const ReductionContext& ctx) override { inner.setup(ctx); }
    ReducerResult reduce(const ReductionRequest& request) override {
      check_interrupt("a long computation of the test reducer");
      return inner.reduce(request);
    }
    Index max_order() const override { return inner.max_order(); }
  } reducer;
  Fixture fx;
  InterruptScope scope([&] { return reducer.inner.calls >= 2; });
  const StrategyResult r = fx.run(reducer, 1e-8, ParameterMap("strategy"));
  EXPECT_EQ(r.termination, Termination::Interrupted) << r.message;
  EXPECT_EQ(reducer.inner.calls, 2);
  EXPECT_TRUE(r.best.has_value());
  EXPECT_NE(r.message.find("stopped during iteration 3: interrupted in a long computation of the "
                           "test reducer; band error"),
            std::string::npos)
      << r.message;
}

// A stop that arrives on the estimate of a model meeting the tolerance leaves it unverified: the
// run is interrupted, never "converged" with a model the independent re-check has not seen.
TEST(GrowOrder, StopBeforeTheRecheckIsNotConvergence) {
  Fixture fx;
  Truncation reducer;
  // Tolerance loose enough that the first order tried (2) meets it on the estimator's sampling.
  const double tol = 2.0 * exact_sup_error(2, 0.01, 10.0);
  const StrategyResult r = fx.run(reducer, tol, ParameterMap("strategy"), 1);
  ASSERT_EQ(r.history.size(), 1u);
  ASSERT_TRUE(r.history.front().meets_tolerance);
  EXPECT_EQ(r.termination, Termination::Interrupted) << r.message;

  // The shared bookkeeping every strategy uses: the candidate does not pass and is not kept as
  // the smallest passing model.
  Fixture fx2;
  reducer.setup(ReductionContext{&fx2.model, fx2.solver.get(), fx2.band});
  StrategyContext ctx;
  ctx.reducer = &reducer;
  ctx.estimator = &fx2.estimator;
  ctx.tolerance = tol;
  ctx.on_iteration = [](const IterationRecord&) { return false; };
  strategy_support::StrategyRun run(ctx);
  const strategy_support::Candidate c = run.assess(reducer.reduce(ReductionRequest{2, {}}), "grow");
  EXPECT_TRUE(run.stopped());
  EXPECT_FALSE(c.passed);
  EXPECT_FALSE(run.smallest_pass().has_value());
  EXPECT_TRUE(run.most_accurate().has_value());
}

// Truncating from the first state: H - Hr is 0 from order 1 on when state 1 alone is controllable,
// so this reducer takes the reverse: states N, N-1, ... (uncontrollable) first, the controllable
// one last.
class ReverseStates final : public Reducer {
 public:
  void setup(const ReductionContext& ctx) override { m_model = ctx.model; }
  ReducerResult reduce(const ReductionRequest& request) override {
    const Index n = std::min<Index>(request.order, kN - 1);
    ReducerResult r;
    r.V = Matrix::Zero(kN, n);
    for (Index j = 0; j < n; ++j) r.V(kN - 1 - j, j) = 1.0;
    r.W = r.V;
    r.model = project(*m_model, r.V, r.W);
    return r;
  }
  Index max_order() const override { return kN - 1; }

 private:
  const Model* m_model = nullptr;
};

// The fixture's model with only state 1 controllable (ReverseStates takes it last).
void only_state_1_controllable(Model& model) {
  auto& dm = std::get<DescriptorModel>(model);
  dm.B.bottomRows(kN - 1).setZero();
  dm.B(0, 0) = 1.0;
  dm.C.setOnes();
}

// grow_order one order at a time, stagnated after `window` steps without gain.
ParameterMap stagnating(long long window, long long max_order) {
  ParameterMap p("strategy");
  p.set("stagnation_window", window);
  p.set("growth_factor", 1.0);
  p.set("max_order", max_order);
  return p;
}

// A reducer whose extra columns never change the reduced model (uncontrollable states): the error
// stalls and the strategy must say so instead of growing to the budget.
TEST(GrowOrder, DetectsStagnation) {
  Fixture fx;
  only_state_1_controllable(fx.model);
  ReverseStates reducer;
  const StrategyResult r = fx.run(reducer, 1e-3, stagnating(3, 39));
  EXPECT_EQ(r.termination, Termination::Stagnated) << r.message;
  EXPECT_LT(r.history.size(), 10u);
}

// A stagnation in the estimate mode escalates (here to the dense mode: a small model), and a run
// that then ends before it assesses another model (its order budget is used up) still reports the
// most accurate model it had: nothing is lost to the escalation.
TEST(GrowOrder, ARunEndingRightAfterAnEscalationKeepsItsBestModel) {
  Fixture fx;
  ASSERT_EQ(fx.estimator.mode(), ErrorVerify::Estimate);
  only_state_1_controllable(fx.model);
  // Orders 2, 3, 4: the stagnation at 4 is also the last order.
  ReverseStates reducer;
  const StrategyResult r = fx.run(reducer, 1e-3, stagnating(2, 4));
  EXPECT_EQ(fx.estimator.mode(), ErrorVerify::Dense) << fx.estimator.switch_note();
  EXPECT_NE(fx.estimator.switch_note().find("stagnated"), std::string::npos);
  EXPECT_EQ(r.termination, Termination::MaxOrderReached) << r.message;
  ASSERT_TRUE(r.best.has_value()) << r.message;
  EXPECT_TRUE(std::isfinite(r.best_error.sup_relative)) << r.message;
}

// The one stagnation rule of grow_order, greedy_points and the point optimisers: progress means
// the best error fell strictly below ratio x its value `window` records before.
TEST(Stagnation, OnlyAStrictFallBelowTheRatioIsProgress) {
  using ecmor::strategy_support::Stagnation;
  Stagnation s(2, 0.5);
  EXPECT_FALSE(s.record(1.0));
  EXPECT_FALSE(s.record(0.8));   // fewer records than the window: no verdict yet
  EXPECT_FALSE(s.record(0.49));  // below 0.5 x 1.0
  EXPECT_TRUE(s.record(0.4));    // not below 0.5 x 0.8
  EXPECT_DOUBLE_EQ(s.before(), 0.8);
  EXPECT_DOUBLE_EQ(s.last(), 0.4);

  Stagnation equal(1, 1.0);  // ratio 1: any fall is progress, none is not
  EXPECT_FALSE(equal.record(0.3));
  EXPECT_FALSE(equal.record(0.2999));
  EXPECT_TRUE(equal.record(0.2999));

  const double inf = std::numeric_limits<double>::infinity();
  Stagnation poles(1, 0.99);  // every model so far has a pole on the band
  EXPECT_FALSE(poles.record(inf));
  EXPECT_TRUE(poles.record(inf));
  Stagnation nan(1, 0.99);
  EXPECT_FALSE(nan.record(1.0));
  EXPECT_TRUE(nan.record(std::numeric_limits<double>::quiet_NaN()));

  Stagnation off(0, 0.99);  // window 0: never
  for (int k = 0; k < 5; ++k) EXPECT_FALSE(off.record(1.0));
}

TEST(GrowOrder, InvalidParametersAreNamed) {
  ParameterMap p("strategy");
  p.set("max_ordr", 10);
  try {
    make_strategy("grow_order", p);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("max_order"), std::string::npos) << e.what();
  }
  ParameterMap q("strategy");
  q.set("initial_order", 10);
  q.set("max_order", 5);
  EXPECT_THROW(make_strategy("grow_order", q), ConfigError);
  EXPECT_THROW(make_strategy("grow_ordr", ParameterMap("strategy")), ConfigError);
}

}  // namespace
}  // namespace ecmor
