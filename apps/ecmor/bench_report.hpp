#pragma once
/// \file bench_report.hpp
/// The reports of `ecmor bench`: bench.csv, bench.json and bench.md (one row per run), and the
/// charts bench_time_error and bench_order_error with their data, bench_chart.csv.

#include <filesystem>
#include <string>
#include <vector>

#include "bench_run.hpp"

namespace ecmor::app {

/// bench.md: a Markdown table of the runs (also printed when the bench ends).
std::string bench_markdown(const std::vector<BenchRow>& rows);

/// Writes the reports of a bench into one directory.
class BenchReport {
 public:
  /// `quiet`: no note when gnuplot is missing.
  BenchReport(std::filesystem::path out, bool quiet) : m_out(std::move(out)), m_quiet(quiet) {}

  /// Rewrites every report from `rows` (all runs so far), so an interrupted bench keeps what it
  /// measured. Charts that cannot be rendered are a note (gnuplot missing) or a warning (gnuplot
  /// failed), once per bench; their data and scripts are written all the same.
  /// \throws IoError when a table cannot be written.
  void write(const std::vector<BenchRow>& rows);

 private:
  void write_charts(const std::vector<BenchRow>& rows);

  std::filesystem::path m_out;
  bool m_quiet;
  bool m_noted = false;  // one note per bench, not one per run
};

}  // namespace ecmor::app
