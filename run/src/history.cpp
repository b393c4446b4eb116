// history.cpp: the convergence history as CSV (for spreadsheets and gnuplot) and JSON lines (for
// scripts: every field, nothing rounded). Both files are rewritten whole after every iteration,
// atomically, so a run killed at any moment leaves complete files up to its last iteration.
#include "ecmor/run/history.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <type_traits>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/parallel.hpp"
#include "ecmor/run/driver.hpp"

namespace ecmor {

namespace {

// ordered_json keeps the documented field order (nlohmann::json sorts keys).
using Json = nlohmann::ordered_json;

// Shortest text that reads back to the same number ("0.001", "1e-13", "inf", "nan", "42").
template <class T>
std::string number(T x) {
  return fmt::format("{}", x);
}

std::string flag(bool b) { return b ? "true" : "false"; }

// RFC 4180: text fields in double quotes, inner quotes doubled; then commas and newlines inside
// notes and point lists cannot break the columns.
std::string csv_text(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

// One field of history.csv being read back, with what an error message needs to name it.
class CsvField {
 public:
  CsvField(const std::string& text, const std::filesystem::path& path, std::size_t line,
           const char* column)
      : m_text(text), m_path(path), m_line(line), m_column(column) {}

  const std::string& text() const { return m_text; }

  Index integer() const {
    char* end = nullptr;
    errno = 0;
    const long long x = std::strtoll(m_text.c_str(), &end, 10);
    require(*end == '\0' && errno != ERANGE, "an integer");
    return static_cast<Index>(x);
  }

  // strtod reads "inf" and "nan" as the writer writes them. Its ERANGE is not checked: it also
  // flags subnormal numbers, which the writer writes and which read back exactly.
  double number() const {
    char* end = nullptr;
    const double x = std::strtod(m_text.c_str(), &end);
    require(*end == '\0', "a number");
    return x;
  }

  bool boolean() const {
    require(m_text == "true" || m_text == "false", "true or false");
    return m_text == "true";
  }

 private:
  // `what` names the rule the field breaks unless it is non-empty and `ok`.
  void require(bool ok, const char* what) const {
    if (ok && !m_text.empty()) return;
    throw InputError(fmt::format("{}:{}: {} = '{}': must be {}", m_path.string(), m_line, m_column,
                                 m_text, what));
  }

  const std::string& m_text;
  const std::filesystem::path& m_path;
  std::size_t m_line;
  const char* m_column;
};

// history.csv's columns in file order: the name, the field as written, and where it is read back
// to. The writer's header and the columns the reader requires both come from this one list.
struct CsvColumn {
  const char* name;
  std::string (*write)(const IterationRecord&);
  void (*read)(const CsvField&, HistoryCsvRow&);
};

// A value as history.csv has it: booleans true/false, numbers round-tripping, text quoted.
template <class T>
std::string field_text(const T& x) {
  if constexpr (std::is_same_v<T, bool>) {
    return flag(x);
  } else if constexpr (std::is_arithmetic_v<T>) {
    return number(x);
  } else {
    return csv_text(x);
  }
}

// A field read back by the type of the member it goes to.
template <class T>
void read_field(const CsvField& f, T& out) {
  if constexpr (std::is_same_v<T, bool>) {
    out = f.boolean();
  } else if constexpr (std::is_integral_v<T>) {
    out = f.integer();
  } else if constexpr (std::is_floating_point_v<T>) {
    out = f.number();
  } else {
    out = f.text();
  }
}

// The column of record.*Field, read back into row.*Back.
template <auto Field, auto Back>
constexpr CsvColumn column(const char* name) {
  return {name, [](const IterationRecord& r) { return field_text(r.*Field); },
          [](const CsvField& f, HistoryCsvRow& row) { read_field(f, row.*Back); }};
}

// The column of record.counters.*Field, read back into row.*Back.
template <auto Field, auto Back>
constexpr CsvColumn counter_column(const char* name) {
  return {name, [](const IterationRecord& r) { return field_text(r.counters.*Field); },
          [](const CsvField& f, HistoryCsvRow& row) { read_field(f, row.*Back); }};
}

using Record = IterationRecord;
using Row = HistoryCsvRow;
const CsvColumn kCsvColumns[] = {
    column<&Record::iteration, &Row::iteration>("iteration"),
    column<&Record::phase, &Row::phase>("phase"),
    column<&Record::order, &Row::order>("order"),
    {"points", [](const Record& r) { return csv_text(format_points(r.points)); },
     [](const CsvField& f, Row& row) { row.points = f.text(); }},
    column<&Record::band_error, &Row::band_error>("band_error"),
    column<&Record::f_peak_hz, &Row::f_peak_hz>("f_peak_hz"),
    column<&Record::meets_tolerance, &Row::meets_tolerance>("meets_tolerance"),
    column<&Record::stable, &Row::stable>("stable"),
    column<&Record::seconds, &Row::seconds>("seconds"),
    column<&Record::step_seconds, &Row::step_seconds>("step_seconds"),
    counter_column<&SolverCounters::factorizations, &Row::factorizations>("factorizations"),
    counter_column<&SolverCounters::solves, &Row::solves>("solves"),
    counter_column<&SolverCounters::factorization_seconds, &Row::factorization_seconds>(
        "factorization_seconds"),
    counter_column<&SolverCounters::solve_seconds, &Row::solve_seconds>("solve_seconds"),
    column<&Record::full_evaluations, &Row::full_evaluations>("full_evaluations"),
    column<&Record::sampling, &Row::sampling>("sampling"),
    column<&Record::note, &Row::note>("note"),
};

// One line of history.csv: `field(column)` for every column, comma-separated.
template <class Field>
std::string csv_line(Field&& field) {
  std::string out;
  for (const CsvColumn& c : kCsvColumns) {
    if (&c != kCsvColumns) out += ',';
    out += field(c);
  }
  return out + '\n';
}

std::string csv_header() {
  return csv_line([](const CsvColumn& c) { return c.name; });
}

std::string csv_row(const IterationRecord& r) {
  return csv_line([&r](const CsvColumn& c) { return c.write(r); });
}

// A record of a CSV file: its fields and the line it starts on.
struct CsvRecord {
  std::size_t line = 1;
  std::vector<std::string> fields{std::string()};
};

// Splits CSV text into records (RFC 4180; a quoted field may span lines). Blank lines are no
// records; a carriage return outside quotes is dropped (CRLF files).
std::vector<CsvRecord> split_records(const std::string& text, const std::filesystem::path& path) {
  std::vector<CsvRecord> records;
  CsvRecord record;
  bool quoted = false, blank = true;
  std::size_t line = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') ++line;
    if (quoted) {
      if (c != '"') {
        record.fields.back() += c;
      } else if (i + 1 < text.size() && text[i + 1] == '"') {
        record.fields.back() += c;  // "" inside quotes is one quote
        ++i;
      } else {
        quoted = false;
      }
    } else if (c == '\n') {
      if (!blank) records.push_back(std::move(record));
      record = CsvRecord{line};
      blank = true;
    } else if (c != '\r') {
      blank = false;
      if (c == '"')
        quoted = true;
      else if (c == ',')
        record.fields.emplace_back();
      else
        record.fields.back() += c;
    }
  }
  if (quoted) {
    throw InputError(fmt::format("{}:{}: a quoted field is not closed before the end of the file",
                                 path.string(), record.line));
  }
  if (!blank) records.push_back(std::move(record));
  return records;
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot be opened for reading", path.string()));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Where each of kCsvColumns is in the file's header.
std::vector<std::size_t> column_positions(const CsvRecord& header,
                                          const std::filesystem::path& path) {
  std::vector<std::size_t> at;
  for (const CsvColumn& c : kCsvColumns) {
    const auto it = std::find(header.fields.begin(), header.fields.end(), c.name);
    if (it == header.fields.end()) {
      const std::string names = csv_header();
      throw InputError(fmt::format("{}:{}: no column '{}': a history.csv header names {}",
                                   path.string(), header.line, c.name,
                                   names.substr(0, names.size() - 1)));
    }
    at.push_back(static_cast<std::size_t>(it - header.fields.begin()));
  }
  return at;
}

// JSON has no inf/NaN; null would lose which one it was (an infinite error means the reduced
// model hit a pole), so non-finite numbers are written as the strings "inf", "-inf", "nan".
Json json_number(double x) {
  if (std::isfinite(x)) return x;
  if (std::isnan(x)) return "nan";
  return x > 0 ? "inf" : "-inf";
}

Json to_json(const IterationRecord& r) {
  Json points = Json::array();
  for (const ExpansionPoint& p : r.points)
    points.push_back({{"re", json_number(p.s.real())},
                      {"im", json_number(p.s.imag())},
                      {"f_hz", json_number(p.s.imag() / kTwoPi)},
                      {"moments", p.moments}});
  Json counters = Json::object();
  for_each_counter(r.counters, [&](const char* name, auto value) {
    if constexpr (std::is_floating_point_v<decltype(value)>) {
      counters[name] = json_number(value);
    } else {
      counters[name] = value;
    }
  });
  Json diagnostics = Json::object();
  for (const auto& [key, value] : r.diagnostics) diagnostics[key] = json_number(value);
  nlohmann::ordered_json out;
  out["iteration"] = r.iteration;
  out["phase"] = r.phase;
  out["order"] = r.order;
  out["points"] = points;
  out["band_error"] = json_number(r.band_error);
  out["f_peak_hz"] = json_number(r.f_peak_hz);
  out["meets_tolerance"] = r.meets_tolerance;
  out["stable"] = r.stable;
  out["seconds"] = json_number(r.seconds);
  out["step_seconds"] = json_number(r.step_seconds);
  out["counters"] = counters;
  out["full_evaluations"] = r.full_evaluations;
  out["sampling"] = r.sampling;
  out["note"] = r.note;
  out["diagnostics"] = diagnostics;
  return out;
}

}  // namespace

RunHistory::RunHistory(std::filesystem::path dir, bool write, RunObserver* observer)
    : m_dir(std::move(dir)), m_write(write && !m_dir.empty()), m_observer(observer) {}

bool RunHistory::append(IterationRecord record) {
  record.iteration = size() + 1;
  m_records.push_back(std::move(record));
  std::string failure;
  if (m_write) {
    try {
      if (!m_created) {
        std::error_code ec;
        std::filesystem::create_directories(m_dir, ec);
        if (ec || !std::filesystem::is_directory(m_dir))
          throw IoError(fmt::format("cannot create the history directory {}: {}", m_dir.string(),
                                    ec ? ec.message() : "not a directory"));
        m_created = true;
      }
      write_history(m_dir, m_records);
    } catch (const Error& e) {
      failure = e.what();
    }
  }
  // A write error is one rank's alone: made collective, so that every rank leaves the strategy at
  // the same record instead of the others waiting in the next collective solve.
  if (any_process(!failure.empty()))
    throw IoError(failure.empty() ? std::string("rank 0 could not write the history") : failure);
  return m_observer ? m_observer->on_iteration(m_records.back()) : true;
}

std::string history_json_line(const IterationRecord& record) { return to_json(record).dump(); }

void write_history(const std::filesystem::path& dir, const std::vector<IterationRecord>& records) {
  std::string csv = csv_header();
  std::string jsonl;
  for (const IterationRecord& r : records) {
    csv += csv_row(r);
    jsonl += history_json_line(r) + "\n";
  }
  // Atomic (a reader sees the old or the new complete file), with a unique temporary name and an
  // fsync before the rename (atomic_file.hpp).
  write_text_atomically(dir / "history.csv", csv);
  write_text_atomically(dir / "history.jsonl", jsonl);
}

std::vector<HistoryCsvRow> read_history_csv(const std::filesystem::path& path) {
  const std::vector<CsvRecord> records = split_records(read_text(path), path);
  if (records.empty()) {
    throw InputError(
        fmt::format("{}: empty file: a history.csv starts with its header line", path.string()));
  }
  const CsvRecord& header = records.front();
  const std::vector<std::size_t> at = column_positions(header, path);
  std::vector<HistoryCsvRow> rows;
  for (std::size_t k = 1; k < records.size(); ++k) {
    const CsvRecord& r = records[k];
    if (r.fields.size() != header.fields.size()) {
      throw InputError(fmt::format("{}:{}: {} fields: must be {}, one per header column",
                                   path.string(), r.line, r.fields.size(), header.fields.size()));
    }
    HistoryCsvRow row;
    for (std::size_t c = 0; c < at.size(); ++c) {
      const CsvColumn& column = kCsvColumns[c];
      column.read(CsvField(r.fields[at[c]], path, r.line, column.name), row);
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

std::string format_points(const std::vector<ExpansionPoint>& points) {
  if (points.empty()) return "-";
  std::string out;
  for (const ExpansionPoint& p : points) {
    if (!out.empty()) out += ", ";
    const double re = p.s.real() == 0.0 ? 0.0 : p.s.real();  // no "-0"
    const double im = p.s.imag();
    if (im == 0.0) {
      out += fmt::format("s={:.6g}", re);  // real shift, in rad/s
    } else {
      // On or near the imaginary axis the frequency in Hz is what the user reads off the band;
      // the real part stays in s units (rad/s).
      out += fmt::format("{:.6g}{}i{:.6g}Hz", re, im < 0 ? "-" : "+", std::abs(im) / kTwoPi);
    }
    if (p.moments > 1) out += fmt::format(" x{}", p.moments);
  }
  return out;
}

}  // namespace ecmor
