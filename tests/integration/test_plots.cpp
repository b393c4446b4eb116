// The plots of `ecmor reduce` / `ecmor plot` and the charts of `ecmor bench`, through the real
// executable: the images must be valid PNG (signature, IHDR size) and SVG (well-formed ends, the
// series titles in the key), the numbers behind them must be the run's (sigma.csv against
// band_error.csv and against an independent dense evaluation of the reduced model), and the bench
// chart data must match the bench table row by row. The Pareto front is tested as a pure function.
//
// Output directories contain a space and a single quote: gnuplot must get them without a shell.
// When gnuplot is not installed, the image tests are skipped with the reason.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/run_ecmor.hpp"
#include "ecmor/base/types.hpp"
#include "ecmor/model/model_io.hpp"
#include "pareto.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

const fs::path kLf10Config = "configs/lf10.yaml";
const fs::path kLf10 = "models/lf10";

using Result = test::CliResult;
using test::read_text;

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  ASSERT_TRUE(out.good()) << "cannot write " << path;
}

// Splits one CSV line; fields in double quotes may contain commas (RFC 4180).
std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      fields.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

// A CSV file as a list of rows keyed by the header's column names.
std::vector<std::map<std::string, std::string>> read_csv(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::map<std::string, std::string>> rows;
  if (!std::getline(in, line)) return rows;
  const std::vector<std::string> header = split_csv(line);
  while (std::getline(in, line)) {
    const std::vector<std::string> f = split_csv(line);
    EXPECT_EQ(f.size(), header.size()) << path << ": " << line;
    std::map<std::string, std::string> row;
    for (std::size_t k = 0; k < header.size() && k < f.size(); ++k) row[header[k]] = f[k];
    rows.push_back(row);
  }
  return rows;
}

double number(const std::string& s) { return std::strtod(s.c_str(), nullptr); }

bool have_gnuplot() { return std::system("command -v gnuplot >/dev/null 2>&1") == 0; }

#define REQUIRE_GNUPLOT()                                                                \
  do {                                                                                   \
    if (!have_gnuplot()) GTEST_SKIP() << "gnuplot is not on PATH (install gnuplot-nox)"; \
  } while (false)

// Width and height from a PNG's IHDR chunk; {0, 0} when the file is not a PNG.
std::pair<std::uint32_t, std::uint32_t> png_size(const fs::path& path) {
  const std::string b = read_text(path);
  const std::string signature = "\x89PNG\r\n\x1a\n";
  if (b.size() < 24 || b.compare(0, 8, signature) != 0 || b.compare(12, 4, "IHDR") != 0) {
    return {0, 0};
  }
  auto be32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t k = 0; k < 4; ++k) v = (v << 8) | static_cast<unsigned char>(b[at + k]);
    return v;
  };
  return {be32(16), be32(20)};
}

// An SVG as gnuplot writes it: XML declaration or <svg> first, </svg> last.
::testing::AssertionResult is_svg(const fs::path& path) {
  std::string s = read_text(path);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  if (s.rfind("<?xml", 0) != 0 && s.rfind("<svg", 0) != 0) {
    return ::testing::AssertionFailure() << path << " does not start like an SVG";
  }
  if (s.find("<svg") == std::string::npos) {
    return ::testing::AssertionFailure() << path << " has no <svg> element";
  }
  if (s.size() < 6 || s.compare(s.size() - 6, 6, "</svg>") != 0) {
    return ::testing::AssertionFailure() << path << " does not end with </svg>";
  }
  return ::testing::AssertionSuccess();
}

// Runs `ecmor ARGS...` from the project root; `env` is prepended (e.g. "PATH=/nonexistent").
Result run_ecmor(const fs::path& scratch, const std::vector<std::string>& args,
                 const std::string& env = "") {
  return test::run_ecmor(args, scratch, env);
}

// One `ecmor reduce configs/lf10.yaml` for the whole suite (its outputs are only read).
class Plots : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    s_root = fs::temp_directory_path() / ("ecmor plots '" + std::to_string(::getpid()) + "'");
    fs::remove_all(s_root);
    fs::create_directories(s_root);
    s_run = s_root / "lf10 run";
    s_reduce = run_ecmor(s_root, {"reduce", kLf10Config.string(), "-o", s_run.string(), "-q"});
  }
  static void TearDownTestSuite() {
    if (!::testing::UnitTest::GetInstance()->Failed()) fs::remove_all(s_root);
  }
  void SetUp() override {
    ASSERT_EQ(s_reduce.exit_code, 0) << s_reduce.out << s_reduce.err;
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    m_dir = s_root / info->name();
    fs::create_directories(m_dir);
  }

  // A copy of the run's files (not its images) in a fresh directory, for `ecmor plot`.
  fs::path copy_of_run(const std::string& name) const {
    const fs::path dir = m_dir / name;
    fs::create_directories(dir);
    for (const auto& e : fs::directory_iterator(s_run)) {
      const std::string ext = e.path().extension().string();
      if (ext == ".png" || ext == ".svg" || ext == ".gp") continue;
      fs::copy_file(e.path(), dir / e.path().filename());
    }
    return dir;
  }

  static inline fs::path s_root, s_run;
  static inline Result s_reduce;
  fs::path m_dir;
};

TEST_F(Plots, ReduceWritesValidPngAndSvgWithTheExpectedSeries) {
  REQUIRE_GNUPLOT();
  const Index order = nlohmann::json::parse(read_text(s_run / "summary.json"))["final_order"];
  struct Expected {
    std::string name;
    std::uint32_t width, height;
    std::vector<std::string> titles;
  };
  const std::vector<Expected> plots = {
      {"sigma",
       1000,
       600,
       {"full model", "reduced model (order " + std::to_string(order) + ")",
        "error sigma_max(H - Hr)"}},
      {"error", 1000, 600, {"eps_2(f)", "eps_F(f)", "tolerance 1e-06"}},
      {"convergence", 1200, 550, {"band error", "reported model (verified)", "tolerance 1e-06"}},
  };
  for (const Expected& p : plots) {
    const auto [w, h] = png_size(s_run / (p.name + ".png"));
    EXPECT_EQ(w, p.width) << p.name << ".png";
    EXPECT_EQ(h, p.height) << p.name << ".png";
    EXPECT_TRUE(is_svg(s_run / (p.name + ".svg")));
    const std::string svg = read_text(s_run / (p.name + ".svg"));
    for (const std::string& t : p.titles) {
      EXPECT_NE(svg.find(t), std::string::npos) << p.name << ".svg lacks the series '" << t << "'";
    }
    // The script stays beside the images so a user can restyle and re-render.
    EXPECT_TRUE(fs::is_regular_file(s_run / (p.name + ".gp"))) << p.name;
    EXPECT_FALSE(fs::exists(s_run / (p.name + ".gp.log"))) << "gnuplot complained on " << p.name;
  }
  // Data and scripts are written atomically: no temporary file is left behind.
  for (const auto& e : fs::directory_iterator(s_run)) {
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  }
}

// Hr(s) = C (s^2 M + s D + K)^-1 B (second order) or C (s E - A)^-1 B by a dense LU, independent
// of the Hessenberg evaluator the plot uses.
Eigen::MatrixXcd dense_response(const ReducedModel& model, Complex s) {
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model)) {
    const Eigen::MatrixXcd P =
        s * s * so->M.cast<Complex>() + s * so->D.cast<Complex>() + so->K.cast<Complex>();
    Eigen::MatrixXcd C = so->C.cast<Complex>();
    if (so->has_velocity_output()) C += s * so->Cv.cast<Complex>();
    return C * P.fullPivLu().solve(so->B.cast<Complex>());
  }
  const auto& ds = std::get<ReducedDescriptorModel>(model);
  const Eigen::MatrixXcd P = s * ds.E.cast<Complex>() - ds.A.cast<Complex>();
  return ds.C.cast<Complex>() * P.fullPivLu().solve(ds.B.cast<Complex>());
}

// sigma.csv of `run`: the run's own full-model sigma_max and a reduced one that matches a dense
// evaluation of the written reduced model at the first, middle and last frequency.
void expect_sigma_csv_of(const fs::path& run) {
  const auto sigma = read_csv(run / "sigma.csv");
  const auto band = read_csv(run / "band_error.csv");
  ASSERT_EQ(sigma.size(), band.size());
  ASSERT_GE(sigma.size(), 3u);
  for (std::size_t k = 0; k < sigma.size(); ++k) {
    // Same frequencies and the run's own full-model sigma_max, read back to the same double.
    EXPECT_EQ(number(sigma[k].at("f_hz")), number(band[k].at("f_hz"))) << "row " << k;
    EXPECT_EQ(number(sigma[k].at("full_sigma_max")), number(band[k].at("reference_spectral")))
        << "row " << k;
    EXPECT_EQ(number(sigma[k].at("error_sigma_max")), number(band[k].at("absolute_spectral")))
        << "row " << k;
  }
  const ReducedModel reduced = read_reduced_model(run);
  double peak = 0.0;
  for (const auto& row : sigma) peak = std::max(peak, number(row.at("reduced_sigma_max")));
  for (const std::size_t k : {std::size_t{0}, sigma.size() / 2, sigma.size() - 1}) {
    const double f_hz = number(sigma[k].at("f_hz"));
    const Eigen::MatrixXcd H = dense_response(reduced, Complex(0.0, kTwoPi * f_hz));
    const double expected = Eigen::JacobiSVD<Eigen::MatrixXcd>(H).singularValues()(0);
    const double got = number(sigma[k].at("reduced_sigma_max"));
    // Resolution: 1e-8 relative, or rounding of the largest response in the band (the run
    // evaluates through a Hessenberg form, accurate relative to ||H|| over the band, not to a
    // value decades below it: lf10's band top is 8.9e-11, where the two evaluations differed by
    // 2e-8 relative under OpenBLAS, 1.9e-18 absolute).
    EXPECT_NEAR(got, expected, 1e-8 * expected + 1e-14 * peak) << "f = " << f_hz << " Hz";
    // And the reduced curve is the full one within the run's error: |s_full - s_red| <= ||H - Hr||,
    // up to the 10 significant digits band_error.csv stores the full sigma_max with.
    const double full = number(sigma[k].at("full_sigma_max"));
    EXPECT_LE(std::abs(full - got), number(sigma[k].at("error_sigma_max")) + 1e-9 * full)
        << "f = " << f_hz << " Hz";
  }
}

TEST_F(Plots, SigmaCsvHoldsTheRunsFullAndAnIndependentReducedSigmaMax) {
  // lf10: a second-order reduced model, one input and output.
  ASSERT_TRUE(std::holds_alternative<ReducedSecondOrderModel>(read_reduced_model(s_run)));
  expect_sigma_csv_of(s_run);
}

TEST_F(Plots, SigmaCsvOfAFirstOrderMimoRun) {
  // rail_371: a descriptor model with 7 inputs and 6 outputs, where sigma_max is a real SVD.
  const fs::path run = m_dir / "rail";
  const Result r = run_ecmor(m_dir, {"reduce", "configs/rail_371.yaml", "-o", run.string(), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const ReducedModel reduced = read_reduced_model(run);
  ASSERT_TRUE(std::holds_alternative<ReducedDescriptorModel>(reduced));
  ASSERT_GT(inputs_of(reduced), 1);
  ASSERT_GT(outputs_of(reduced), 1);
  expect_sigma_csv_of(run);
}

TEST_F(Plots, ConvergenceCsvIsTheHistory) {
  const auto conv = read_csv(s_run / "convergence.csv");
  const auto hist = read_csv(s_run / "history.csv");
  ASSERT_EQ(conv.size(), hist.size());
  ASSERT_FALSE(conv.empty());
  for (std::size_t k = 0; k < conv.size(); ++k) {
    EXPECT_EQ(conv[k].at("iteration"), hist[k].at("iteration"));
    EXPECT_EQ(conv[k].at("order"), hist[k].at("order"));
    EXPECT_EQ(number(conv[k].at("band_error")), number(hist[k].at("band_error")));
    EXPECT_EQ(conv[k].at("meets_tolerance") == "1", hist[k].at("meets_tolerance") == "true");
  }
}

TEST_F(Plots, PlotWithoutSummaryFailsNamingTheFile) {
  const fs::path empty = m_dir / "empty";
  fs::create_directories(empty);
  Result r = run_ecmor(m_dir, {"plot", empty.string()});
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.err.find((empty / "summary.json").string()), std::string::npos) << r.err;

  // summary.json present, band_error.csv missing: that one is named.
  const fs::path partial = m_dir / "partial";
  fs::create_directories(partial);
  fs::copy_file(s_run / "summary.json", partial / "summary.json");
  r = run_ecmor(m_dir, {"plot", partial.string()});
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.err.find((partial / "band_error.csv").string()), std::string::npos) << r.err;
}

TEST_F(Plots, HistoryWithoutAColumnFailsNamingFileLineAndRule) {
  const fs::path run = copy_of_run("bad history");
  std::string history = read_text(run / "history.csv");
  const std::size_t at = history.find(",meets_tolerance,");
  ASSERT_NE(at, std::string::npos) << history;
  history.replace(at, 17, ",met,");
  write_text(run / "history.csv", history);
  const Result r = run_ecmor(m_dir, {"plot", run.string()});
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.err.find((run / "history.csv").string() +
                       ":1: no column 'meets_tolerance': a history.csv header names iteration,"),
            std::string::npos)
      << r.err;
}

TEST_F(Plots, FormatSvgWritesNoPng) {
  REQUIRE_GNUPLOT();
  const fs::path dir = copy_of_run("svg only");
  const Result r = run_ecmor(m_dir, {"plot", dir.string(), "--format", "svg"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const std::string name : {"sigma", "error", "convergence"}) {
    EXPECT_TRUE(is_svg(dir / (name + ".svg")));
    EXPECT_FALSE(fs::exists(dir / (name + ".png"))) << name;
  }
  const fs::path png_dir = copy_of_run("png only");
  ASSERT_EQ(run_ecmor(m_dir, {"plot", png_dir.string(), "--format", "png"}).exit_code, 0);
  for (const std::string name : {"sigma", "error", "convergence"}) {
    EXPECT_NE(png_size(png_dir / (name + ".png")).first, 0u) << name;
    EXPECT_FALSE(fs::exists(png_dir / (name + ".svg"))) << name;
  }
}

TEST_F(Plots, UnknownFormatIsAnError) {
  const Result r = run_ecmor(m_dir, {"plot", s_run.string(), "--format", "jpeg"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("'jpeg'"), std::string::npos) << r.err;
}

TEST_F(Plots, MissingGnuplotFailsPlotButOnlyNotesInReduce) {
  const fs::path dir = copy_of_run("no gnuplot");
  const Result plot = run_ecmor(m_dir, {"plot", dir.string()}, "PATH=/nonexistent");
  EXPECT_EQ(plot.exit_code, 1) << plot.out << plot.err;
  EXPECT_NE(plot.err.find("gnuplot not found"), std::string::npos) << plot.err;

  const fs::path out = m_dir / "reduce";
  const Result reduce =
      run_ecmor(m_dir, {"reduce", kLf10Config.string(), "-o", out.string()}, "PATH=/nonexistent");
  EXPECT_EQ(reduce.exit_code, 0) << reduce.out << reduce.err;
  EXPECT_NE(reduce.out.find("note: gnuplot not found"), std::string::npos) << reduce.out;
  EXPECT_NE(reduce.out.find(out.string()), std::string::npos) << "the note says where the data is";
  EXPECT_TRUE(fs::is_regular_file(out / "sigma.csv"));
  EXPECT_TRUE(fs::is_regular_file(out / "error.gp"));
  EXPECT_FALSE(fs::exists(out / "error.png"));
}

TEST_F(Plots, NoPlotWritesNoPlots) {
  const fs::path out = m_dir / "reduce";
  const Result r =
      run_ecmor(m_dir, {"reduce", kLf10Config.string(), "-o", out.string(), "-q", "--no-plot"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_TRUE(fs::is_regular_file(out / "band_error.csv"));
  for (const std::string f : {"sigma.csv", "sigma.png", "error.svg", "convergence.gp"}) {
    EXPECT_FALSE(fs::exists(out / f)) << f;
  }
}

// ---------------------------------------------------------------- Pareto front (pure)

using app::pareto_front;
using app::TradeoffPoint;

TEST(Pareto, DominatedPointsAreExcluded) {
  // (1, 1e-2) and (3, 1e-4) trade off; (2, 1e-2) is dominated by (1, 1e-2), (4, 1e-3) by (3, 1e-4).
  const std::vector<TradeoffPoint> p = {{1, 1e-2}, {2, 1e-2}, {3, 1e-4}, {4, 1e-3}};
  EXPECT_EQ(pareto_front(p), (std::vector<bool>{true, false, true, false}));
}

TEST(Pareto, TiesAreAllOnTheFront) {
  const std::vector<TradeoffPoint> p = {{1, 1e-3}, {1, 1e-3}, {2, 1e-3}};
  EXPECT_EQ(pareto_front(p), (std::vector<bool>{true, true, false}));
  // Same time, different error: the worse one is dominated.
  EXPECT_EQ(pareto_front({{1, 1e-3}, {1, 1e-4}}), (std::vector<bool>{false, true}));
}

TEST(Pareto, SinglePointIsTheFront) {
  EXPECT_EQ(pareto_front({{5, 0.1}}), std::vector<bool>{true});
  EXPECT_TRUE(pareto_front({}).empty());
}

TEST(Pareto, FailedRunsAreNeverOnTheFrontNorDominate) {
  // The failed run has the best numbers (a run that threw at once): it neither joins the front
  // nor pushes the real runs off it. Non-finite errors are treated the same way.
  const std::vector<TradeoffPoint> p = {
      {0.0, 0.0, false}, {1, 1e-2}, {2, 1e-3}, {0.5, std::nan(""), true}};
  EXPECT_EQ(pareto_front(p), (std::vector<bool>{false, true, true, false}));
}

// ---------------------------------------------------------------- bench charts

TEST_F(Plots, BenchChartsMatchTheTableAndShowFailedRuns) {
  // Two tolerances of lf10, plus a config whose reducer does not exist: two failed rows.
  const fs::path good = m_dir / "lf10.yaml";
  const std::string model = fs::absolute(kLf10).string();
  write_text(good, "model:    {dir: " + model +
                       "}\n"
                       "band:     {f_min_hz: 15.9, f_max_hz: 1.59e6}\n"
                       "target:   {tolerance: 1.0e-3}\n"
                       "reducer:  {name: modal}\n"
                       "strategy: {name: grow_order, max_order: 18}\n"
                       "output:   {dir: unused}\n");
  std::string bad_text = read_text(good);
  bad_text.replace(bad_text.find("modal"), 5, "no_such_reducer");
  const fs::path bad = m_dir / "bad.yaml";
  write_text(bad, bad_text);
  // A second model with the same method: its own panel, the same series (colour and marker).
  const fs::path other = m_dir / "build_so.yaml";
  write_text(other, "model:    {dir: " + fs::absolute("models/build_so").string() +
                        "}\n"
                        "band:     {f_min_hz: 0.1, f_max_hz: 10}\n"
                        "target:   {tolerance: 1.0e-3}\n"
                        "reducer:  {name: modal}\n"
                        "strategy: {name: grow_order, max_order: 24}\n"
                        "output:   {dir: unused}\n");
  const fs::path out = m_dir / "bench out";
  const Result r = run_ecmor(m_dir, {"bench", good.string(), bad.string(), other.string(), "-t",
                                     "1e-3,1e-6", "-o", out.string()});
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  // Progress lines carry the elapsed time since the bench started.
  EXPECT_NE(r.out.find("[1/6 "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("s elapsed"), std::string::npos) << r.out;

  const auto table = read_csv(out / "bench.csv");
  const auto chart = read_csv(out / "bench_chart.csv");
  ASSERT_EQ(table.size(), 6u);
  ASSERT_EQ(chart.size(), table.size());
  std::vector<TradeoffPoint> points;
  for (std::size_t k = 0; k < table.size(); ++k) {
    const auto& t = table[k];
    const auto& c = chart[k];
    EXPECT_EQ(c.at("run"), std::to_string(k + 1));
    for (const std::string col : {"reducer", "strategy", "tolerance", "order",
                                  "verified_band_error", "seconds", "reducer_seconds"}) {
      EXPECT_EQ(c.at(col), t.at(col)) << "row " << k << " column " << col;
    }
    const bool failed = t.at("termination") == "error" || t.at("termination") == "failed";
    const std::string status = failed ? "failed" : t.at("target_met") == "1" ? "met" : "missed";
    EXPECT_EQ(c.at("status"), status) << "row " << k;
    EXPECT_EQ(c.at("label"), t.at("reducer") + " / " + t.at("strategy"));
    points.push_back({number(t.at("seconds")), number(t.at("verified_band_error")), !failed});
  }
  EXPECT_EQ(chart[2].at("status"), "failed");
  EXPECT_EQ(chart[3].at("status"), "failed");
  // The Pareto column is the front of the table's own numbers, one front per model; failed rows
  // are never on it.
  for (std::size_t k = 0; k < 4; ++k) ASSERT_EQ(table[k].at("model"), "lf10");
  for (std::size_t k = 4; k < 6; ++k) ASSERT_EQ(table[k].at("model"), "build_so");
  const std::vector<bool> front_lf10 = pareto_front({points.begin(), points.begin() + 4});
  const std::vector<bool> front_build = pareto_front({points.begin() + 4, points.end()});
  for (std::size_t k = 0; k < chart.size(); ++k) {
    const bool on = k < 4 ? front_lf10[k] : front_build[k - 4];
    EXPECT_EQ(chart[k].at("pareto"), on ? "1" : "0") << "row " << k;
  }
  EXPECT_EQ(chart[2].at("pareto"), "0");
  // One series per method across models: modal / grow_order is series 1 on both models (its
  // colour and marker in every panel), the failing reducer series 2.
  for (std::size_t k : {0u, 1u, 4u, 5u}) EXPECT_EQ(chart[k].at("series"), "1") << "row " << k;
  for (std::size_t k : {2u, 3u}) EXPECT_EQ(chart[k].at("series"), "2") << "row " << k;

  if (!have_gnuplot()) GTEST_SKIP() << "gnuplot is not on PATH: chart images not checked";
  for (const std::string name : {"bench_time_error", "bench_order_error"}) {
    const auto [w, h] = png_size(out / (name + ".png"));
    EXPECT_EQ(w, 1200u) << name;
    EXPECT_EQ(h, 650u) << name;
    ASSERT_TRUE(is_svg(out / (name + ".svg")));
    const std::string svg = read_text(out / (name + ".svg"));
    for (const std::string t :
         {"modal / grow_order", "no_such_reducer / grow_order", "FAILED (2 runs)",
          "no_such_reducer / grow_order tol 0.001", "tolerance ladder", "lf10", "build_so"}) {
      EXPECT_NE(svg.find(t), std::string::npos) << name << ".svg lacks '" << t << "'";
    }
    EXPECT_TRUE(fs::is_regular_file(out / (name + ".gp")));
  }
  EXPECT_NE(read_text(out / "bench_time_error.svg").find("Pareto front"), std::string::npos);
}

}  // namespace
}  // namespace ecmor
