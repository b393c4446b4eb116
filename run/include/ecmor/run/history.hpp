#pragma once
/// \file history.hpp
/// The convergence history: one record per iteration of a strategy, always kept in full, written
/// as history.csv and history.jsonl (each rewritten atomically after every iteration, so an
/// interrupted run keeps everything up to its last iteration).

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/plugin/reducer.hpp"
#include "ecmor/strategies/iteration_record.hpp"

namespace ecmor {

class RunObserver;

/// The run's history, the one path of every record: a strategy's record, labelled by the member
/// runner (members.cpp), is numbered here over the whole run, kept, written as history.csv and
/// history.jsonl (each rewritten atomically, so an interrupted run keeps everything up to its last
/// record) and shown to the observer (the CLI's table).
class RunHistory {
 public:
  /// `dir` empty: kept in memory only (the Python module's runs). Otherwise `dir` is created at
  /// the first record, so that a run refused before any record leaves no directory behind. Under
  /// MPI only rank 0 writes (`write` false on the others). `observer` may be null.
  RunHistory(std::filesystem::path dir, bool write, RunObserver* observer);
  /// Appends `record` as the next row (its iteration number set to size() + 1), rewrites the
  /// files and shows it to the observer; returns the observer's answer (false: stop the run).
  /// \throws IoError naming the file or directory that could not be written, on every rank
  ///         (collective under MPI, so that all ranks leave the strategy at the same record).
  bool append(IterationRecord record);
  Index size() const { return static_cast<Index>(m_records.size()); }
  const std::vector<IterationRecord>& records() const { return m_records; }
  /// The records, moved out (the history is empty afterwards).
  std::vector<IterationRecord> release() { return std::move(m_records); }

 private:
  std::filesystem::path m_dir;
  bool m_write;
  RunObserver* m_observer;
  bool m_created = false;
  std::vector<IterationRecord> m_records;
};

/// One line of history.jsonl (without its newline): every field of the record, nothing rounded;
/// non-finite numbers as the strings "inf", "-inf", "nan".
std::string history_json_line(const IterationRecord& record);

/// Writes history.csv and history.jsonl of `records` into the existing directory `dir`, each
/// atomically (what RunHistory::append writes).
/// \throws IoError naming the file that could not be written.
void write_history(const std::filesystem::path& dir, const std::vector<IterationRecord>& records);

/// One row of history.csv as read back: the fields the CSV carries. It holds part of an
/// IterationRecord (the points as format_points() text, two of the solver counters, no
/// diagnostics); history.jsonl has every field.
struct HistoryCsvRow {
  Index iteration = 0;
  std::string phase;
  Index order = 0;
  std::string points;  ///< format_points() of the record's points
  double band_error = 0.0;
  double f_peak_hz = 0.0;
  bool meets_tolerance = false;
  bool stable = true;
  double seconds = 0.0;
  double step_seconds = 0.0;
  Index factorizations = 0;  ///< cumulative, as counters.factorizations
  Index solves = 0;          ///< cumulative, as counters.solves
  double factorization_seconds = 0.0;
  double solve_seconds = 0.0;
  Index full_evaluations = 0;
  std::string sampling;
  std::string note;
};

/// Reads a history.csv as RunHistory writes it: RFC 4180 (quoted fields may hold commas,
/// newlines and doubled quotes), columns found by their header names (others are ignored), blank
/// lines skipped. Numbers read back exactly, including "inf" and "nan".
/// \throws InputError naming the file, the line and the rule broken: the file cannot be read or
///         is empty; the header lacks a column the writer writes; a row has another number of
///         fields than the header; a field is not an integer, a number, or true/false as its
///         column requires; a quoted field is not closed.
std::vector<HistoryCsvRow> read_history_csv(const std::filesystem::path& path);

/// Calls f(name, value) for every solver counter, in a fixed order: the one list of counter
/// names used by history.jsonl and summary.json. Values are Index (counts) or double (seconds).
template <class F>
void for_each_counter(const SolverCounters& c, F&& f) {
  f("symbolic_analyses", c.symbolic_analyses);
  f("factorizations", c.factorizations);
  f("cholesky_factorizations", c.cholesky_factorizations);
  f("lu_factorizations", c.lu_factorizations);
  f("complex_factorizations", c.complex_factorizations);
  f("failed_cholesky", c.failed_cholesky);
  f("solves", c.solves);
  f("analysis_seconds", c.analysis_seconds);
  f("factorization_seconds", c.factorization_seconds);
  f("solve_seconds", c.solve_seconds);
}

/// Expansion points formatted for tables: "i*12.5Hz, 3.0rad/s" style, "-" when empty.
std::string format_points(const std::vector<ExpansionPoint>& points);

}  // namespace ecmor
