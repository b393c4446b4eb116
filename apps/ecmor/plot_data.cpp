// The data files of the run plots. The reduced model's sigma_max is computed here; everything
// else is copied from the run's own files, converted only where gnuplot needs it.
#include "plot_data.hpp"

#include <fmt/core.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/response/reduced_response.hpp"
#include "ecmor/run/history.hpp"

namespace fs = std::filesystem;

namespace ecmor::app {
namespace {

// Shortest text that reads back to the same double; non-finite as "nan" (gnuplot skips the point
// instead of failing on a log axis).
std::string data_number(double x) { return std::isfinite(x) ? fmt::format("{}", x) : "nan"; }

nlohmann::json read_summary(const fs::path& path) {
  std::ifstream in(path);
  if (!in) {
    throw InputError(
        fmt::format("{}: not found (is this a finished ecmor run directory?)", path.string()));
  }
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: not valid JSON: {}", path.string(), e.what()));
  }
}

template <class T>
T summary_field(const nlohmann::json& j, const char* key, const fs::path& path) {
  if (!j.contains(key)) throw InputError(fmt::format("{}: no field '{}'", path.string(), key));
  try {
    return j.at(key).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw InputError(fmt::format("{}: field '{}' has the wrong type", path.string(), key));
  }
}

// band_error.csv as the run writes it: a header line, then rows of numbers (no quoting).
class ErrorCurveFile {
 public:
  explicit ErrorCurveFile(fs::path path) : m_path(std::move(path)) {
    std::ifstream in(m_path);
    if (!in) {
      throw InputError(
          fmt::format("{}: not found (is this a finished ecmor run directory?)", m_path.string()));
    }
    std::string line;
    if (!std::getline(in, line)) throw InputError(fmt::format("{}: empty file", m_path.string()));
    m_header = split(line);
    for (std::size_t line_no = 2; std::getline(in, line); ++line_no) {
      if (line.empty()) continue;
      m_rows.push_back(split(line));
      m_lines.push_back(line_no);
      if (m_rows.back().size() != m_header.size()) {
        throw InputError(fmt::format("{}:{}: {} fields, the header has {}", m_path.string(),
                                     line_no, m_rows.back().size(), m_header.size()));
      }
    }
  }

  std::size_t rows() const { return m_rows.size(); }

  std::size_t column(const std::string& name) const {
    for (std::size_t k = 0; k < m_header.size(); ++k) {
      if (m_header[k] == name) return k;
    }
    throw InputError(fmt::format("{}:1: no column '{}'", m_path.string(), name));
  }

  // strtod reads "inf" and "nan" as written by the run; anything else unparsable is an error.
  double number(std::size_t row, std::size_t column) const {
    const std::string& s = m_rows[row][column];
    char* end = nullptr;
    const double x = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != '\0') {
      throw InputError(fmt::format("{}:{}: {} = '{}': must be a number", m_path.string(),
                                   m_lines[row], m_header[column], s));
    }
    return x;
  }

 private:
  static std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> fields(1);
    for (char c : line) {
      if (c == ',') {
        fields.emplace_back();
      } else if (c != '\r') {
        fields.back() += c;
      }
    }
    return fields;
  }

  fs::path m_path;
  std::vector<std::string> m_header;
  std::vector<std::vector<std::string>> m_rows;
  std::vector<std::size_t> m_lines;  // file line of each row
};

}  // namespace

RunFacts read_run_facts(const fs::path& summary_path) {
  const nlohmann::json summary = read_summary(summary_path);
  RunFacts run;
  run.tolerance = summary_field<double>(summary, "tolerance", summary_path);
  run.order = summary_field<Index>(summary, "final_order", summary_path);
  run.verified_band_error = summary_field<double>(summary, "verified_band_error", summary_path);
  run.norm = summary_field<std::string>(summary, "norm", summary_path);
  run.reducer = summary_field<std::string>(summary, "reducer", summary_path);
  run.strategy = summary_field<std::string>(summary, "strategy", summary_path);
  run.termination = summary_field<std::string>(summary, "termination", summary_path);
  const nlohmann::json band = summary_field<nlohmann::json>(summary, "band", summary_path);
  run.f_min_hz = summary_field<double>(band, "f_min_hz", summary_path);
  run.f_max_hz = summary_field<double>(band, "f_max_hz", summary_path);
  for (const char* key : {"dir", "file"}) {
    if (summary.contains("model") && summary["model"].contains(key))
      run.model_name = fs::path(summary["model"][key].get<std::string>()).filename().string();
  }
  return run;
}

void write_sigma_csv(const fs::path& run_dir) {
  const ErrorCurveFile errors(run_dir / "band_error.csv");
  const std::size_t c_f = errors.column("f_hz");
  const std::size_t c_ref = errors.column("reference_spectral");
  const std::size_t c_abs = errors.column("absolute_spectral");
  // The error plot reads these two by position from band_error.csv itself.
  errors.column("relative_spectral");
  errors.column("relative_frobenius");
  const ReducedModel reduced = read_reduced_model(run_dir);
  const ReducedResponse response(reduced);
  std::string sigma = "f_hz,full_sigma_max,reduced_sigma_max,error_sigma_max\n";
  for (std::size_t k = 0; k < errors.rows(); ++k) {
    const double f_hz = errors.number(k, c_f);
    double reduced_sigma = std::nan("");
    try {
      reduced_sigma = matrix_norm(response(s_from_hz(f_hz)), ErrorNorm::Spectral);
    } catch (const NumericalError&) {
      // A reduced pole on the grid: no finite value to draw (band_error.csv says inf there).
    }
    sigma += fmt::format("{},{},{},{}\n", data_number(f_hz), data_number(errors.number(k, c_ref)),
                         data_number(reduced_sigma), data_number(errors.number(k, c_abs)));
  }
  write_text_atomically(run_dir / "sigma.csv", sigma);
}

void write_convergence_csv(const fs::path& run_dir) {
  std::string convergence = "iteration,order,band_error,meets_tolerance,phase\n";
  for (const HistoryCsvRow& row : read_history_csv(run_dir / "history.csv")) {
    convergence += fmt::format("{},{},{},{},{}\n", row.iteration, row.order,
                               data_number(row.band_error), row.meets_tolerance ? 1 : 0, row.phase);
  }
  write_text_atomically(run_dir / "convergence.csv", convergence);
}

}  // namespace ecmor::app
