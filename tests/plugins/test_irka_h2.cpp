// The H2 error of irka against an independent reference: dense square-root balanced truncation of
// the same model (tests/common/dense_balanced_truncation.hpp: dense Gramians, SVD), both errors by
// the core's dense H2 inner products (sylvester_trace on the full model's Schur form). IRKA is a
// local H2 optimiser and balanced truncation is not H2-optimal, so with `initial_shifts: best`
// (band, modal and balanced starts, the converged model of largest ||Gr|| kept) IRKA's error must
// not exceed BT's. The plugin's balanced start is its own dense square-root balancing, not this
// reference; from band starts alone IRKA ends worse than BT on iss and cdplayer (README.md).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>

#include "common/dense_balanced_truncation.hpp"
#include "common/plugin_registry.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/measures/h2_norm.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"

namespace ecmor {
namespace {

Registry& registry() { return test::plugin_registry("libecmor_irka.so"); }

struct Case {
  const char* model;
  double f_min_hz, f_max_hz;  // the band of the starting shifts
};

class IrkaVersusBalancedTruncation : public ::testing::TestWithParam<Case> {};

TEST_P(IrkaVersusBalancedTruncation, H2ErrorIsNoWorseAtOrders10And20) {
  const Case c = GetParam();
  const Model model = load_model(std::filesystem::path("models") / c.model);
  const auto t0 = std::chrono::steady_clock::now();
  const ReducedModel dense = densify(model);
  // Errors by adaptive quadrature of ||G(i w) - Gr(i w)||_F^2 (core h2_error_quadrature, accurate
  // to about 1e-10 relative on the integral, checked against dense Gramians in test_h2): unlike
  // ||G||^2 + ||Gr||^2 - 2 <G, Gr> from Gramians it does not cancel, which matters on fom at
  // r = 20 (relative error 4e-8, i.e. 2e-15 of ||G||^2).
  auto quadrature_solver = make_shifted_solver(model);
  H2QuadratureOptions q;
  q.max_evaluations = 20000;
  const H2Result full_norm = h2_error_quadrature(model, *quadrature_solver, nullptr, q);
  ASSERT_TRUE(full_norm.converged);
  const double norm = full_norm.value;
  // Errors near 1e-8 ||G|| (fom, r = 20) make the integral 1e-16 ||G||^2: there the relative
  // target is below the rounding of H itself; an absolute floor of 1e-20 ||G||^2 still fixes the
  // error norm to 1e-12 ||G||, a thousandth of the smallest error compared.
  q.absolute_tolerance = 1e-20 * norm * norm;
  auto error_of = [&](const ReducedModel& reduced) {
    const H2Result e = h2_error_quadrature(model, *quadrature_solver, &reduced, q);
    EXPECT_TRUE(e.converged) << e.method;
    return e.value;
  };
  const ReducedDescriptorModel fo = first_order_realization(dense);
  auto solver = make_shifted_solver(model);
  ParameterMap p("reducer 'irka'");
  p.set("max_iterations", 100LL);
  p.set("initial_shifts", std::string("best"));
  auto reducer = registry().create("irka", p);
  ReductionContext ctx;
  ctx.model = &model;
  ctx.solver = solver.get();
  ctx.band.f_min_hz = c.f_min_hz;
  ctx.band.f_max_hz = c.f_max_hz;
  reducer->setup(ctx);
  // Balanced truncation of order 10 is the prefix of order 20's square-root bases (the SVD's
  // leading singular triplets): one Gramian computation serves both orders.
  const auto bt20 = test::dense_balanced_truncation(dense, 20);
  std::cout << fmt::format(
      "[ irka-h2 ] {}: dense reference (Schur form, Gramians) {:.1f} s\n", c.model,
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  for (const Index r : {10, 20}) {
    SCOPED_TRACE(fmt::format("{} r = {}", c.model, r));
    const Matrix V = bt20.V.leftCols(r), W = bt20.W.leftCols(r);
    const ReducedDescriptorModel bt{W.transpose() * fo.E * V, W.transpose() * fo.A * V,
                                    W.transpose() * fo.B, fo.C * V};
    const double e_bt = error_of(ReducedModel(bt));
    const auto start = std::chrono::steady_clock::now();
    const ReducerResult res = reducer->reduce(ReductionRequest{r, {}});
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double e_irka = error_of(res.model);
    std::cout << fmt::format(
        "[ irka-h2 ] {} r = {}: relative H2 error irka {:.4e}, balanced "
        "truncation {:.4e} (ratio {:.3f}); irka {:.1f} s; {}\n",
        c.model, r, e_irka / norm, e_bt / norm, e_irka / e_bt, seconds, res.note);
    // A relative margin of 1e-6 for the rounding of the two dense error norms (each accurate to
    // about 1e-8 relative at these error levels, see h2_norm.hpp).
    EXPECT_LE(e_irka, e_bt * (1.0 + 1e-6));
  }
}

INSTANTIATE_TEST_SUITE_P(SharedFirstOrderModels, IrkaVersusBalancedTruncation,
                         ::testing::Values(Case{"build", 0.016, 16.0},
                                           Case{"cdplayer", 0.16, 16000.0},
                                           Case{"iss", 0.016, 16.0}, Case{"fom", 0.016, 16000.0},
                                           Case{"rail_1357", 1e-4, 1.0}),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(p.param.model);
                         });

}  // namespace
}  // namespace ecmor
