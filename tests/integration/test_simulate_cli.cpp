// End-to-end tests of `ecmor simulate RUN_DIR`: the real executable on run directories built by
// hand (summary.json with the model dir and the band, a reduced model written with
// write_reduced_model), so no reducer plugin is needed. A full-order "reduction" must give an
// output error at round-off level; a truncated model a visible one; the defaults follow the band;
// bad run directories and options exit 1 with a message naming the problem.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "common/run_ecmor.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

const fs::path kBuildSo = "models/build_so";

using Result = test::CliResult;
using test::read_text;

class SimulateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    m_dir = fs::temp_directory_path() /
            ("ecmor_simulate_cli_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(m_dir);
    fs::create_directories(m_dir);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(m_dir);
  }

  Result run(const std::vector<std::string>& args) { return test::run_ecmor(args, m_dir); }

  // A run directory for build_so with the band [0.1, 2] Hz and the model projected on the first
  // `order` unit vectors (order = N: the full-order "reduction").
  fs::path make_run(Index order) {
    const fs::path run_dir = m_dir / "run";
    fs::create_directories(run_dir);
    const Model full = load_model(kBuildSo);
    const Matrix V = Matrix::Identity(size_of(full), order);
    write_reduced_model(run_dir, project(full, V, V));
    nlohmann::json j;
    j["model"] = {{"dir", fs::absolute(kBuildSo).string()}};
    j["band"] = {{"f_min_hz", 0.1}, {"f_max_hz", 2.0}};
    std::ofstream(run_dir / "summary.json") << j.dump(2);
    return run_dir;
  }

  fs::path m_dir;
};

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

std::vector<std::string> read_lines(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST_F(SimulateCli, FullOrderReductionHasRoundOffErrorForEveryInput) {
  const fs::path run_dir = make_run(24);
  for (const char* input : {"step", "impulse", "chirp"}) {
    const Result r = run({"simulate", run_dir.string(), "--input", input, "--t-end", "10",
                          "--steps", "2000", "--chirp-hz", "0.05,2"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::vector<std::string> lines = read_lines(run_dir / "time_response.csv");
    ASSERT_EQ(lines.size(), 2002u);
    EXPECT_EQ(lines[0], "t,y1,yr1");
    const nlohmann::json j = read_json(run_dir / "time_error.json");
    SCOPED_TRACE(input);
    EXPECT_EQ(j["input"]["kind"], input);
    EXPECT_EQ(j["steps"], 2000);
    EXPECT_DOUBLE_EQ(j["dt"].get<double>(), 10.0 / 2000);
    EXPECT_TRUE(j["error"]["relative_defined"].get<bool>());
    EXPECT_LT(j["error"]["relative_max"].get<double>(), 1e-12);
    EXPECT_LT(j["error"]["relative_l2"].get<double>(), 1e-12);
    EXPECT_GT(j["error"]["y_max"].get<double>(), 0.0);
    EXPECT_EQ(j["full"]["factorizations"], 2);
    EXPECT_EQ(j["full"]["N"], 24);
    EXPECT_EQ(j["reduced"]["n"], 24);
    EXPECT_NE(r.out.find("output error y - yr"), std::string::npos) << r.out;
  }
}

TEST_F(SimulateCli, TruncatedModelShowsTheErrorAndDefaultsFollowItsPoles) {
  const fs::path run_dir = make_run(6);
  const Result r =
      run({"simulate", run_dir.string(), "--scheme", "generalized-alpha", "--rho-inf", "0.8"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = read_json(run_dir / "time_error.json");
  // The span follows the reduced model's slowest decaying term, within 5 periods of f_min =
  // 0.1 Hz (50 s): its time constant is that of a pole of the reduced model (computed here by
  // the QZ algorithm on the pencil, not by the eigensolver the suggestion uses).
  const nlohmann::json& span = j["span"];
  ASSERT_TRUE(span["from_poles"].get<bool>()) << span.dump();
  const double tau = span["tau_slow"].get<double>();
  EXPECT_DOUBLE_EQ(j["t_end"].get<double>(), std::min(50.0, 5.0 * tau));
  double nearest = 1.0;
  for (const Complex& p : poles(read_reduced_model(run_dir)))
    nearest = std::min(nearest, std::abs(-p.real() * tau - 1.0));
  EXPECT_LT(nearest, 1e-8) << "tau = " << tau;
  // 20 steps per period of the fastest term, at most f_max = 2 Hz, at least 200 steps.
  EXPECT_LE(span["f_fast_hz"].get<double>(), 2.0);
  EXPECT_EQ(j["steps"].get<long>(),
            std::max(200L, static_cast<long>(std::ceil(20.0 * span["f_fast_hz"].get<double>() *
                                                       j["t_end"].get<double>()))));
  EXPECT_EQ(j["scheme"], "generalized-alpha");
  EXPECT_EQ(j["input"]["kind"], "step");
  EXPECT_GT(j["error"]["relative_max"].get<double>(), 1e-6);
  EXPECT_EQ(j["reduced"]["n"], 6);
  // The CSV holds y and yr: recompute the max error from it (printed with 17 digits).
  const std::vector<std::string> lines = read_lines(run_dir / "time_response.csv");
  double max_e = 0.0;
  for (std::size_t k = 1; k < lines.size(); ++k) {
    std::stringstream ss(lines[k]);
    std::string t, y, yr;
    std::getline(ss, t, ',');
    std::getline(ss, y, ',');
    std::getline(ss, yr, ',');
    max_e = std::max(max_e, std::abs(std::stod(y) - std::stod(yr)));
  }
  EXPECT_NEAR(max_e, j["error"]["max"].get<double>(), 1e-15 + 1e-12 * max_e);
  // The plot of both outputs and the error (when gnuplot is installed, as scripts/setup.sh does).
  if (std::system("command -v gnuplot >/dev/null 2>&1") == 0) {
    const std::string svg = read_text(run_dir / "time_response.svg");
    const std::size_t end = svg.rfind("</svg>");
    ASSERT_NE(end, std::string::npos) << "not an SVG";
    EXPECT_EQ(svg.find_first_not_of(" \n", end + 6), std::string::npos) << "truncated";
    for (const char* series : {"y1 full", "y1 reduced", "y1 - yr1"}) {
      EXPECT_NE(svg.find(series), std::string::npos) << series;
    }
    std::ifstream png(run_dir / "time_response.png", std::ios::binary);
    char magic[8] = {};
    png.read(magic, 8);
    EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  }
  fs::remove(run_dir / "time_response.svg");
  EXPECT_EQ(run({"simulate", run_dir.string(), "--no-plot", "-q"}).exit_code, 0);
  EXPECT_FALSE(fs::exists(run_dir / "time_response.svg"));
}

// The README's first command reduces the shipped example; `ecmor simulate` on its output must show
// the step response, not a flat line: with the default span most of the change of y happens in
// its first half (the response has settled), and not within its first 0.1 % (the transient is
// resolved, not squeezed against t = 0). The band's 5 / f_min = 500 000 s did the latter.
TEST_F(SimulateCli, TheShippedExampleShowsItsTransient) {
  const fs::path run_dir = m_dir / "example";
  const Result reduce = run({"reduce", "configs/triplechain_saak09_n451.yaml", "-o",
                             run_dir.string(), "--no-plot", "-q"});
  ASSERT_EQ(reduce.exit_code, 0) << reduce.err;
  const Result r = run({"simulate", run_dir.string(), "--no-plot"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<std::string> lines = read_lines(run_dir / "time_response.csv");
  ASSERT_GT(lines.size(), 200u);
  std::vector<double> t, y;
  for (std::size_t k = 1; k < lines.size(); ++k) {
    std::stringstream ss(lines[k]);
    std::string tk, yk;
    std::getline(ss, tk, ',');
    std::getline(ss, yk, ',');
    t.push_back(std::stod(tk));
    y.push_back(std::stod(yk));
  }
  const double t_end = t.back();
  auto y_at = [&](double when) {
    const auto it = std::lower_bound(t.begin(), t.end(), when);
    return y[static_cast<std::size_t>(it - t.begin())];
  };
  const double change = y.back() - y.front();
  ASSERT_GT(std::abs(change), 0.0);
  EXPECT_LE(std::abs(y.back() - y_at(0.5 * t_end)), 0.1 * std::abs(change))
      << "the response has not settled by the middle of the span, t_end = " << t_end;
  EXPECT_LE(std::abs(y_at(1e-3 * t_end) - y.front()), 0.5 * std::abs(change))
      << "half the change happens in the first 0.1 % of the span, t_end = " << t_end;
  EXPECT_NE(r.out.find("span: 5 time constants"), std::string::npos) << r.out;
}

TEST_F(SimulateCli, BadRunDirectoriesAndOptionsAreNamed) {
  Result r = run({"simulate", (m_dir / "nothing").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no such run directory"), std::string::npos) << r.err;

  fs::create_directories(m_dir / "empty");
  r = run({"simulate", (m_dir / "empty").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("summary.json: missing"), std::string::npos) << r.err;

  std::ofstream(m_dir / "empty" / "summary.json") << R"({"band": {"f_min_hz": 1, "f_max_hz": 2}})";
  r = run({"simulate", (m_dir / "empty").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("needs model.dir"), std::string::npos) << r.err;

  const fs::path run_dir = make_run(24);
  r = run({"simulate", run_dir.string(), "--input", "ramp"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("input = 'ramp': must be one of step, impulse, chirp"), std::string::npos)
      << r.err;
  r = run({"simulate", run_dir.string(), "--steps", "-5"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("steps = -5: must be in [1, 1e9]"), std::string::npos) << r.err;
  r = run({"simulate", run_dir.string(), "--input-index", "3"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("InputSignal::input = 3"), std::string::npos) << r.err;
  r = run({"simulate", run_dir.string(), "--input", "chirp", "--chirp-hz", "1,0"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("InputSignal::f1_hz = 0: must be finite and > 0"), std::string::npos)
      << r.err;
  r = run({"simulate", run_dir.string(), "--time-axis", "sideways"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--time-axis = sideways: must be auto, linear or log"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(run_dir / "time_error.json")) << "an error must not look like a result";
}

}  // namespace
}  // namespace ecmor
