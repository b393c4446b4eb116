// The H2 error of irka against an independent reference: dense square-root balanced truncation of
// the same model (tests/common/dense_balanced_truncation.hpp: dense Gramians, SVD), both errors by
// the dense H2 error norm of the core (h2_error_norm on densify(full)). IRKA is a local H2
// optimiser; balanced truncation is not H2-optimal, so IRKA's error must not exceed BT's.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <iostream>
#include <string>

#include "common/dense_balanced_truncation.hpp"
#include "ecmor/h2_norm.hpp"
#include "ecmor/lyapunov.hpp"
#include "ecmor/model_io.hpp"
#include "ecmor/registry.hpp"
#include "ecmor/shifted_solver.hpp"

namespace ecmor {
namespace {

Registry& registry() {
  static Registry r;
  static bool loaded = false;
  if (!loaded) {
    r.load_plugin(std::filesystem::path(ECMOR_TEST_PLUGIN_DIR) / "libecmor_irka.so");
    loaded = true;
  }
  return r;
}

struct Case {
  const char* model;
  double f_min_hz, f_max_hz;  // the band of the starting shifts
};

class IrkaVersusBalancedTruncation : public ::testing::TestWithParam<Case> {};

TEST_P(IrkaVersusBalancedTruncation, H2ErrorIsNoWorseAtOrders10And20) {
  const Case c = GetParam();
  const Model model = load_model(std::filesystem::path("../shared/models") / c.model);
  const ReducedModel dense = densify(model);
  const double norm = h2_norm(dense);
  auto solver = make_shifted_solver(model);
  ParameterMap p("reducer 'irka'");
  p.set("max_iterations", 100LL);
  auto reducer = registry().create("irka", p);
  ReductionContext ctx;
  ctx.model = &model;
  ctx.solver = solver.get();
  ctx.band.f_min_hz = c.f_min_hz;
  ctx.band.f_max_hz = c.f_max_hz;
  reducer->setup(ctx);
  for (const Index r : {10, 20}) {
    SCOPED_TRACE(fmt::format("{} r = {}", c.model, r));
    const auto bt = test::dense_balanced_truncation(dense, r);
    const double e_bt = h2_error_norm(dense, ReducedModel(bt.model));
    const ReducerResult res = reducer->reduce(ReductionRequest{r, {}});
    const double e_irka = h2_error_norm(dense, res.model);
    std::cout << fmt::format("[ irka-h2 ] {} r = {}: relative H2 error irka {:.4e}, balanced "
                             "truncation {:.4e} (ratio {:.3f}); {}\n",
                             c.model, r, e_irka / norm, e_bt / norm, e_irka / e_bt, res.note);
    // A relative margin of 1e-6 for the rounding of the two dense error norms (each accurate to
    // about 1e-8 relative at these error levels, see h2_norm.hpp).
    EXPECT_LE(e_irka, e_bt * (1.0 + 1e-6));
  }
}

INSTANTIATE_TEST_SUITE_P(
    SharedFirstOrderModels, IrkaVersusBalancedTruncation,
    ::testing::Values(Case{"build", 0.016, 16.0}, Case{"cdplayer", 0.16, 16000.0},
                      Case{"iss", 0.016, 16.0}, Case{"fom", 0.016, 16000.0},
                      Case{"rail_1357", 1e-4, 1.0}),
    [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.model); });

}  // namespace
}  // namespace ecmor
