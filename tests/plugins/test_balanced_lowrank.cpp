// test_balanced_lowrank: the balanced reducer's low-rank route (gramians: lowrank / auto above
// 2000 states): factors by low-rank ADI (lowrank_factors.hpp) against the dense route; the
// second-order variants on the M-M.E.S.S. triple chain (N = 1501) at r = 20 against the shared
// reference response and the peers' figure; the handling of an ADI run that stops at its budget;
// bad parameters.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "balanced/gramian_factors.hpp"
#include "balanced/lowrank_factors.hpp"
#include "common/plugin_registry.hpp"
#include "common/reference_response.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/reduced_response.hpp"

namespace ecmor {
namespace {

using test::message_of;

Registry& registry() { return test::plugin_registry("libecmor_balanced.so"); }

std::filesystem::path shared(const std::string& name) {
  return std::filesystem::path("models") / name;
}

Band band_of(double f_min, double f_max) {
  Band b;
  b.f_min_hz = f_min;
  b.f_max_hz = f_max;
  return b;
}

ParameterMap params(std::initializer_list<std::pair<const char*, ParameterValue::Storage>> kv) {
  ParameterMap p("reducer 'balanced'");
  for (const auto& [k, v] : kv) p.set(k, ParameterValue{v, {}});
  return p;
}

struct Fixture {
  Model model;
  std::unique_ptr<ShiftedSolver> solver;
  std::shared_ptr<Reducer> reducer;
};

std::unique_ptr<Fixture> make(const std::string& name, const ParameterMap& p, Band band) {
  auto f = std::make_unique<Fixture>();
  f->model = load_model(shared(name));
  f->solver = make_shifted_solver(f->model);
  f->reducer = registry().create("balanced", p);
  ReductionContext ctx;
  ctx.model = &f->model;
  ctx.solver = f->solver.get();
  ctx.band = band;
  f->reducer->setup(ctx);
  return f;
}

Vector hsv(const balanced::GramianFactors& g) {
  return Eigen::JacobiSVD<Matrix>(Matrix(g.Zo.transpose() * g.Zc)).singularValues();
}

/// The low-rank factors give the Hankel singular values of the dense route. ADI stops at the
/// relative residual 1e-12 here, so each Gramian is within about 1e-12 ||X|| (times the
/// equation's condition) of the exact one, and s_i^2 (an eigenvalue of P E'QE) moves by about
/// that times ||P|| ||E'QE||: 1e-6 relative for the HSVs down to 1e-3 s_1 leaves a margin of
/// several hundred for the condition. The leading HSVs are compared; the tail is below what
/// either route resolves.
TEST(BalancedLowRank, FactorsReproduceTheDenseHankelSingularValues) {
  for (const std::string name : {"build", "cdplayer", "triplechain_cmess_n301"}) {
    const Model model = load_model(shared(name));
    const Vector dense = hsv(balanced::dense_gramian_factors(model));
    auto solver = make_shifted_solver(model);
    FirstOrderView view(model, *solver);
    AdiOptions options;
    options.tolerance = 1e-12;
    options.max_iterations = 2000;
    balanced::AdiSummary summary;
    const Vector lowrank = hsv(balanced::lowrank_gramian_factors(view, options, summary));
    ASSERT_TRUE(summary.converged()) << name << ": " << summary.text();
    Index compared = 0;
    double worst = 0.0;
    for (Index i = 0; i < std::min<Index>(10, lowrank.size()); ++i) {
      if (dense(i) < 1e-3 * dense(0)) break;
      const double diff = std::abs(lowrank(i) - dense(i)) / dense(i);
      EXPECT_LE(diff, 1e-6) << name << " s_" << i + 1 << " = " << dense(i);
      worst = std::max(worst, diff);
      ++compared;
    }
    EXPECT_GE(compared, 3) << name;
    std::cout << fmt::format(
        "  {}: {} HSVs >= 1e-3 s_1 compared, worst relative difference "
        "{:.1e}; ADI {} / {} iterations\n",
        name, compared, worst, summary.controllability.iterations,
        summary.observability.iterations);
  }
}

/// The comparison: second-order BT at r = 20 on triplechain_mess_n1501, where pyMOR,
/// M-M.E.S.S. and C-M.E.S.S. reach a maximum relative band error of about 0.20 with their best
/// variants. 3002 first-order states: gramians: auto takes the low-rank route; ADI stops at its
/// budget of 300 iterations with residuals of a few 1e-2, as M-M.E.S.S.'s demo does (its own test
/// only asks for a residual below 0.1): the Gramian of this lightly damped chain has a numerical
/// rank above 1000 (docs/lowrank-adi.md). The error is measured against the shared reference
/// response (SciPy/SuperLU, 200 log-spaced frequencies over the demo's band 1e-4..1 rad/s), i.e.
/// on a grid of the peers' kind. On that grid the sharp resonance the reduced models miss near
/// 0.06 Hz is not resolved; the driver's estimator resolves it (0.248 for p, README), which is
/// why the figure must be compared on a grid like the peers'.
TEST(BalancedLowRank, TripleChainSecondOrderVariantsReachThePeersError) {
  const std::string name = "triplechain_mess_n1501";
  const test::ReferenceResponse ref =
      test::read_reference_response(shared(name) / "ref_freq_response.csv", 1, 1);
  ASSERT_EQ(ref.omega.size(), 200u);
  const Band band = band_of(1.6e-5, 1.6);
  double best = 1e300;
  for (const std::string variant : {"p", "v", "pv", "vp", "fv"}) {
    auto f = make(name, params({{"structure", std::string("second_order")}, {"variant", variant}}),
                  band);
    const ReducerResult r = f->reducer->reduce(ReductionRequest{20, {}});
    ASSERT_TRUE(std::holds_alternative<ReducedSecondOrderModel>(r.model)) << variant;
    EXPECT_EQ(r.diagnostics.at("adi_converged"), 0.0) << variant;
    EXPECT_GT(r.diagnostics.at("adi_residual_c"), 0.0);
    EXPECT_LT(r.diagnostics.at("adi_residual_c"), 0.1) << variant;
    EXPECT_LT(r.diagnostics.at("adi_residual_o"), 0.1) << variant;
    EXPECT_NE(r.note.find("did not converge"), std::string::npos) << r.note;
    const ReducedResponse response(r.model);
    double worst = 0.0;
    for (std::size_t k = 0; k < ref.omega.size(); ++k) {
      const Complex Hr = response(Complex(0.0, ref.omega[k]))(0, 0);
      worst = std::max(worst, std::abs(ref.H[k](0, 0) - Hr) / std::abs(ref.H[k](0, 0)));
    }
    std::cout << fmt::format(
        "  {} r = 20: max relative error {:.3f} on the reference grid, "
        "{} unstable poles, Gramians {:.2f} s\n",
        variant, worst, r.diagnostics.at("unstable_poles"), r.diagnostics.at("gramian_seconds"));
    if (variant == "p" || variant == "v" || variant == "fv") {
      // The peers' "about 0.20" to its two stated digits.
      EXPECT_LT(worst, 0.205) << variant;
      EXPECT_EQ(r.diagnostics.at("unstable_poles"), 0.0) << variant;
    }
    best = std::min(best, worst);
  }
  EXPECT_LE(best, 0.20) << "the best variant is no worse than the peers' best";
}

TEST(BalancedLowRank, AnAdiRunThatStopsAtItsBudgetIsReportedOrRefused) {
  // build at 4 ADI iterations is far from converged (its Gramians need dozens).
  auto f =
      make("build", params({{"gramians", std::string("lowrank")}, {"adi_max_iterations", 4LL}}),
           band_of(0.1, 10.0));
  const ReducerResult r = f->reducer->reduce(ReductionRequest{4, {}});
  EXPECT_EQ(r.diagnostics.at("adi_converged"), 0.0);
  EXPECT_GT(r.diagnostics.at("adi_residual_c"), 1e-10);
  EXPECT_EQ(r.diagnostics.count("error_bound"), 0u) << "no bound from truncated Gramians";
  EXPECT_NE(r.note.find("WARNING"), std::string::npos) << r.note;

  const std::string msg = message_of<NumericalError>([] {
    make("build",
         params({{"gramians", std::string("lowrank")},
                 {"adi_max_iterations", 4LL},
                 {"adi_require_convergence", true}}),
         band_of(0.1, 10.0));
  });
  EXPECT_NE(msg.find("did not reach adi_tolerance"), std::string::npos) << msg;
  EXPECT_NE(msg.find("adi_max_iterations = 4"), std::string::npos) << msg;
  EXPECT_NE(msg.find("residual"), std::string::npos) << msg;

  // Converged: the bound is reported and holds the same meaning as on the dense route.
  auto ok = make("build", params({{"gramians", std::string("lowrank")}}), band_of(0.1, 10.0));
  const ReducerResult good = ok->reducer->reduce(ReductionRequest{4, {}});
  EXPECT_EQ(good.diagnostics.at("adi_converged"), 1.0);
  EXPECT_LE(good.diagnostics.at("adi_residual_c"), 1e-10);
  EXPECT_EQ(good.diagnostics.count("error_bound"), 1u);
}

/// At its numerical rank the reducer cannot grow the order, and the strategy's message only says
/// "the reducer delivers at most order r": the note must name why (issue 29, item 5). build with
/// 4 ADI iterations is the unconverged case of triplechain_mess_n1501 on a small model: the note
/// names the floor and the unconverged ADI with its residuals; below the rank it says nothing;
/// with converged ADI it names the floor only.
TEST(BalancedLowRank, TheLargestOrderNamesItsCause) {
  auto f =
      make("build", params({{"gramians", std::string("lowrank")}, {"adi_max_iterations", 4LL}}),
           band_of(0.1, 10.0));
  const Index cap = f->reducer->max_order();
  ASSERT_GT(cap, 1);
  const ReducerResult at = f->reducer->reduce(ReductionRequest{cap, {}});
  EXPECT_EQ(at.diagnostics.at("order_limit_reached"), 1.0);
  EXPECT_NE(at.note.find(fmt::format("BT LIMIT: order {} is the largest", cap)), std::string::npos)
      << at.note;
  EXPECT_NE(at.note.find("cause: low-rank ADI did not converge"), std::string::npos) << at.note;
  EXPECT_NE(at.note.find(fmt::format("{:.2e}", at.diagnostics.at("adi_residual_c"))),
            std::string::npos)
      << at.note;
  const ReducerResult below = f->reducer->reduce(ReductionRequest{cap - 1, {}});
  EXPECT_EQ(below.diagnostics.at("order_limit_reached"), 0.0);
  EXPECT_EQ(below.note.find("BT LIMIT"), std::string::npos) << below.note;

  auto ok = make("build", params({{"gramians", std::string("lowrank")}}), band_of(0.1, 10.0));
  const ReducerResult good = ok->reducer->reduce(ReductionRequest{ok->reducer->max_order(), {}});
  EXPECT_EQ(good.diagnostics.at("adi_converged"), 1.0);
  EXPECT_NE(good.note.find("BT LIMIT"), std::string::npos) << good.note;
  EXPECT_EQ(good.note.find("did not converge"), std::string::npos) << good.note;
}

TEST(BalancedLowRank, BadParametersAreNamed) {
  auto create = [](const ParameterMap& p) { registry().create("balanced", p); };
  std::string msg = message_of<ConfigError>([&] {
    create(params({{"gramians", std::string("dense")}, {"adi_tolerance", 1e-8}}));
  });
  EXPECT_NE(msg.find("adi_tolerance"), std::string::npos) << msg;
  EXPECT_NE(msg.find("low-rank Gramians only"), std::string::npos) << msg;
  msg = message_of<ConfigError>([&] { create(params({{"gramians", std::string("sparse")}})); });
  EXPECT_NE(msg.find("gramians"), std::string::npos) << msg;
  EXPECT_NE(msg.find("lowrank"), std::string::npos) << msg;
  msg = message_of<ConfigError>([&] { create(params({{"adi_shifts", std::string("penzl")}})); });
  EXPECT_NE(msg.find("adi_shifts"), std::string::npos) << msg;
  msg = message_of<ConfigError>([&] { create(params({{"band_quadrature_budget", 100LL}})); });
  EXPECT_NE(msg.find("band_quadrature_budget"), std::string::npos) << msg;
  EXPECT_NE(msg.find("band_limited: true"), std::string::npos) << msg;
  msg = message_of<ConfigError>([&] {
    create(params({{"band_limited", true}, {"band_quadrature_tolerance", 2.0}}));
  });
  EXPECT_NE(msg.find("band_quadrature_tolerance"), std::string::npos) << msg;
  msg = message_of<ConfigError>([&] { create(params({{"adi_max_iterations", 0LL}})); });
  EXPECT_NE(msg.find("adi_max_iterations"), std::string::npos) << msg;
  // A DAE has no ADI Gramians either: the route names the singular E.
  msg = message_of<InputError>([&] {
    make("mna1", params({{"gramians", std::string("lowrank")}}), band_of(1e6, 1e9));
  });
  EXPECT_NE(msg.find("singular"), std::string::npos) << msg;
  EXPECT_NE(msg.find("balanced"), std::string::npos) << msg;
}

/// Frequency-limited BT on the low-rank route (band quadrature + LDL' ADI) against the dense route
/// (band Gramians by a matrix function of E^-1 A and Bartels-Stewart; gramian_factors.hpp): two
/// independent computations of the same band Gramians. The low-rank side is accurate to its
/// quadrature tolerance (1e-8 relative on L_B, L_C) times the Lyapunov operator's amplification
/// of a right-hand-side error (test_lowrank_band measures <= 100 on these models) plus the ADI
/// tolerance 1e-10: 1e-6 on the Gramians. An HSV s_i moves by about that times s_1^2 / s_i
/// (s_i^2 is an eigenvalue of P_Omega E'Q_Omega E), hence the bound 1e-6 (s_1 / s_i)^2, checked
/// for the HSVs it keeps below 1e-3.
TEST(BalancedLowRank, BandLimitedLowRankAgreesWithTheDenseBandRoute) {
  struct Case {
    const char* name;
    Band band;
  };
  for (const Case& c : {Case{"build", band_of(0.5, 2.0)}, Case{"cdplayer", band_of(10.0, 1000.0)},
                        Case{"triplechain_cmess_n301", band_of(1e-3, 1e-1)}}) {
    auto dense =
        make(c.name, params({{"gramians", std::string("dense")}, {"band_limited", true}}), c.band);
    // cdplayer's ADI needs about 340 iterations per side (the default budget is 300).
    auto lowrank = make(c.name,
                        params({{"gramians", std::string("lowrank")},
                                {"band_limited", true},
                                {"adi_max_iterations", 2000LL}}),
                        c.band);
    double s1 = 0.0, worst = 0.0;
    Index compared = 0;
    for (Index r = 1; r <= 8; ++r) {
      const ReducerResult d = dense->reducer->reduce(ReductionRequest{r, {}});
      const ReducerResult l = lowrank->reducer->reduce(ReductionRequest{r, {}});
      if (r == 1) {
        s1 = d.diagnostics.at("hsv_1");
        EXPECT_EQ(l.diagnostics.at("adi_converged"), 1.0) << c.name << ": " << l.note;
        EXPECT_GT(l.diagnostics.at("band_integral_evaluations"), 0.0);
        EXPECT_LE(l.diagnostics.at("band_integral_error"), 1e-8) << c.name;
      }
      const double sd = d.diagnostics.at("hsv_r"), sl = l.diagnostics.at("hsv_r");
      if (sd < 1e-3 * s1) break;
      const double diff = std::abs(sl - sd) / sd;
      const double allowed = 1e-6 * (s1 / sd) * (s1 / sd);
      EXPECT_LE(diff, allowed) << c.name << " s_" << r << " = " << sd;
      worst = std::max(worst, diff);
      ++compared;
    }
    EXPECT_GE(compared, 2) << c.name;
    std::cout << fmt::format("  {}: {} band HSVs compared, worst relative difference {:.1e}\n",
                             c.name, compared, worst);
  }
}

// ref_freq_response.csv of a MIMO model: omega, sigma_max, then re_H_i_j, im_H_i_j.
/// On a large model (rail_5177, 5177 states: the low-rank route) frequency-limited BT balances the
/// band and beats plain BT there at the same order, measured against the reference response
/// at its frequencies inside the band (relative spectral error).
TEST(BalancedLowRank, BandLimitedBeatsPlainOnALargeModelAgainstTheReference) {
  const std::string name = "rail_5177";
  const Band band = band_of(1e-3, 1e-1);
  const test::ReferenceResponse ref =
      test::read_reference_response(shared(name) / "ref_freq_response.csv", 6, 7);
  auto band_error = [&](const ReducedModel& model) {
    const ReducedResponse response(model);
    double worst = 0.0;
    Index points = 0;
    for (std::size_t k = 0; k < ref.omega.size(); ++k) {
      const double f = ref.omega[k] / (2.0 * M_PI);
      if (f < band.f_min_hz || f > band.f_max_hz) continue;
      const ComplexMatrix Hr = response(Complex(0.0, ref.omega[k]));
      const double full = Eigen::JacobiSVD<ComplexMatrix>(ref.H[k]).singularValues()(0);
      const double diff =
          Eigen::JacobiSVD<ComplexMatrix>(ComplexMatrix(ref.H[k] - Hr)).singularValues()(0);
      worst = std::max(worst, diff / full);
      ++points;
    }
    EXPECT_GE(points, 5);
    return worst;
  };
  const Index r = 10;
  auto plain = make(name, params({}), band);
  auto limited = make(name, params({{"band_limited", true}}), band);
  const ReducerResult p = plain->reducer->reduce(ReductionRequest{r, {}});
  const ReducerResult l = limited->reducer->reduce(ReductionRequest{r, {}});
  EXPECT_EQ(l.diagnostics.count("band_integral_evaluations"), 1u) << "the low-rank band route";
  EXPECT_EQ(l.diagnostics.at("unstable_poles"), 0.0);
  const double ep = band_error(p.model), el = band_error(l.model);
  std::cout << fmt::format(
      "  rail_5177 r = {}: band error plain BT {:.2e}, frequency-limited "
      "{:.2e}; band Gramians {:.1f} s ({} quadrature nodes)\n",
      r, ep, el, l.diagnostics.at("gramian_seconds"),
      l.diagnostics.at("band_integral_evaluations"));
  EXPECT_LT(el, ep);
}

/// A spring chain without damping (D = 0): every pole is on the imaginary axis, the Gramians do
/// not exist. The low-rank route must say so, not iterate to its budget or return a model.
TEST(BalancedLowRank, UndampedAndUnstableModelsAreRefusedByName) {
  const Index n = 60;
  SecondOrderModel so;
  std::vector<Eigen::Triplet<double>> k;
  for (Index i = 0; i < n; ++i) {
    k.emplace_back(i, i, 2.0);
    if (i + 1 < n) {
      k.emplace_back(i, i + 1, -1.0);
      k.emplace_back(i + 1, i, -1.0);
    }
  }
  so.K.resize(n, n);
  so.K.setFromTriplets(k.begin(), k.end());
  so.M.resize(n, n);
  so.M.setIdentity();
  so.D.resize(n, n);  // all zero
  so.B = Matrix::Zero(n, 1);
  so.B(0, 0) = 1.0;
  so.C = Matrix::Zero(1, n);
  so.C(0, n - 1) = 1.0;
  Model model = so;
  auto solver = make_shifted_solver(model);
  auto reducer = registry().create("balanced", params({{"gramians", std::string("lowrank")}}));
  ReductionContext ctx;
  ctx.model = &model;
  ctx.solver = solver.get();
  ctx.band = band_of(0.01, 1.0);
  const std::string msg = message_of<InputError>([&] { reducer->setup(ctx); });
  EXPECT_NE(msg.find("balanced"), std::string::npos) << msg;
  EXPECT_NE(msg.find("do not exist"), std::string::npos) << msg;
  EXPECT_NE(msg.find("imaginary axis"), std::string::npos) << msg;
  EXPECT_NE(msg.find("D = 0"), std::string::npos) << msg;

  // Negative damping: unstable. The ADI's projection finds a Ritz value with Re > 0 whose
  // residual makes it an eigenvalue, and the setup refuses the model by name.
  std::get<SecondOrderModel>(model).D = -0.01 * std::get<SecondOrderModel>(model).M;
  auto unstable_solver = make_shifted_solver(model);
  ctx.solver = unstable_solver.get();
  auto again = registry().create("balanced", params({{"gramians", std::string("lowrank")}}));
  const std::string unstable = message_of<InputError>([&] { again->setup(ctx); });
  EXPECT_NE(unstable.find("do not exist"), std::string::npos) << unstable;
  EXPECT_NE(unstable.find("not asymptotically stable"), std::string::npos) << unstable;
}

}  // namespace
}  // namespace ecmor
