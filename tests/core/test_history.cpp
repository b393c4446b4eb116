// The convergence history files: what is written reads back exactly (CSV with quoting, JSON lines
// with every field), and the files are complete after every append.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ecmor/base/error.hpp"
#include "ecmor/run/driver.hpp"
#include "ecmor/run/history.hpp"

namespace fs = std::filesystem;
using namespace ecmor;

namespace {

std::string read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// RFC 4180 reader, independent of the writer: fields separated by commas, records by newlines,
// quoted fields may contain both, "" is a literal quote.
std::vector<std::vector<std::string>> parse_csv(const std::string& text) {
  std::vector<std::vector<std::string>> rows(1);
  std::string field;
  bool quoted = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      rows.back().push_back(field);
      field.clear();
    } else if (c == '\n') {
      rows.back().push_back(field);
      field.clear();
      rows.emplace_back();
    } else {
      field += c;
    }
  }
  EXPECT_FALSE(quoted) << "unterminated quote";
  if (rows.back().empty() && field.empty()) rows.pop_back();  // trailing newline
  return rows;
}

IterationRecord sample_record(Index iteration) {
  IterationRecord r;
  r.iteration = iteration;
  r.phase = "grow";
  r.order = 10 * iteration;
  r.points = {{Complex(0.0, kTwoPi * 12.5), 2}, {Complex(3.1, 0.0), 1}};
  r.band_error = 1.0 / (3.0 * static_cast<double>(iteration));  // not a short decimal
  r.f_peak_hz = 0.123456789012345;
  r.meets_tolerance = iteration > 1;
  r.stable = iteration != 1;
  r.seconds = 0.5 * static_cast<double>(iteration);
  r.step_seconds = 0.5;
  r.counters.factorizations = 3 * iteration;
  r.counters.cholesky_factorizations = iteration;
  r.counters.solves = 40 * iteration;
  r.counters.factorization_seconds = 0.01;
  r.counters.solve_seconds = 0.002;
  r.full_evaluations = 200;
  r.sampling = "200 log grid + 12 poles + 50 refinement";
  r.note = "12 modes, 1 \"static\" correction";  // comma and quotes must survive CSV
  r.diagnostics = {{"orthogonality_loss", 1e-15}, {"eigen_residual", 2.5e-9}};
  return r;
}

class History : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    m_dir = fs::temp_directory_path() /
            ("ecmor_history_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(m_dir);
  }
  void TearDown() override { fs::remove_all(m_dir); }
  fs::path m_dir;
};

}  // namespace

TEST(FormatPoints, ImaginaryRealAndComplexPoints) {
  EXPECT_EQ(format_points({}), "-");
  EXPECT_EQ(format_points({{Complex(0.0, kTwoPi * 12.5), 2}}), "0+i12.5Hz x2");
  EXPECT_EQ(format_points({{Complex(3.1, 0.0), 1}}), "s=3.1");
  EXPECT_EQ(format_points({{Complex(0.0, 0.0), 3}}), "s=0 x3");
  EXPECT_EQ(format_points({{Complex(-0.0, kTwoPi * 2.0), 1}}), "0+i2Hz");  // no "-0"
  EXPECT_EQ(format_points({{Complex(-1.5, -kTwoPi * 4.0), 1}}), "-1.5-i4Hz");
  EXPECT_EQ(format_points({{Complex(0.0, kTwoPi * 1e-3), 1},
                           {Complex(2.0, 0.0), 4},
                           {Complex(0.0, kTwoPi * 250.0), 1}}),
            "0+i0.001Hz, s=2 x4, 0+i250Hz");
}

// The directory appears with the first record: a run refused before any record leaves none.
TEST_F(History, TheDirectoryIsCreatedAtTheFirstRecord) {
  RunHistory history(m_dir / "nested" / "out", true, nullptr);
  EXPECT_FALSE(fs::exists(m_dir / "nested"));
  EXPECT_TRUE(history.records().empty());
  history.append(sample_record(1));
  EXPECT_TRUE(fs::is_regular_file(m_dir / "nested" / "out" / "history.csv"));
  EXPECT_TRUE(fs::is_regular_file(m_dir / "nested" / "out" / "history.jsonl"));
}

// Without a directory (or on a rank that does not write) the records are kept, not written.
TEST_F(History, WithoutADirectoryTheRecordsAreOnlyKept) {
  RunHistory in_memory({}, true, nullptr);
  in_memory.append(sample_record(1));
  RunHistory not_writing(m_dir / "quiet", false, nullptr);
  not_writing.append(sample_record(1));
  EXPECT_EQ(in_memory.size(), 1);
  EXPECT_EQ(not_writing.size(), 1);
  EXPECT_FALSE(fs::exists(m_dir / "quiet"));
}

namespace {
/// Keeps what it is shown and says stop at the record numbered `stop_at`.
class Watcher : public RunObserver {
 public:
  explicit Watcher(Index stop_at) : m_stop_at(stop_at) {}
  bool on_iteration(const IterationRecord& r) override {
    seen.push_back(r.iteration);
    return r.iteration != m_stop_at;
  }
  std::vector<Index> seen;

 private:
  Index m_stop_at;
};
}  // namespace

// One path: every record is numbered over the whole run (whatever the strategy numbered it),
// kept, written and shown to the observer, whose answer append() returns.
TEST_F(History, RecordsAreNumberedOverTheRunAndShownToTheObserver) {
  Watcher watcher(2);
  RunHistory history(m_dir, true, &watcher);
  EXPECT_TRUE(history.append(sample_record(7)));   // a second member's first record
  EXPECT_FALSE(history.append(sample_record(1)));  // the observer stops at the second
  EXPECT_TRUE(history.append(sample_record(1)));
  EXPECT_EQ(watcher.seen, (std::vector<Index>{1, 2, 3}));
  ASSERT_EQ(history.size(), 3);
  for (Index i = 0; i < 3; ++i) EXPECT_EQ(history.records()[i].iteration, i + 1);
  EXPECT_EQ(parse_csv(read(m_dir / "history.csv")).size(), 4u);
  const std::vector<IterationRecord> released = history.release();
  EXPECT_EQ(released.size(), 3u);
  EXPECT_EQ(history.size(), 0);
}

TEST_F(History, CsvReadsBackExactly) {
  RunHistory writer(m_dir, true, nullptr);
  writer.append(sample_record(1));
  writer.append(sample_record(2));
  const auto rows = parse_csv(read(m_dir / "history.csv"));
  ASSERT_EQ(rows.size(), 3u);
  const std::vector<std::string> header = {"iteration",
                                           "phase",
                                           "order",
                                           "points",
                                           "band_error",
                                           "f_peak_hz",
                                           "meets_tolerance",
                                           "stable",
                                           "seconds",
                                           "step_seconds",
                                           "factorizations",
                                           "solves",
                                           "factorization_seconds",
                                           "solve_seconds",
                                           "full_evaluations",
                                           "sampling",
                                           "note"};
  EXPECT_EQ(rows[0], header);
  for (Index i = 1; i <= 2; ++i) {
    const IterationRecord expected = sample_record(i);
    const auto& row = rows[static_cast<std::size_t>(i)];
    ASSERT_EQ(row.size(), header.size());
    EXPECT_EQ(std::stoll(row[0]), expected.iteration);
    EXPECT_EQ(row[1], "grow");
    EXPECT_EQ(std::stoll(row[2]), expected.order);
    EXPECT_EQ(row[3], "0+i12.5Hz x2, s=3.1");
    // Doubles are written to round-trip: parsing gives the identical value.
    EXPECT_EQ(std::stod(row[4]), expected.band_error);
    EXPECT_EQ(std::stod(row[5]), expected.f_peak_hz);
    EXPECT_EQ(row[6], expected.meets_tolerance ? "true" : "false");
    EXPECT_EQ(row[7], expected.stable ? "true" : "false");
    EXPECT_EQ(std::stod(row[8]), expected.seconds);
    EXPECT_EQ(std::stod(row[9]), expected.step_seconds);
    EXPECT_EQ(std::stoll(row[10]), expected.counters.factorizations);
    EXPECT_EQ(std::stoll(row[11]), expected.counters.solves);
    EXPECT_EQ(std::stod(row[12]), expected.counters.factorization_seconds);
    EXPECT_EQ(std::stod(row[13]), expected.counters.solve_seconds);
    EXPECT_EQ(std::stoll(row[14]), expected.full_evaluations);
    EXPECT_EQ(row[15], expected.sampling);
    EXPECT_EQ(row[16], expected.note);
  }
}

TEST_F(History, JsonLinesCarryEveryField) {
  RunHistory writer(m_dir, true, nullptr);
  writer.append(sample_record(1));
  writer.append(sample_record(2));
  std::ifstream in(m_dir / "history.jsonl");
  std::string line;
  Index n = 0;
  while (std::getline(in, line)) {
    ++n;
    const IterationRecord e = sample_record(n);
    const nlohmann::json j = nlohmann::json::parse(line);  // one complete object per line
    EXPECT_EQ(j.at("iteration").get<Index>(), e.iteration);
    EXPECT_EQ(j.at("phase"), e.phase);
    EXPECT_EQ(j.at("order").get<Index>(), e.order);
    ASSERT_EQ(j.at("points").size(), 2u);
    EXPECT_EQ(j["points"][0].at("re").get<double>(), 0.0);
    EXPECT_EQ(j["points"][0].at("im").get<double>(), kTwoPi * 12.5);
    EXPECT_NEAR(j["points"][0].at("f_hz").get<double>(), 12.5, 1e-13);
    EXPECT_EQ(j["points"][0].at("moments").get<Index>(), 2);
    EXPECT_EQ(j["points"][1].at("re").get<double>(), 3.1);
    EXPECT_EQ(j["points"][1].at("f_hz").get<double>(), 0.0);
    EXPECT_EQ(j.at("band_error").get<double>(), e.band_error);
    EXPECT_EQ(j.at("f_peak_hz").get<double>(), e.f_peak_hz);
    EXPECT_EQ(j.at("meets_tolerance").get<bool>(), e.meets_tolerance);
    EXPECT_EQ(j.at("stable").get<bool>(), e.stable);
    EXPECT_EQ(j.at("seconds").get<double>(), e.seconds);
    EXPECT_EQ(j.at("step_seconds").get<double>(), e.step_seconds);
    const auto& c = j.at("counters");
    EXPECT_EQ(c.at("factorizations").get<Index>(), e.counters.factorizations);
    EXPECT_EQ(c.at("cholesky_factorizations").get<Index>(), e.counters.cholesky_factorizations);
    EXPECT_EQ(c.at("lu_factorizations").get<Index>(), 0);
    EXPECT_EQ(c.at("solves").get<Index>(), e.counters.solves);
    EXPECT_EQ(c.at("factorization_seconds").get<double>(), e.counters.factorization_seconds);
    EXPECT_EQ(c.at("solve_seconds").get<double>(), e.counters.solve_seconds);
    EXPECT_EQ(c.size(), 10u);  // every SolverCounters field
    EXPECT_EQ(j.at("full_evaluations").get<Index>(), e.full_evaluations);
    EXPECT_EQ(j.at("sampling"), e.sampling);
    EXPECT_EQ(j.at("note"), e.note);
    EXPECT_EQ(j.at("diagnostics").at("orthogonality_loss").get<double>(), 1e-15);
    EXPECT_EQ(j.at("diagnostics").at("eigen_residual").get<double>(), 2.5e-9);
  }
  EXPECT_EQ(n, 2);
}

TEST_F(History, NonFiniteValuesAreNamedNotNull) {
  RunHistory writer(m_dir, true, nullptr);
  IterationRecord r = sample_record(1);
  r.band_error = std::numeric_limits<double>::infinity();  // reduced model hit a pole
  r.f_peak_hz = std::numeric_limits<double>::quiet_NaN();
  r.points.clear();
  r.diagnostics = {{"x", -std::numeric_limits<double>::infinity()}};
  writer.append(r);
  std::ifstream in(m_dir / "history.jsonl");
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  const nlohmann::json j = nlohmann::json::parse(line);
  EXPECT_EQ(j.at("band_error"), "inf");
  EXPECT_EQ(j.at("f_peak_hz"), "nan");
  EXPECT_EQ(j.at("diagnostics").at("x"), "-inf");
  EXPECT_TRUE(j.at("points").is_array());
  EXPECT_TRUE(j.at("points").empty());
  const auto rows = parse_csv(read(m_dir / "history.csv"));
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1][3], "-");
  EXPECT_EQ(rows[1][4], "inf");
  EXPECT_EQ(rows[1][5], "nan");
}

TEST_F(History, FilesAreCompleteAfterEveryAppendAndNoTempFilesRemain) {
  RunHistory writer(m_dir, true, nullptr);
  for (Index i = 1; i <= 5; ++i) {
    IterationRecord r = sample_record(i);
    r.note = "line one\nline two";  // a newline inside a quoted field
    writer.append(r);
    EXPECT_EQ(parse_csv(read(m_dir / "history.csv")).size(), static_cast<std::size_t>(i + 1));
    std::ifstream in(m_dir / "history.jsonl");
    std::string line;
    Index lines = 0;
    while (std::getline(in, line)) {
      EXPECT_EQ(nlohmann::json::parse(line).at("note"), "line one\nline two");
      ++lines;
    }
    EXPECT_EQ(lines, i);
    EXPECT_EQ(writer.records().size(), static_cast<std::size_t>(i));
  }
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(m_dir))
    files.push_back(entry.path().filename().string());
  std::sort(files.begin(), files.end());
  EXPECT_EQ(files, (std::vector<std::string>{"history.csv", "history.jsonl"}));
}

// The files are replaced through uniquely named temporary files (atomic_file.hpp): whatever
// another writer or a killed run left under a fixed name ("history.csv.tmp", here a directory
// that cannot be opened as a file) does not stop the history. (The private writer history.cpp
// once had used exactly that name, and failed here with "cannot create .../history.csv.tmp".)
TEST_F(History, ALeftoverTemporaryNameDoesNotBlockTheFiles) {
  fs::create_directories(m_dir / "history.csv.tmp");
  fs::create_directories(m_dir / "history.jsonl.tmp");
  RunHistory writer(m_dir, true, nullptr);
  writer.append(sample_record(1));
  writer.append(sample_record(2));
  EXPECT_EQ(parse_csv(read(m_dir / "history.csv")).size(), 3u);
  EXPECT_TRUE(fs::is_directory(m_dir / "history.csv.tmp"));  // left alone
}

TEST_F(History, UnusableDirectoryIsAnIoErrorNamingIt) {
  fs::create_directories(m_dir);
  const fs::path file = m_dir / "a_file";
  std::ofstream(file) << "x";
  RunHistory history(file / "sub", true, nullptr);
  try {
    history.append(sample_record(1));
    FAIL() << "no IoError";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find((file / "sub").string()), std::string::npos) << e.what();
  }
}

// What RunHistory writes, read_history_csv reads back: every field the CSV carries, doubles
// bit for bit, text with commas, quotes and newlines intact.
TEST_F(History, CsvRoundTripsThroughTheReader) {
  RunHistory writer(m_dir, true, nullptr);
  std::vector<IterationRecord> written;
  for (Index i = 1; i <= 3; ++i) written.push_back(sample_record(i));
  written[1].note = "line one\nline two, \"quoted\"";
  written[2].band_error = std::numeric_limits<double>::infinity();
  written[2].f_peak_hz = std::numeric_limits<double>::quiet_NaN();
  written[2].points.clear();
  for (const IterationRecord& r : written) writer.append(r);

  const std::vector<HistoryCsvRow> rows = read_history_csv(m_dir / "history.csv");
  ASSERT_EQ(rows.size(), written.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const IterationRecord& e = written[k];
    const HistoryCsvRow& r = rows[k];
    EXPECT_EQ(r.iteration, e.iteration);
    EXPECT_EQ(r.phase, e.phase);
    EXPECT_EQ(r.order, e.order);
    EXPECT_EQ(r.points, format_points(e.points));
    if (std::isnan(e.band_error)) {
      EXPECT_TRUE(std::isnan(r.band_error));
    } else {
      EXPECT_EQ(r.band_error, e.band_error);
    }
    if (std::isnan(e.f_peak_hz)) {
      EXPECT_TRUE(std::isnan(r.f_peak_hz));
    } else {
      EXPECT_EQ(r.f_peak_hz, e.f_peak_hz);
    }
    EXPECT_EQ(r.meets_tolerance, e.meets_tolerance);
    EXPECT_EQ(r.stable, e.stable);
    EXPECT_EQ(r.seconds, e.seconds);
    EXPECT_EQ(r.step_seconds, e.step_seconds);
    EXPECT_EQ(r.factorizations, e.counters.factorizations);
    EXPECT_EQ(r.solves, e.counters.solves);
    EXPECT_EQ(r.factorization_seconds, e.counters.factorization_seconds);
    EXPECT_EQ(r.solve_seconds, e.counters.solve_seconds);
    EXPECT_EQ(r.full_evaluations, e.full_evaluations);
    EXPECT_EQ(r.sampling, e.sampling);
    EXPECT_EQ(r.note, e.note);
  }
  EXPECT_EQ(rows[2].points, "-");
  EXPECT_TRUE(std::isinf(rows[2].band_error));
}

namespace {

// The InputError of reading `text` as history.csv; empty when it reads.
std::string read_error(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  try {
    read_history_csv(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
}

// The text of a history.csv of one record, as RunHistory writes it into `dir`.
std::string one_record_csv(const fs::path& dir) {
  RunHistory writer(dir, true, nullptr);
  writer.append(sample_record(1));
  return read(dir / "history.csv");
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

}  // namespace

TEST_F(History, ReaderNamesFileLineAndRule) {
  const std::string good = one_record_csv(m_dir);
  const fs::path bad = m_dir / "bad.csv";
  const std::string file = bad.string();
  EXPECT_NE(
      read_error(bad, replaced(good, "band_error,", "error,"))
          .find(file + ":1: no column 'band_error': a history.csv header names iteration,phase,"),
      std::string::npos)
      << read_error(bad, replaced(good, "band_error,", "error,"));
  // The record starts on line 2; its note is quoted, so the field count is the header's.
  EXPECT_EQ(read_error(bad, replaced(good, "\n1,", "\n1,2,")),
            file + ":2: 18 fields: must be 17, one per header column");
  EXPECT_EQ(read_error(bad, replaced(good, ",false,false,", ",yes,false,")),
            file + ":2: meets_tolerance = 'yes': must be true or false");
  EXPECT_EQ(read_error(bad, replaced(good, "\n1,", "\none,")),
            file + ":2: iteration = 'one': must be an integer");
  EXPECT_EQ(read_error(bad, replaced(good, ",0.123456789012345,", ",12Hz,")),
            file + ":2: f_peak_hz = '12Hz': must be a number");
  EXPECT_EQ(read_error(bad, good + "2,\"grow"),
            file + ":3: a quoted field is not closed before the end of the file");
  EXPECT_EQ(read_error(bad, ""), file + ": empty file: a history.csv starts with its header line");
  EXPECT_EQ(read_error(m_dir / "missing" / "history.csv", ""),
            (m_dir / "missing" / "history.csv").string() + ": cannot be opened for reading");
}

TEST_F(History, ReaderCountsLinesInsideQuotedFieldsAndSkipsBlankLines) {
  RunHistory writer(m_dir, true, nullptr);
  IterationRecord r = sample_record(1);
  r.note = "one\ntwo\nthree";
  writer.append(r);
  writer.append(sample_record(2));
  const std::string text = read(m_dir / "history.csv") + "\r\n\n";
  // Record 2 starts on line 5: header, then record 1 over three lines.
  const fs::path bad = m_dir / "bad.csv";
  EXPECT_EQ(read_error(bad, replaced(text, "\n2,", "\n2x,")),
            bad.string() + ":5: iteration = '2x': must be an integer");
  EXPECT_EQ(read_error(bad, text), "");
  EXPECT_EQ(read_history_csv(bad).size(), 2u);
  EXPECT_EQ(read_history_csv(bad)[0].note, "one\ntwo\nthree");
}
