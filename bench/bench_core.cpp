// bench_core: scaling benchmark of the core numerics on triple chains of N = 1e4, 1e5, 1e6.
//
// Measures what the architecture calls the unavoidable cost of a reduction: symbolic analysis,
// numeric factorisations (CHOLMOD real SPD, UMFPACK complex), solves, the full model's band
// response (frequencies per second, 1 and 2 threads), the gain from reusing the symbolic analysis
// across shifts, and modal reduction through the plugin registry. Every row carries the solver's
// counters (factorisations, solves) and the peak resident memory.
//
// Each model size runs in its own child process (fork), so that the peak memory reported for a size
// is that size's own (ru_maxrss is a process-lifetime maximum) and a crash or an out-of-memory kill
// at 1e6 still leaves the smaller sizes' rows.
//
// Usage: ecmor_bench_core [--quick] [--sizes 1e4,1e5,...] [--csv file] [--plugin-dir dir]
//                         [--modal-max-n 1e5] [--reduced-only]
// Never run by ctest: timings are not assertions.

#include <fmt/format.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/response/reduced_response.hpp"
#include "triple_chain.hpp"

#ifndef ECMOR_BENCH_PLUGIN_DIR
#define ECMOR_BENCH_PLUGIN_DIR ""
#endif

namespace {

using ecmor::Complex;
using ecmor::Index;
using Clock = std::chrono::steady_clock;

// The instance of triplechain_mess_n1501 (alpha = beta = 0.002, v = 5) scaled up: lightly damped,
// the hard case for the band error; its band 1e-4..10 rad/s (M-M.E.S.S. demos) is used throughout.
constexpr double kAlpha = 0.002;
constexpr double kBeta = 0.002;
constexpr double kViscosity = 5.0;
constexpr double kOmegaMin = 1e-4;  // rad/s
constexpr double kOmegaMax = 10.0;  // rad/s

struct Options {
  bool quick = false;
  std::vector<Index> sizes;
  std::string csv;
  std::string plugin_dir;
  Index frequencies = 64;  // band-response frequencies
  Index reuse_shifts = 8;  // shifts in the symbolic-reuse comparison
  std::vector<Index> modal_orders{20, 50};
  // Modal reduction is skipped above this size: at N = 1e5 one modal reduction already costs
  // ~20 s of CPU in dense products (not in factorisations), so N = 1e6 would take most of an hour.
  Index modal_max_n = 100000;
  // Only the reduced-response rows (no triple chain sizes): --reduced-only.
  bool reduced_only = false;
};

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Process CPU time (user + system, all threads) in seconds.
double process_cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

/// Wall and CPU time of a stage. On a shared machine the wall time includes waiting for a core;
/// the CPU time does not (but sums over threads), so the table reports both.
struct Stopwatch {
  Clock::time_point wall0 = Clock::now();
  double cpu0 = process_cpu_seconds();
  double wall() const { return seconds_since(wall0); }
  double cpu() const { return process_cpu_seconds() - cpu0; }
};

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux reports KiB
}

/// One line of the table.
struct Row {
  Index n = 0;
  std::string stage{};
  std::string detail{};
  double seconds = 0.0;
  double cpu_seconds = -1.0;  ///< < 0: not measured separately for this row
  double rate = 0.0;          ///< <= 0: no rate for this row
  std::string rate_unit{};
  Index factorizations = 0;
  Index solves = 0;
  double rss_mb = 0.0;
};

void print_header() {
  fmt::print("{:>8}  {:<30} {:<52} {:>10} {:>10} {:>18} {:>6} {:>7} {:>9}\n", "N", "stage",
             "detail", "wall [s]", "cpu [s]", "rate", "fact", "solves", "peak MB");
  fmt::print(
      "{}\n",
      std::string(8 + 2 + 30 + 1 + 52 + 1 + 10 + 1 + 10 + 1 + 18 + 1 + 6 + 1 + 7 + 1 + 9, '-'));
  std::fflush(stdout);
}

class Reporter {
 public:
  explicit Reporter(const std::string& csv_path) {
    if (!csv_path.empty()) {
      m_csv.open(csv_path, std::ios::app);
      if (!m_csv)
        throw ecmor::IoError(fmt::format("bench: cannot append to CSV file '{}'", csv_path));
    }
  }

  void add(Row row) {
    row.rss_mb = peak_rss_mb();
    const std::string rate =
        row.rate > 0.0 ? fmt::format("{:.4g} {}", row.rate, row.rate_unit) : std::string();
    const std::string cpu =
        row.cpu_seconds >= 0.0 ? fmt::format("{:.4f}", row.cpu_seconds) : std::string("-");
    fmt::print("{:>8}  {:<30} {:<52} {:>10.4f} {:>10} {:>18} {:>6} {:>7} {:>9.1f}\n", row.n,
               row.stage, row.detail, row.seconds, cpu, rate, row.factorizations, row.solves,
               row.rss_mb);
    std::fflush(stdout);
    if (m_csv.is_open()) {
      m_csv << fmt::format(
          "{},\"{}\",\"{}\",{:.6g},{},{},{},{},{},{:.1f}\n", row.n, row.stage, row.detail,
          row.seconds,
          row.cpu_seconds >= 0.0 ? fmt::format("{:.6g}", row.cpu_seconds) : std::string(),
          row.rate > 0.0 ? fmt::format("{:.6g}", row.rate) : std::string(), row.rate_unit,
          row.factorizations, row.solves, row.rss_mb);
      m_csv.flush();
    }
  }

 private:
  std::ofstream m_csv;
};

std::vector<double> band_frequencies_hz(Index count) {
  return ecmor::log_grid(kOmegaMin / ecmor::kTwoPi, kOmegaMax / ecmor::kTwoPi, count);
}

/// Reading a Matrix Market file: K written to a temporary file and read back (the read rate
/// that test_matrix_market once asserted as wall time).
void bench_matrix_market(const ecmor::Model& model, Index N, Reporter& out) {
  const auto& K = std::get<ecmor::SecondOrderModel>(model).K;
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / fmt::format("ecmor_bench_core_K_{}.mtx", ::getpid());
  ecmor::write_matrix_market(path, K, "bench_core: K of the triple chain");
  const double mb = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  Stopwatch watch;
  const ecmor::SparseMatrix read = ecmor::read_matrix_market_sparse(path);
  const double seconds = watch.wall();
  std::filesystem::remove(path);
  if (read.nonZeros() != K.nonZeros())
    throw ecmor::NumericalError(
        fmt::format("bench: read {} nonzeros of K, wrote {}", read.nonZeros(), K.nonZeros()));
  out.add({.n = N,
           .stage = "read Matrix Market",
           .detail = fmt::format("K: {:.1f} MB, nnz {}", mb, K.nonZeros()),
           .seconds = seconds,
           .cpu_seconds = watch.cpu(),
           .rate = mb / seconds,
           .rate_unit = "MB/s"});
}

/// Analysis, one real (CHOLMOD) and one complex (UMFPACK) factorisation, and solves.
void bench_factorizations(const ecmor::Model& model, Index N, Reporter& out) {
  const auto& so = std::get<ecmor::SecondOrderModel>(model);
  Stopwatch watch;
  auto solver = ecmor::make_shifted_solver(model);
  out.add({.n = N,
           .stage = "solver construction",
           .detail = "union pattern of M, D, K",
           .seconds = watch.wall(),
           .cpu_seconds = watch.cpu()});

  // Real shift s = 0: P = K, symmetric positive definite, so CHOLMOD. The first factorisation of
  // each arithmetic performs the symbolic analysis; the counters split the two (CPU time is only
  // measured for the whole call, so it is not split).
  const ecmor::SolverCounters c0 = solver->counters();
  auto real_fac = solver->factorize(Complex(0.0, 0.0));
  const ecmor::SolverCounters c1 = solver->counters() - c0;
  out.add({.n = N,
           .stage = "symbolic analysis (real)",
           .detail = fmt::format("{} analyses", c1.symbolic_analyses),
           .seconds = c1.analysis_seconds});
  out.add({.n = N,
           .stage = "real factorisation",
           .detail = fmt::format("P(0) = K, {}", real_fac->method()),
           .seconds = c1.factorization_seconds,
           .factorizations = c1.factorizations});

  // Complex shift on the imaginary axis at the band's upper end: UMFPACK.
  const Complex s(0.0, kOmegaMax);
  const ecmor::SolverCounters c2 = solver->counters();
  auto complex_fac = solver->factorize(s);
  const ecmor::SolverCounters c3 = solver->counters() - c2;
  out.add({.n = N,
           .stage = "symbolic analysis (complex)",
           .detail = fmt::format("{} analyses", c3.symbolic_analyses),
           .seconds = c3.analysis_seconds});
  out.add({.n = N,
           .stage = "complex factorisation",
           .detail = fmt::format("P(i {:g}), {}, rcond {:.1e}", kOmegaMax, complex_fac->method(),
                                 complex_fac->rcond()),
           .seconds = c3.factorization_seconds,
           .factorizations = c3.factorizations});

  // Solves: repeated so that the small sizes are above the clock's resolution.
  const Index repeats = std::max<Index>(1, 2000000 / N);
  const double per = 1.0 / static_cast<double>(repeats);
  const ecmor::ComplexMatrix b = so.B.cast<Complex>();
  double guard = 0.0;  // keeps the solves observable
  const ecmor::SolverCounters c4 = solver->counters();
  watch = Stopwatch{};
  for (Index r = 0; r < repeats; ++r) guard += std::abs(complex_fac->solve(b)(0, 0));
  const double complex_wall = watch.wall() * per;
  out.add({.n = N,
           .stage = "complex solve",
           .detail = fmt::format("1 rhs, mean of {}", repeats),
           .seconds = complex_wall,
           .cpu_seconds = watch.cpu() * per,
           .rate = 1.0 / complex_wall,
           .rate_unit = "solves/s",
           .solves = (solver->counters() - c4).solves});

  const ecmor::SolverCounters c6 = solver->counters();
  watch = Stopwatch{};
  for (Index r = 0; r < repeats; ++r) guard += std::abs(real_fac->solve(so.B)(0, 0));
  const double real_wall = watch.wall() * per;
  out.add({.n = N,
           .stage = "real solve",
           .detail = fmt::format("1 rhs, mean of {}", repeats),
           .seconds = real_wall,
           .cpu_seconds = watch.cpu() * per,
           .rate = 1.0 / real_wall,
           .rate_unit = "solves/s",
           .solves = (solver->counters() - c6).solves});
  if (!std::isfinite(guard)) fmt::print("  (warning: non-finite solution)\n");
}

/// The full model's band response, in parallel over frequencies.
void bench_band_response(const ecmor::Model& model, Index N, const Options& opt, Reporter& out) {
  const std::vector<double> f_hz = band_frequencies_hz(opt.frequencies);
  for (int threads : {1, 2}) {
    auto solver = ecmor::make_shifted_solver(model);
    // Analyse once outside the timing: the band response of a run reuses the run's solver.
    (void)solver->factorize(Complex(0.0, kOmegaMax));
    const ecmor::SolverCounters c0 = solver->counters();
    const Stopwatch watch;
    const auto H = ecmor::frequency_response(model, *solver, f_hz, threads);
    const double wall = watch.wall();
    const double cpu = watch.cpu();
    const ecmor::SolverCounters c = solver->counters() - c0;
    // Share of the CPU time (summed over threads) spent in numeric factorisations; the counters'
    // factorisation seconds are wall-clock per call, so on a loaded machine this is an upper bound.
    const double share = c.factorization_seconds / std::max(cpu, wall * threads);
    out.add({.n = N,
             .stage = "band response",
             .detail = fmt::format("{} freq, {} thread{}, fact {:.0f}%", f_hz.size(), threads,
                                   threads > 1 ? "s" : "", 100.0 * share),
             .seconds = wall,
             .cpu_seconds = cpu,
             .rate = static_cast<double>(f_hz.size()) / wall,
             .rate_unit = "freq/s",
             .factorizations = c.factorizations,
             .solves = c.solves});
    if (H.size() != f_hz.size()) fmt::print("  (warning: {} responses)\n", H.size());
  }
}

/// Symbolic analysis once for all shifts vs a fresh solver (analysis + numeric) per shift.
void bench_symbolic_reuse(const ecmor::Model& model, Index N, const Options& opt, Reporter& out) {
  const std::vector<double> f_hz = band_frequencies_hz(opt.reuse_shifts);
  const auto shifts = static_cast<double>(f_hz.size());

  Stopwatch watch;
  auto shared = ecmor::make_shifted_solver(model);
  for (double f : f_hz) (void)shared->factorize(ecmor::s_from_hz(f));
  const double reuse_wall = watch.wall();
  const double reuse_cpu = watch.cpu();
  const ecmor::SolverCounters cr = shared->counters();
  shared.reset();
  out.add({.n = N,
           .stage = "shifts, one solver",
           .detail = fmt::format("{} shifts, {} analyses", f_hz.size(), cr.symbolic_analyses),
           .seconds = reuse_wall,
           .cpu_seconds = reuse_cpu,
           .rate = shifts / reuse_wall,
           .rate_unit = "shifts/s",
           .factorizations = cr.factorizations});

  ecmor::SolverCounters cf;
  watch = Stopwatch{};
  for (double f : f_hz) {
    auto fresh = ecmor::make_shifted_solver(model);
    (void)fresh->factorize(ecmor::s_from_hz(f));
    cf += fresh->counters();
  }
  const double fresh_wall = watch.wall();
  const double fresh_cpu = watch.cpu();
  out.add(
      {.n = N,
       .stage = "shifts, fresh solver each",
       .detail = fmt::format("{} analyses; reuse gain x{:.2f} wall, x{:.2f} cpu",
                             cf.symbolic_analyses, fresh_wall / reuse_wall, fresh_cpu / reuse_cpu),
       .seconds = fresh_wall,
       .cpu_seconds = fresh_cpu,
       .rate = shifts / fresh_wall,
       .rate_unit = "shifts/s",
       .factorizations = cf.factorizations});
}

/// The modal reducer's work diagnostics that explain its time (eigenpairs computed, ARPACK runs).
std::string diagnostics(const ecmor::ReducerResult& result) {
  std::string text;
  for (const char* key : {"computed_modes", "batches", "operator_applications"}) {
    const auto it = result.diagnostics.find(key);
    if (it == result.diagnostics.end()) continue;
    const std::string name = std::string(key) == "computed_modes" ? "eig"
                             : std::string(key) == "batches"      ? "runs"
                                                                  : "ops";
    text += fmt::format("{}{} {:g}", text.empty() ? "" : ", ", name, it->second);
  }
  return text;
}

/// Loads the plugin providing `name` (the default directories, then the build tree's) into
/// `registry`; false, with a printed note, when it is not found.
bool load_reducer(ecmor::Registry& registry, const std::string& name, const Options& opt) {
  std::vector<std::filesystem::path> dirs;
  if (!opt.plugin_dir.empty()) {
    dirs.emplace_back(opt.plugin_dir);
  } else {
    dirs = ecmor::default_plugin_directories();
    const std::filesystem::path build_dir(ECMOR_BENCH_PLUGIN_DIR);
    if (!build_dir.empty() &&
        std::find(dirs.begin(), dirs.end(), build_dir.lexically_normal()) == dirs.end()) {
      dirs.push_back(build_dir);
    }
  }
  std::vector<std::string> load_errors;
  for (const auto& dir : dirs) {
    if (registry.contains(name)) break;
    for (auto& e : registry.load_directory(dir)) load_errors.push_back(std::move(e));
  }
  if (registry.contains(name)) return true;
  std::string where;
  for (const auto& d : dirs) where += (where.empty() ? "" : ", ") + d.string();
  fmt::print("  {} reducer not found in [{}]{}{}: {} rows skipped\n", name, where,
             load_errors.empty() ? "" : "; ", load_errors.empty() ? "" : load_errors.front(), name);
  return false;
}

/// Modal reduction through the registry (the plugin as the driver loads it).
void bench_modal(const ecmor::Model& model, Index N, const Options& opt, Reporter& out) {
  ecmor::Registry registry;
  if (!load_reducer(registry, "modal", opt)) return;

  const ecmor::Band band{kOmegaMin / ecmor::kTwoPi, kOmegaMax / ecmor::kTwoPi};
  for (Index order : opt.modal_orders) {
    for (bool static_correction : {false, true}) {
      ecmor::ParameterMap params("reducer 'modal'");
      params.set("static_correction", static_correction);
      auto solver = ecmor::make_shifted_solver(model);
      const Stopwatch watch;
      auto reducer = registry.create("modal", params);
      reducer->setup(ecmor::ReductionContext{&model, solver.get(), band});
      const ecmor::ReducerResult result = reducer->reduce(ecmor::ReductionRequest{order, {}});
      const double wall = watch.wall();
      const double cpu = watch.cpu();
      const ecmor::SolverCounters c = solver->counters();
      out.add({.n = N,
               .stage = fmt::format("modal r={}{}", order, static_correction ? " +static" : ""),
               .detail = fmt::format("n={}, fact {:.0f}%, {}", ecmor::size_of(result.model),
                                     100.0 * c.factorization_seconds / std::max(cpu, wall),
                                     diagnostics(result)),
               .seconds = wall,
               .cpu_seconds = cpu,
               .factorizations = c.factorizations,
               .solves = c.solves});
    }
  }
}

/// One Krylov reduction at fixed points through the registry: the reduction proper (no error
/// estimation), p points log-spaced in the band with k moments each, one-sided. Order r = 2 p k for
/// a SISO model (complex points give real and imaginary parts). Comparable with one IRKA
/// iteration of order r (r/2 complex factorisations), not with a converged IRKA run.
void bench_krylov(const ecmor::Model& model, Index N, const Options& opt, Reporter& out) {
  ecmor::Registry registry;
  if (!load_reducer(registry, "krylov", opt)) return;
  const ecmor::Band band{kOmegaMin / ecmor::kTwoPi, kOmegaMax / ecmor::kTwoPi};
  struct Case {
    Index points, moments;
  };
  for (const Case c : {Case{5, 2}, Case{10, 5}}) {
    const std::vector<double> f = ecmor::log_grid(band.f_min_hz, band.f_max_hz, c.points);
    std::vector<ecmor::ExpansionPoint> points;
    for (double fi : f) points.push_back(ecmor::point_at_hz(fi, c.moments));
    auto solver = ecmor::make_shifted_solver(model);
    const Stopwatch watch;
    auto reducer = registry.create("krylov", ecmor::ParameterMap("reducer 'krylov'"));
    reducer->setup(ecmor::ReductionContext{&model, solver.get(), band});
    const ecmor::ReducerResult result = reducer->reduce(ecmor::ReductionRequest{0, points});
    const double wall = watch.wall();
    const double cpu = watch.cpu();
    const ecmor::SolverCounters sc = solver->counters();
    out.add({.n = N,
             .stage =
                 fmt::format("krylov r={} ({} pts x {} mom)", result.V.cols(), c.points, c.moments),
             .detail = fmt::format(
                 "fact+solve {:.0f}%, {}",
                 100.0 * (sc.factorization_seconds + sc.solve_seconds) / std::max(cpu, wall),
                 diagnostics(result)),
             .seconds = wall,
             .cpu_seconds = cpu,
             .factorizations = sc.factorizations,
             .solves = sc.solves});
  }
}

/// A random lightly damped reduced second-order model of order n with m inputs and p outputs:
/// SPD M and K (eigenvalues spread over decades, as projected FE matrices), D = 1e-3 (M + K).
ecmor::ReducedSecondOrderModel random_reduced_model(Index n, Index m, Index p, unsigned seed) {
  std::mt19937 gen(seed);
  std::normal_distribution<double> dist;
  auto random = [&](Index rows, Index cols) {
    ecmor::Matrix X(rows, cols);
    for (Index j = 0; j < cols; ++j)
      for (Index i = 0; i < rows; ++i) X(i, j) = dist(gen);
    return X;
  };
  ecmor::ReducedSecondOrderModel r;
  const ecmor::Matrix Qm = random(n, n).householderQr().householderQ();
  const ecmor::Matrix Qk = random(n, n).householderQr().householderQ();
  ecmor::Vector dm(n), dk(n);
  for (Index i = 0; i < n; ++i) {
    const double t = n > 1 ? static_cast<double>(i) / static_cast<double>(n - 1) : 0.0;
    dm(i) = std::pow(10.0, -t);       // M: eigenvalues 1 .. 0.1
    dk(i) = std::pow(10.0, 4.0 * t);  // K: eigenvalues 1 .. 1e4
  }
  r.M = Qm * dm.asDiagonal() * Qm.transpose();
  r.K = Qk * dk.asDiagonal() * Qk.transpose();
  r.D = 1e-3 * (r.M + r.K);
  r.B = random(n, m);
  r.C = random(p, n);
  return r;
}

/// The reduced model's frequency response, the hot spot of every strategy's error assessment:
/// per-frequency time of ReducedResponse (and its one-off setup) at first-order dimensions 40,
/// 160 and 328 (the largest a greedy run on triplechain_mess_n1501 reaches), SISO and 3 x 3, one
/// thread, next to the dense LU of P_r(s) (transfer_function) it replaces.
void bench_reduced_response(Reporter& out) {
  for (Index n : {20, 80, 164}) {
    for (Index io : {1, 3}) {
      const ecmor::ReducedModel model =
          random_reduced_model(n, io, io, 7u + static_cast<unsigned>(n));
      // Frequencies across the poles (omega 1 .. 100 rad/s), as an assessment grid is.
      const Index count = std::max<Index>(1000, 5000000 / (n * n));
      const std::vector<double> f_hz =
          ecmor::log_grid(0.5 / ecmor::kTwoPi, 200.0 / ecmor::kTwoPi, count);
      Stopwatch watch;
      const ecmor::ReducedResponse response(model);
      const double setup = watch.wall();
      double guard = 0.0;
      watch = Stopwatch{};
      for (double f : f_hz) guard += std::abs(response(ecmor::s_from_hz(f))(0, 0));
      const double per = watch.wall() / static_cast<double>(count);
      const double per_cpu = watch.cpu() / static_cast<double>(count);
      // Dense LU reference on a tenth of the frequencies (it is the slow path).
      const Index dense_count = std::max<Index>(20, count / 10);
      watch = Stopwatch{};
      for (Index i = 0; i < dense_count; ++i) {
        guard += std::abs(ecmor::transfer_function(
            model, ecmor::s_from_hz(f_hz[static_cast<std::size_t>(i)]))(0, 0));
      }
      const double dense_per = watch.wall() / static_cast<double>(dense_count);
      out.add({.n = 2 * n,
               .stage = fmt::format("reduced response {}x{}", io, io),
               .detail = fmt::format("{:.2f} us/freq; setup {:.2f} ms; dense LU {:.1f} us{}",
                                     1e6 * per, 1e3 * setup, 1e6 * dense_per,
                                     response.hessenberg() ? "" : "; FALLBACK"),
               .seconds = per,
               .cpu_seconds = per_cpu,
               .rate = 1.0 / per,
               .rate_unit = "freq/s"});
      if (!std::isfinite(guard)) fmt::print("  (warning: non-finite reduced response)\n");
    }
  }
}

void run_size(Index N, const Options& opt) {
  Reporter out(opt.csv);
  const Index n1 = (N - 1) / 3;
  N = 3 * n1 + 1;
  const Stopwatch watch;
  const ecmor::Model model = ecmor::bench::triple_chain(n1, kAlpha, kBeta, kViscosity);
  out.add({.n = N,
           .stage = "generate triple chain",
           .detail = fmt::format("n1={}, nnz(K)={}", n1,
                                 std::get<ecmor::SecondOrderModel>(model).K.nonZeros()),
           .seconds = watch.wall(),
           .cpu_seconds = watch.cpu()});
  bench_matrix_market(model, N, out);
  bench_factorizations(model, N, out);
  bench_band_response(model, N, opt, out);
  bench_symbolic_reuse(model, N, opt, out);
  bench_krylov(model, N, opt, out);
  if (N <= opt.modal_max_n) {
    bench_modal(model, N, opt, out);
  } else {
    fmt::print("  modal rows skipped at N={} (> --modal-max-n {})\n", N, opt.modal_max_n);
  }
}

Index parse_size(const std::string& text) {
  std::size_t used = 0;
  const double value = std::stod(text, &used);
  if (used != text.size() || !(value >= 4.0) || value > 7.0e8) {
    throw ecmor::ConfigError(fmt::format("bench: size '{}': must be a number in [4, 7e8]", text));
  }
  return static_cast<Index>(std::llround(value));
}

Options parse_arguments(int argc, char** argv) {
  Options opt;
  bool sizes_given = false;
  bool modal_max_n_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw ecmor::ConfigError(fmt::format("bench: {} needs a value", arg));
      return argv[++i];
    };
    if (arg == "--quick") {
      opt.quick = true;
    } else if (arg == "--csv") {
      opt.csv = value();
    } else if (arg == "--modal-max-n") {
      opt.modal_max_n = parse_size(value());
      modal_max_n_given = true;
    } else if (arg == "--plugin-dir") {
      opt.plugin_dir = value();
    } else if (arg == "--sizes") {
      const std::string list = value();
      std::size_t start = 0;
      while (start <= list.size()) {
        std::size_t end = list.find(',', start);
        if (end == std::string::npos) end = list.size();
        opt.sizes.push_back(parse_size(list.substr(start, end - start)));
        start = end + 1;
      }
      sizes_given = true;
    } else if (arg == "--reduced-only") {
      opt.reduced_only = true;
    } else if (arg == "--help" || arg == "-h") {
      fmt::print(
          "usage: {} [--quick] [--sizes 1e4,1e5,1e6] [--csv file] [--plugin-dir dir] "
          "[--modal-max-n 1e5] [--reduced-only]\n",
          argv[0]);
      std::exit(0);
    } else {
      throw ecmor::ConfigError(
          fmt::format("bench: unknown argument '{}' (valid: --quick, --sizes, "
                      "--csv, --plugin-dir, --modal-max-n, --reduced-only, --help)",
                      arg));
    }
  }
  if (opt.quick) {
    // Smoke run: the two smaller sizes, a shorter band grid, one modal order at N = 1e4 only.
    opt.frequencies = 16;
    opt.reuse_shifts = 4;
    opt.modal_orders = {20};
    if (!modal_max_n_given) opt.modal_max_n = 10000;
  }
  if (!sizes_given) {
    opt.sizes =
        opt.quick ? std::vector<Index>{10000, 100000} : std::vector<Index>{10000, 100000, 1000000};
  }
  return opt;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  try {
    opt = parse_arguments(argc, argv);
  } catch (const ecmor::Error& e) {
    fmt::print(stderr, "{}\n", e.what());
    return 2;
  }
  fmt::print(
      "ecmor bench_core: triple chain alpha=beta={:g}, v={:g}, band {:g}..{:g} rad/s; "
      "{} hardware threads; mode {}\n",
      kAlpha, kViscosity, kOmegaMin, kOmegaMax, std::thread::hardware_concurrency(),
      opt.quick ? "quick" : "full");
  if (!opt.csv.empty()) {
    std::ofstream csv(opt.csv, std::ios::trunc);
    if (!csv) {
      fmt::print(stderr, "bench: cannot write CSV file '{}'\n", opt.csv);
      return 2;
    }
    csv << "N,stage,detail,seconds,cpu_seconds,rate,rate_unit,factorizations,solves,peak_rss_mb\n";
  }
  print_header();

  // Reduced models are small and dense: one process for all of them, before the large sizes.
  try {
    Reporter reduced_out(opt.csv);
    bench_reduced_response(reduced_out);
  } catch (const std::exception& e) {
    fmt::print("  reduced response: failed: {}\n", e.what());
    if (opt.reduced_only) return 1;
  }
  if (opt.reduced_only) return 0;

  int failures = 0;
  for (Index N : opt.sizes) {
    const pid_t pid = fork();
    if (pid < 0) {
      fmt::print(stderr, "bench: fork failed\n");
      return 1;
    }
    if (pid == 0) {
      int code = 0;
      try {
        run_size(N, opt);
      } catch (const std::exception& e) {
        fmt::print("  N={}: failed: {}\n", N, e.what());
        code = 1;
      }
      std::fflush(stdout);
      std::_Exit(code);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    if (WIFSIGNALED(status)) {
      fmt::print("  N={}: killed by signal {}\n", N, WTERMSIG(status));
      ++failures;
    } else if (WEXITSTATUS(status) != 0) {
      ++failures;
    }
  }
  return failures == 0 ? 0 : 1;
}
