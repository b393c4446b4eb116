// Every YAML in configs/ is a regression test of its tolerance target.
//
// Each config is run through the real `ecmor check` executable (which runs it as `ecmor reduce`
// would and checks its target and its optional `check:` budgets). The result must meet its target,
// and the test re-checks the written reduced model itself, independently of the driver:
//  1. against the reference response (ref_freq_response.csv, computed with SciPy/SuperLU by
//     the data's authors) at every reference frequency inside the band;
//  2. on its own grid, 4x denser than the driver's and placed by a golden-ratio (Kronecker)
//     sequence in log f, which shares no frequency with the driver's grids.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/reference_response.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/run/config.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

// configs/ (label integration, run in CI) or configs/slow/ (label slow: runs of a minute or more,
// `ctest -L slow`), chosen at compile time.
#ifndef ECMOR_CONFIG_DIR
#define ECMOR_CONFIG_DIR "configs"
#endif
// The fewest configs the folder may hold: configs/ shipped 51 on 2026-11-29, so a folder that is
// missing, moved or emptied fails (TheConfigFolderIsThere) instead of instantiating no test.
// configs/slow/ may be empty.
#ifndef ECMOR_MIN_CONFIGS
#define ECMOR_MIN_CONFIGS 40
#endif

std::vector<std::string> config_files() {
  std::vector<std::string> out;
  const fs::path dir = fs::path(ECMOR_TEST_SOURCE_DIR) / ECMOR_CONFIG_DIR;
  if (!fs::is_directory(dir)) return out;  // configs/slow/ may be empty (git keeps no empty dir)
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".yaml") out.push_back(e.path().filename().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

class ConfigTarget : public ::testing::TestWithParam<std::string> {};

TEST_P(ConfigTarget, MeetsItsToleranceAndTheIndependentRecheckAgrees) {
  const fs::path config_path = fs::path(ECMOR_CONFIG_DIR) / GetParam();
  const RunConfig config = load_run_config(config_path);
  const fs::path check_dir = fs::temp_directory_path() /
                             ("ecmor_config_test_" + std::to_string(::getpid()) + "_" + GetParam());
  fs::remove_all(check_dir);
  // `ecmor check` is the regression runner users call on configs/; it puts the run into
  // <dir>/<config name>/.
  const std::string cmd = std::string(ECMOR_TEST_BINARY_DIR) + "/bin/ecmor check " +
                          config_path.string() + " -q -o " + check_dir.string() + " > " +
                          (check_dir.string() + ".log") + " 2>&1";
  const fs::path out = check_dir / config_path.stem();
  const int status = std::system(cmd.c_str());
  std::ifstream log(check_dir.string() + ".log");
  const std::string log_text((std::istreambuf_iterator<char>(log)), {});
  ASSERT_TRUE(WIFEXITED(status)) << log_text;
  ASSERT_EQ(WEXITSTATUS(status), 0) << "target or check budget not met:\n" << log_text;

  std::ifstream sj(out / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(sj);
  EXPECT_TRUE(summary["target_met"].get<bool>());
  EXPECT_LE(summary["verified_band_error"].get<double>(), config.tolerance);
  const Index order = summary["final_order"].get<Index>();

  const Model full = load_model(config.model);
  const ReducedModel reduced = read_reduced_model(out);
  ASSERT_EQ(size_of(reduced), order);
  const ErrorNorm norm = config.norm;
  auto relative = [&](const ComplexMatrix& H, const ComplexMatrix& Hr) {
    return matrix_norm(H - Hr, norm) / matrix_norm(H, norm);
  };

  // 1. Against the independent reference response, where the band covers it. A model whose
  // info.json names a reference (every benchmark model in models/ but mna5) must have it: a
  // missing file would otherwise skip this check without a word.
  const fs::path ref_path = config.model.path / "ref_freq_response.csv";
  if (std::ifstream info(config.model.path / "info.json"); info) {
    const nlohmann::json j = nlohmann::json::parse(info);
    if (j.contains("reference") && !j["reference"].is_null()) {
      ASSERT_TRUE(fs::exists(ref_path))
          << GetParam() << ": info.json names a reference response, " << ref_path << " is missing";
    }
  }
  Index checked = 0;
  if (fs::exists(ref_path)) {
    const test::ReferenceResponse ref =
        test::read_reference_response(ref_path, outputs_of(full), inputs_of(full));
    for (std::size_t k = 0; k < ref.omega.size(); ++k) {
      const double f = ref.omega[k] / kTwoPi;
      if (f < config.band.f_min_hz || f > config.band.f_max_hz) continue;
      const ComplexMatrix Hr = transfer_function(reduced, s_from_hz(f));
      // The reference itself is accurate to ~1e-12 relative; allow that much on top.
      EXPECT_LE(relative(ref.H[k], Hr), config.tolerance * (1.0 + 1e-9) + 1e-10)
          << GetParam() << " at f = " << f << " Hz (reference)";
      ++checked;
    }
  }

  if (fs::exists(ref_path)) {
    EXPECT_GT(checked, 0) << GetParam() << ": the band holds no reference frequency";
  }

  // 2. A denser grid of our own: Kronecker sequence x_k = frac(k / phi) in log f.
  auto solver = make_shifted_solver(full);
  const Index n = 4 * config.error.grid_points;
  const double phi = 0.5 * (1.0 + std::sqrt(5.0));
  const double x0 = std::log(config.band.f_min_hz), x1 = std::log(config.band.f_max_hz);
  std::vector<double> f(static_cast<std::size_t>(n));
  for (Index k = 0; k < n; ++k) {
    const double u = std::fmod(static_cast<double>(k + 1) / phi, 1.0);
    f[static_cast<std::size_t>(k)] = std::exp(x0 + u * (x1 - x0));
  }
  const std::vector<ComplexMatrix> H = frequency_response(full, *solver, f);
  double worst = 0.0, f_worst = 0.0;
  for (std::size_t k = 0; k < f.size(); ++k) {
    const double e = relative(H[k], transfer_function(reduced, s_from_hz(f[k])));
    if (e > worst) {
      worst = e;
      f_worst = f[k];
    }
  }
  EXPECT_LE(worst, config.tolerance)
      << GetParam() << ": independent grid finds " << worst << " at " << f_worst << " Hz";
  RecordProperty("order", static_cast<int>(order));
  RecordProperty("reference_points", static_cast<int>(checked));
  std::cout << "[ config   ] " << GetParam() << ": order " << order << ", driver "
            << summary["band_error"].get<double>() << ", re-check " << worst << " (tolerance "
            << config.tolerance << ", " << checked << " reference points)\n";
  fs::remove_all(check_dir);
  fs::remove(check_dir.string() + ".log");
}

#if ECMOR_MIN_CONFIGS > 0
TEST(Configs, TheConfigFolderIsThere) {
  EXPECT_GE(config_files().size(), static_cast<std::size_t>(ECMOR_MIN_CONFIGS))
      << (fs::path(ECMOR_TEST_SOURCE_DIR) / ECMOR_CONFIG_DIR).string();
}
#endif

// configs/slow/ may hold none (ECMOR_MIN_CONFIGS 0 there).
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(ConfigTarget);
INSTANTIATE_TEST_SUITE_P(Configs, ConfigTarget, ::testing::ValuesIn(config_files()),
                         [](const ::testing::TestParamInfo<std::string>& param_info) {
                           std::string name =
                               param_info.param.substr(0, param_info.param.size() - 5);
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });

}  // namespace
}  // namespace ecmor
