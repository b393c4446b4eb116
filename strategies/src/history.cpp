// history.cpp: the convergence history as CSV (for spreadsheets and gnuplot) and JSON lines (for
// scripts: every field, nothing rounded). Both files are rewritten whole after every iteration,
// atomically, so a run killed at any moment leaves complete files up to its last iteration.
#include "ecmor/strategies/history.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <type_traits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ecmor/base/error.hpp"

namespace ecmor {

namespace {

// ordered_json keeps the documented field order (nlohmann::json sorts keys).
using Json = nlohmann::ordered_json;

// Temporary file next to the target, then rename: rename(2) within one directory is atomic, so a
// reader sees the old or the new complete file. (atomic_file.hpp will offer the same; this private
// copy exists until it lands, and is replaced by write_file_atomically then.)
void replace_file(const std::filesystem::path& path, const std::string& contents) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw IoError(fmt::format("cannot create {}", tmp.string()));
    out << contents;
    out.flush();
    if (!out) {
      out.close();
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
      throw IoError(fmt::format("cannot write {}", tmp.string()));
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw IoError(
        fmt::format("cannot rename {} to {}: {}", tmp.string(), path.string(), ec.message()));
  }
}

// Shortest text that reads back to the same double ("0.001", "1e-13", "inf", "nan").
std::string number(double x) { return fmt::format("{}", x); }

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

HistoryWriter::HistoryWriter(std::filesystem::path dir) : m_dir(std::move(dir)) {
  std::error_code ec;
  std::filesystem::create_directories(m_dir, ec);
  if (ec || !std::filesystem::is_directory(m_dir))
    throw IoError(fmt::format("cannot create the history directory {}: {}", m_dir.string(),
                              ec ? ec.message() : "not a directory"));
}

void HistoryWriter::append(const IterationRecord& record) {
  m_records.push_back(record);

  std::string csv =
      "iteration,phase,order,points,band_error,f_peak_hz,meets_tolerance,stable,seconds,"
      "step_seconds,factorizations,solves,factorization_seconds,solve_seconds,full_evaluations,"
      "sampling,note\n";
  std::string jsonl;
  for (const IterationRecord& r : m_records) {
    csv += fmt::format(
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", r.iteration, csv_text(r.phase),
        r.order, csv_text(format_points(r.points)), number(r.band_error), number(r.f_peak_hz),
        r.meets_tolerance ? "true" : "false", r.stable ? "true" : "false", number(r.seconds),
        number(r.step_seconds), r.counters.factorizations, r.counters.solves,
        number(r.counters.factorization_seconds), number(r.counters.solve_seconds),
        r.full_evaluations, csv_text(r.sampling), csv_text(r.note));
    jsonl += to_json(r).dump() + "\n";
  }
  replace_file(m_dir / "history.csv", csv);
  replace_file(m_dir / "history.jsonl", jsonl);
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
