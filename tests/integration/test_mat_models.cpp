// .mat models through the whole run: a benchmark model converted to a .mat file here (with matio
// directly) must reduce to the same order and the same band error as its Matrix Market twin,
// through the public driver; output.format: mat must write the reduced model and the bases the run
// wrote as .mtx, bit for bit; and the `ecmor` commands that load models (info, reduce, simulate)
// accept the .mat model.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "common/bitwise_equal.hpp"
#include "common/mat_test_file.hpp"
#include "common/plugin_registry.hpp"
#include "common/test_support.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/driver.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

using test::bitwise_equal;
using test::TempDir;

/// A benchmark model, its band (Hz) and tolerance, and the MAT version to convert it to.
struct Twin {
  const char* model;
  const char* band;
  double tolerance;
  mat_ft version;
};

std::ostream& operator<<(std::ostream& os, const Twin& t) { return os << t.model; }

/// The model of `dir` written as a .mat file (M, D, K sparse, B, C dense; or E, A, B, C).
fs::path convert(const fs::path& dir, const fs::path& file, mat_ft version) {
  test::MatTestFile f(file, version);
  f.model(load_model(dir));
  return file;
}

std::string yaml(const std::string& model, const Twin& t, const fs::path& out,
                 const std::string& format = "mtx") {
  return "model: " + model + "\nband: " + t.band +
         "\ntarget: {tolerance: " + std::to_string(t.tolerance) +
         "}\nreducer: {name: modal}\nstrategy: {name: grow_order, max_order: 40}\noutput: {dir: " +
         out.string() + ", format: " + format + "}\n";
}

class MatTwin : public ::testing::TestWithParam<Twin> {};

TEST_P(MatTwin, SameOrderAndBandErrorAsTheMtxModel) {
  const Twin& t = GetParam();
  TempDir tmp{"ecmor_test_mat_twin"};
  const fs::path dir = fs::path("models") / t.model;
  const fs::path mat = convert(dir, tmp / "model.mat", t.version);
  Registry& registry = test::plugin_registry("libecmor_modal.so");

  const RunSummary a = run_reduction(
      parse_run_config(yaml("{dir: " + dir.string() + "}", t, tmp / "mtx"), "mtx.yaml"), registry);
  const RunSummary b = run_reduction(
      parse_run_config(yaml("{file: " + mat.string() + "}", t, tmp / "mat"), "mat.yaml"), registry);
  ASSERT_TRUE(a.has_model) << a.message;
  ASSERT_TRUE(b.has_model) << b.message;
  EXPECT_EQ(a.termination, Termination::Converged) << a.message;
  EXPECT_EQ(b.termination, a.termination) << b.message;
  EXPECT_EQ(b.full_order, a.full_order);
  EXPECT_EQ(b.order, a.order);
  // The same matrices bit for bit, so the same arithmetic: equal, not merely close.
  EXPECT_EQ(b.band_error, a.band_error);
  EXPECT_EQ(b.verified_band_error, a.verified_band_error);
  EXPECT_LE(b.band_error, t.tolerance);

  // summary.json names the model as the YAML did.
  std::ifstream in(tmp / "mat" / "summary.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["model"]["file"], mat.string());
  EXPECT_FALSE(j["model"].contains("dir"));
  EXPECT_EQ(j["model"]["N"], a.full_order);
}

INSTANTIATE_TEST_SUITE_P(
    SharedModels, MatTwin,
    ::testing::Values(Twin{"lf10", "{f_min_hz: 15.9, f_max_hz: 1.59e6}", 1e-6, MAT_FT_MAT5},
                      Twin{"build", "{f_min_hz: 0.5, f_max_hz: 2.0}", 1e-3, MAT_FT_MAT73}),
    [](const auto& p) { return std::string(p.param.model); });

TEST(MatOutput, FormatBothWritesTheSameModelAndBasesAsTheMtxFiles) {
  TempDir tmp{"ecmor_test_mat_out"};
  const Twin t{"lf10", "{f_min_hz: 15.9, f_max_hz: 1.59e6}", 1e-6, MAT_FT_MAT5};
  const fs::path out = tmp / "run";
  const RunSummary s =
      run_reduction(parse_run_config(yaml("{dir: models/lf10}", t, out, "both"), "both.yaml"),
                    test::plugin_registry("libecmor_modal.so"));
  ASSERT_TRUE(s.has_model) << s.message;
  const fs::path mat = out / kReducedModelMatFile;
  // The .mtx files hold 17 significant digits, which read back bit for bit.
  const ReducedModel from_mat = read_reduced_model(mat);
  EXPECT_EQ(size_of(from_mat), s.order);
  EXPECT_TRUE(bitwise_equal(from_mat, read_reduced_model(out)));
  const Matrix V = test::mat_read_dense(mat, "V");
  EXPECT_EQ(V.cols(), s.order);
  EXPECT_TRUE(bitwise_equal(V, read_matrix_market_dense(out / "V.mtx")));
  // Modal truncation is a Galerkin projection: W.mtx repeats V, the .mat file leaves W out.
  EXPECT_TRUE(bitwise_equal(read_matrix_market_dense(out / "W.mtx"), V));
  const std::vector<std::string> names = test::mat_variable_names(mat);
  EXPECT_EQ(std::count(names.begin(), names.end(), "W"), 0);
}

// ------------------------------------------------------------ the executable

struct CliResult {
  int exit_code = -1;
  std::string out;
};

CliResult run_ecmor(const std::string& args, const fs::path& dir) {
  const fs::path log = dir / "ecmor.log";
  const std::string cmd = "env -u ECMOR_PLUGIN_PATH '" + std::string(ECMOR_TEST_BINARY_DIR) +
                          "/bin/ecmor' " + args + " </dev/null >'" + log.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(log);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1,
          std::string((std::istreambuf_iterator<char>(in)), {})};
}

TEST(MatCli, InfoReduceAndSimulateAcceptAMatModel) {
  TempDir tmp{"ecmor_test_mat_cli"};
  const fs::path mat = tmp / "lf10.mat";
  {
    // Renamed variables, as a user's own file might have them.
    test::MatTestFile f(mat, MAT_FT_MAT73);
    const auto so = std::get<SecondOrderModel>(load_model("models/lf10"));
    f.sparse("Mass", so.M);
    f.sparse("D", so.D);
    f.sparse("Stiff", so.K);
    f.dense("B", so.B);
    f.dense("C", so.C);
  }
  const CliResult renamed =
      run_ecmor("info '" + mat.string() + "' --eigenfrequencies 0", tmp.path());
  EXPECT_EQ(renamed.exit_code, 1) << renamed.out;  // without the renames there is no model
  EXPECT_NE(renamed.out.find(mat.string() + ": no model variables"), std::string::npos)
      << renamed.out;
  const fs::path plain = convert("models/lf10", tmp / "plain.mat", MAT_FT_MAT5);
  const CliResult info =
      run_ecmor("info '" + plain.string() + "' --eigenfrequencies 2", tmp.path());
  EXPECT_EQ(info.exit_code, 0) << info.out;
  EXPECT_NE(info.out.find(plain.string() + ": second order model, N = 18"), std::string::npos)
      << info.out;
  EXPECT_NE(info.out.find("lowest 2 undamped eigenfrequencies"), std::string::npos) << info.out;

  const fs::path run_dir = tmp / "run";
  std::ofstream(tmp / "run.yaml")
      << "model: {file: " << mat.string() << ", variables: {M: Mass, K: Stiff}}\n"
      << "band: {f_min_hz: 15.9, f_max_hz: 1.59e6}\ntarget: {tolerance: 1.0e-6}\n"
      << "reducer: {name: modal}\nstrategy: {name: grow_order, max_order: 18}\n"
      << "output: {dir: " << run_dir.string() << ", format: mat}\n";
  const CliResult reduce =
      run_ecmor("reduce -q --no-plot '" + (tmp / "run.yaml").string() + "'", tmp.path());
  ASSERT_EQ(reduce.exit_code, 0) << reduce.out;
  EXPECT_TRUE(fs::exists(run_dir / kReducedModelMatFile));
  EXPECT_FALSE(fs::exists(run_dir / "Mr.mtx"));

  // plot reads the reduced model from the .mat file: its sigma_max must agree with the full
  // model's to the band error the run met (|sigma(Hr) - sigma(H)| <= ||H - Hr||_2).
  run_ecmor("plot '" + run_dir.string() + "' --format svg", tmp.path());
  std::ifstream csv(run_dir / "sigma.csv");
  std::string line;
  std::getline(csv, line);
  ASSERT_EQ(line, "f_hz,full_sigma_max,reduced_sigma_max,error_sigma_max");
  int rows = 0;
  for (; std::getline(csv, line); ++rows) {
    double f = 0, full = 0, reduced = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf", &f, &full, &reduced), 3) << line;
    EXPECT_LE(std::abs(reduced - full), 1e-6 * full) << line;
  }
  EXPECT_GT(rows, 10);

  // simulate finds the .mat model (with its renames) in summary.json and the reduced model in
  // the run directory's .mat file.
  const CliResult sim = run_ecmor("simulate '" + run_dir.string() + "' --steps 200", tmp.path());
  ASSERT_EQ(sim.exit_code, 0) << sim.out;
  std::ifstream in(run_dir / "time_error.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["steps"], 200);
}

}  // namespace
}  // namespace ecmor
