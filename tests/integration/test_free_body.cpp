// A free-floating 3-D solid (six rigid-body modes, K singular) through the whole driver: it must
// meet a 1e-3 band target with exit code 0 through modal and through krylov, with every pole away
// from 0 damped; modal must keep all six rigid-body poles, and summary.json must then say that the
// reduced model is stable like the full model (issue 28, item 1).
//
// The model is generated at run time (bench/solid.hpp, 30 x 3 x 2 hexahedra, N = 1 116, free).
// Independent reference for "poles kept": with Rayleigh damping D = alpha M + beta K every
// rigid-body mode r (K r = 0) has the poles s = 0 and s = -alpha exactly, and every elastic pole
// has |s| >= 2 pi f_1 >> alpha. So the reduced model keeps the rigid-body poles when exactly 6 of
// its poles lie within 1e-2 alpha of 0 and the next is at least alpha / 2 away.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../../bench/solid.hpp"
#include "common/test_support.hpp"
#include "ecmor/config.hpp"
#include "ecmor/error.hpp"
#include "ecmor/frequency_response.hpp"
#include "ecmor/matrix_market.hpp"
#include "ecmor/model_io.hpp"
#include "ecmor/strategies/driver.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

bench::SolidOptions free_solid() {
  bench::SolidOptions o;
  o.nx = 30;
  o.ny = 3;
  o.nz = 2;
  o.clamped = false;
  return o;
}

void write_model(const fs::path& dir, const SecondOrderModel& m) {
  fs::create_directories(dir);
  write_matrix_market(dir / "M.mtx", m.M, "free solid");
  write_matrix_market(dir / "D.mtx", m.D, "free solid");
  write_matrix_market(dir / "K.mtx", m.K, "free solid");
  write_matrix_market(dir / "B.mtx", Matrix(m.B), "free solid");
  write_matrix_market(dir / "C.mtx", Matrix(m.C), "free solid");
}

struct Method {
  const char* reducer;
  const char* strategy;
  /// modal puts the null space of K into its basis; krylov's moments at s0 != 0 capture the
  /// rigid-body motions only approximately (measured: 4 of the 6 at order 32), which the rule
  /// accepts as "stable with 4 of the full model's 6 rigid-body modes".
  bool keeps_every_rigid_mode;
};

class FreeBody : public ::testing::TestWithParam<Method> {};

TEST_P(FreeBody, MeetsTheTargetAndKeepsTheRigidBodyPoles) {
  const Method run = GetParam();
  test::TempDir tmp("ecmor_free_body");
  const bench::SolidOptions options = free_solid();
  write_model(tmp / "model", bench::solid(options));
  const fs::path out = tmp / "out";
  const std::string yaml = "model:  {dir: " + (tmp / "model").string() +
                           "}\n"
                           "band:   {f_min_hz: 20, f_max_hz: 2000}\n"
                           "target: {tolerance: 1.0e-3, norm: spectral}\n"
                           "reducer: {name: " +
                           run.reducer + "}\nstrategy: {name: " + run.strategy +
                           "}\n"
                           "output: {dir: " +
                           out.string() + "}\n";
  Registry registry;
  registry.load_plugin(fs::path(ECMOR_TEST_PLUGIN_DIR) /
                       ("libecmor_" + std::string(run.reducer) + ".so"));
  const RunSummary s = run_reduction(parse_run_config(yaml, "free_body.yaml"), registry);
  SCOPED_TRACE(s.message);
  EXPECT_EQ(s.exit_code(), 0);
  EXPECT_EQ(s.termination, Termination::Converged);
  ASSERT_TRUE(s.has_model);
  EXPECT_LE(s.verified_band_error, 1e-3);
  EXPECT_TRUE(s.stable);
  std::ifstream in(out / "summary.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_TRUE(j.at("target_met").get<bool>());
  EXPECT_TRUE(j.at("stability").at("accepted").get<bool>());
  EXPECT_EQ(j.at("stability").at("full_rigid_modes"), 6);
  EXPECT_LE(j.at("stability").at("rigid_modes").get<Index>(), 6);
  // Every pole away from s = 0 is damped.
  const ComplexVector p = poles(read_reduced_model(out));
  for (Index i = 0; i < p.size(); ++i) {
    if (std::abs(p(i)) > 1e-2 * options.alpha) {
      EXPECT_LT(p(i).real(), 0.0) << p(i);
    }
  }
  if (!run.keeps_every_rigid_mode) return;
  EXPECT_EQ(s.stability.verdict, ReducedVerdict::RigidLikeFull) << s.stability.reason;
  EXPECT_EQ(j.at("stability").at("verdict"), "stable with 6 rigid-body modes like the full model");
  // The expected case of a free body is not a warning.
  EXPECT_TRUE(j.at("warnings").empty()) << j.at("warnings").dump();

  // The written reduced model keeps the 6 rigid-body poles at s = 0 (see the file comment).
  std::vector<double> modulus;
  for (Index i = 0; i < p.size(); ++i) modulus.push_back(std::abs(p(i)));
  std::sort(modulus.begin(), modulus.end());
  ASSERT_GE(modulus.size(), 7u);
  EXPECT_LE(modulus[5], 1e-2 * options.alpha);
  EXPECT_GE(modulus[6], 0.5 * options.alpha);
}

INSTANTIATE_TEST_SUITE_P(Reducers, FreeBody,
                         ::testing::Values(Method{"modal", "grow_order", true},
                                           Method{"krylov", "greedy_points", false}),
                         [](const ::testing::TestParamInfo<Method>& param) {
                           return std::string(param.param.reducer);
                         });

// Balanced truncation refuses the free body by name, with the number of rigid-body modes.
TEST(FreeBodyRefusal, BalancedTruncationRefusesByName) {
  test::TempDir tmp("ecmor_free_body");
  bench::SolidOptions options = free_solid();
  options.nx = 8;
  write_model(tmp / "model", bench::solid(options));
  const std::string yaml = "model:  {dir: " + (tmp / "model").string() +
                           "}\nband: {f_min_hz: 20, f_max_hz: 2000}\n"
                           "target: {tolerance: 1.0e-3}\nreducer: {name: balanced}\n"
                           "output: {dir: " +
                           (tmp / "out").string() + "}\n";
  Registry registry;
  registry.load_plugin(fs::path(ECMOR_TEST_PLUGIN_DIR) / "libecmor_balanced.so");
  const std::string msg = test::message_of<InputError>(
      [&] { run_reduction(parse_run_config(yaml, "free_body.yaml"), registry); });
  EXPECT_NE(msg.find("balanced truncation needs an asymptotically stable model; this one has 6 "
                     "rigid-body modes (K is singular"),
            std::string::npos)
      << msg;
  EXPECT_NE(msg.find("Use modal"), std::string::npos) << msg;
}

}  // namespace
}  // namespace ecmor
