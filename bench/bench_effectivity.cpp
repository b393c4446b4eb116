// ecmor_bench_effectivity: how well the estimate mode of the band error (ErrorVerify::Estimate)
// predicts the true error curve of a reduced model, measured against the dense mode (a full solve
// per sample). The table is in docs/error-measures.md ("Effectivity of the estimate (measured)").
//
//   ecmor_bench_effectivity [CONFIG.yaml ...] [--triplechain N1] [--lattice NX NY NZ]
//                           [--solid NX NY NZ] [--points 2,4,8,16,32] [--band FMIN FMAX]
//                           [--plugin-dir DIR] [--out FILE.md]
//
// CONFIG: the config is reduced by the driver (run_reduction, as `ecmor reduce` does) into a
// temporary directory; its reported model and V, W are measured with the config's error options
// and norm (effectivity.hpp). Families generated here (no config; default error options, spectral
// norm): for each k of --points, a Galerkin projection onto P(s_j)^-1 B at k log-spaced points
// s_j = i 2 pi f_j of the band (real and imaginary parts; what a multipoint Krylov reducer builds);
// choose --points so that the errors range from ~1 down to ~1e-4 (docs/error-measures.md):
//   --triplechain N1   the triple chain of triple_chain.hpp (alpha = beta = 0.002, v = 5, the
//                      triplechain_mess_n1501 instance for N1 = 500), band 1.6e-5 .. 0.01 Hz
//                      (that config's band)
//   --lattice NX NY NZ the lattice of lattice.hpp, band 0.5 .. 6.5 Hz (15 modes for 20x20x20,
//                      counted with multiplicity from the separable formula of lattice.hpp)
//   --solid NX NY NZ   the clamped steel bar of solid.hpp, band 20 .. 5000 Hz
// --band overrides the family bands. Each row is printed when it is done (a run cut short keeps
// the rows before); --out gets the whole table, rewritten after every row.
// Never run by ctest: timings are not assertions.
#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/run/config.hpp"
#include "effectivity.hpp"
#include "lattice.hpp"
#include "solid.hpp"
#include "triple_chain.hpp"

#ifndef ECMOR_BENCH_PLUGIN_DIR
#define ECMOR_BENCH_PLUGIN_DIR ""
#endif

namespace {

using ecmor::Index;
using ecmor::bench::EffectivityReport;
namespace fs = std::filesystem;

struct Family {
  std::string label;
  std::function<ecmor::Model()> make;
  ecmor::Band band;
};

struct Options {
  std::vector<fs::path> configs;
  std::vector<Family> families;
  std::vector<Index> points{2, 4, 8, 16, 32};
  bool band_given = false;
  ecmor::Band band;
  std::string plugin_dir;
  std::string out;
};

Index parse_index(const std::string& text, const char* what) {
  std::size_t used = 0;
  long long v = 0;
  try {
    v = std::stoll(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || v < 1)
    throw std::runtime_error(fmt::format("{} = '{}': must be a positive integer", what, text));
  return static_cast<Index>(v);
}

double parse_double(const std::string& text, const char* what) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(v) || v <= 0.0)
    throw std::runtime_error(fmt::format("{} = '{}': must be a positive number", what, text));
  return v;
}

// The Galerkin projection onto span{Re, Im of P(s_j)^-1 B}, k log-spaced points of the band.
struct Candidate {
  ecmor::ReducedModel reduced;
  ecmor::Matrix V;
};
Candidate krylov_candidate(const ecmor::Model& model, ecmor::ShiftedSolver& solver,
                           const ecmor::Band& band, Index points) {
  Candidate c;
  c.V = ecmor::Matrix(ecmor::size_of(model), 0);
  const ecmor::Matrix& B =
      std::visit([](const auto& m) -> const ecmor::Matrix& { return m.B; }, model);
  const ecmor::ComplexMatrix Bc = B.cast<ecmor::Complex>();
  for (double f : ecmor::log_grid(band.f_min_hz, band.f_max_hz, points)) {
    const auto P = solver.factorize(ecmor::s_from_hz(f));
    const ecmor::ComplexMatrix X = P->solve(Bc);
    ecmor::Matrix parts(X.rows(), 2 * X.cols());
    parts << X.real(), X.imag();
    ecmor::orthonormalize_append(c.V, parts);
  }
  c.reduced = ecmor::project(model, c.V, c.V);
  return c;
}

class Table {
 public:
  explicit Table(std::string out) : m_out(std::move(out)) {
    fmt::print("{}", ecmor::bench::effectivity_table({}));
    std::fflush(stdout);
  }
  void add(const EffectivityReport& r) {
    m_rows.push_back(r);
    fmt::print("{}", ecmor::bench::effectivity_row(r));
    std::fflush(stdout);
    if (m_out.empty()) return;
    std::ofstream os(m_out);
    os << ecmor::bench::effectivity_table(m_rows);
    if (!os) throw std::runtime_error("cannot write " + m_out);
  }

 private:
  std::string m_out;
  std::vector<EffectivityReport> m_rows;
};

int usage(const char* argv0) {
  fmt::print(
      stderr,
      "usage: {} [CONFIG.yaml ...] [--triplechain N1] [--lattice NX NY NZ] "
      "[--solid NX NY NZ]\n"
      "          [--points 2,4,8,16,32] [--band FMIN FMAX] [--plugin-dir DIR] [--out FILE.md]\n",
      argv0);
  return 1;
}

Options parse(int argc, char** argv) {
  Options o;
  auto need = [&](int i, int count) {
    if (i + count >= argc)
      throw std::runtime_error(fmt::format("{} needs {} value(s)", argv[i], count));
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out") {
      need(i, 1);
      o.out = argv[++i];
    } else if (a == "--plugin-dir") {
      need(i, 1);
      o.plugin_dir = argv[++i];
    } else if (a == "--points") {
      need(i, 1);
      o.points.clear();
      std::string list = argv[++i];
      std::size_t start = 0;
      while (start <= list.size()) {
        const std::size_t comma = std::min(list.find(',', start), list.size());
        o.points.push_back(parse_index(list.substr(start, comma - start), "--points"));
        start = comma + 1;
      }
    } else if (a == "--band") {
      need(i, 2);
      o.band.f_min_hz = parse_double(argv[++i], "FMIN");
      o.band.f_max_hz = parse_double(argv[++i], "FMAX");
      o.band.validate();
      o.band_given = true;
    } else if (a == "--triplechain") {
      need(i, 1);
      const Index n1 = parse_index(argv[++i], "N1");
      o.families.push_back({fmt::format("triple chain n1 = {}", n1),
                            [n1] { return ecmor::bench::triple_chain(n1, 0.002, 0.002, 5.0); },
                            ecmor::Band{1.6e-5, 0.01}});
    } else if (a == "--lattice" || a == "--solid") {
      need(i, 3);
      const Index nx = parse_index(argv[i + 1], "NX"), ny = parse_index(argv[i + 2], "NY"),
                  nz = parse_index(argv[i + 3], "NZ");
      i += 3;
      if (a == "--lattice") {
        o.families.push_back({fmt::format("lattice {}x{}x{}", nx, ny, nz),
                              [=] { return ecmor::bench::lattice(nx, ny, nz); },
                              ecmor::Band{0.5, 6.5}});
      } else {
        o.families.push_back({fmt::format("solid {}x{}x{}", nx, ny, nz),
                              [=] {
                                ecmor::bench::SolidOptions so;
                                so.nx = nx;
                                so.ny = ny;
                                so.nz = nz;
                                return ecmor::bench::solid(so);
                              },
                              ecmor::Band{20.0, 5000.0}});
      }
    } else if (!a.empty() && a[0] == '-') {
      throw std::runtime_error("unknown option " + a);
    } else {
      o.configs.emplace_back(a);
    }
  }
  if (o.band_given)
    for (Family& f : o.families) f.band = o.band;
  return o;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  try {
    opt = parse(argc, argv);
  } catch (const std::exception& e) {
    fmt::print(stderr, "ecmor_bench_effectivity: {}\n", e.what());
    return usage(argv[0]);
  }
  if (opt.configs.empty() && opt.families.empty()) return usage(argv[0]);
  int failures = 0;
  Table table(opt.out);
  std::vector<fs::path> plugin_dirs;
  if (!opt.plugin_dir.empty()) plugin_dirs.emplace_back(opt.plugin_dir);
  if (std::string(ECMOR_BENCH_PLUGIN_DIR).size() > 0)
    plugin_dirs.emplace_back(ECMOR_BENCH_PLUGIN_DIR);

  for (const fs::path& path : opt.configs) {
    const fs::path out = fs::temp_directory_path() /
                         fmt::format("ecmor_effectivity_{}_{}", ::getpid(), path.stem().string());
    try {
      const ecmor::RunConfig config = ecmor::load_run_config(path);
      ecmor::Registry registry;
      ecmor::bench::load_plugins_for(registry, config, plugin_dirs);
      fs::remove_all(out);
      const ecmor::bench::DriverRun run = ecmor::bench::reduce_with_driver(config, registry, out);
      const ecmor::Model model = ecmor::load_model(config.model);
      ecmor::BandErrorOptions options = config.error;
      options.norm = config.norm;
      EffectivityReport r = ecmor::bench::measure_effectivity(
          model, config.band, options, run.reduced, run.V, run.W, config.solver, config.threads);
      r.name = path.stem().string();
      r.reduction_seconds = run.seconds;
      table.add(r);
    } catch (const std::exception& e) {
      fmt::print(stderr, "ecmor_bench_effectivity: {}: {}\n", path.string(), e.what());
      ++failures;
    }
    std::error_code ec;
    fs::remove_all(out, ec);
  }

  for (const Family& family : opt.families) {
    try {
      const ecmor::Model model = family.make();
      auto solver = ecmor::make_shifted_solver(model);
      for (Index k : opt.points) {
        const auto t0 = std::chrono::steady_clock::now();
        const Candidate c = krylov_candidate(model, *solver, family.band, k);
        const double build = seconds_since(t0);
        EffectivityReport r = ecmor::bench::measure_effectivity(
            model, family.band, ecmor::BandErrorOptions{}, c.reduced, c.V, c.V);
        r.name = fmt::format("{}, krylov k = {} ({:g}..{:g} Hz)", family.label, k,
                             family.band.f_min_hz, family.band.f_max_hz);
        r.reduction_seconds = build;
        table.add(r);
      }
    } catch (const std::exception& e) {
      fmt::print(stderr, "ecmor_bench_effectivity: {}: {}\n", family.label, e.what());
      ++failures;
    }
  }
  return failures == 0 ? 0 : 2;
}
