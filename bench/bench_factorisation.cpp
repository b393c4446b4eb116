// ecmor_bench_factorisation: one complex factorisation of P(s) = s^2 M + s D + K at s = i 2 pi f,
// and the solve of its B columns, with the embedded backend under a chosen ordering and method
// (issue 27; docs/benchmarks.md, "Sparse factorisation of 3-D solids").
//
//   ecmor_bench_factorisation MODEL_DIR F_HZ [--ordering auto|amd|metis]
//                             [--complex-symmetric auto|ldlt|lu] [--repeat R] [--sweep K]
//
// MODEL_DIR holds M.mtx, D.mtx, K.mtx, B.mtx, C.mtx (say, from `ecmor_bench_models solid ...`).
// Prints one line: method, ordering, times of the first factorisation (with the analysis) and of
// the next R - 1 ones (analysis reused), the solve, the relative residual ||P X - B|| / ||B||, and
// the peak resident memory of the process. Run one method per process, so that the peak memory
// is that method's; run it under another BLAS with LD_LIBRARY_PATH (bench/factorisation.sh).
// --sweep K also times the frequency response at K log-spaced frequencies in [F_HZ/10, F_HZ], as
// the error control sweeps it (in parallel over frequencies when the solver is concurrent, one
// factorisation at a time with MUMPS): the throughput that SolverOptions::complex_symmetric weighs
// against memory.
#include <fmt/core.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace {

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // KiB on Linux
}

int usage(const char* self) {
  fmt::print(stderr,
             "usage: {} MODEL_DIR F_HZ [--ordering auto|amd|metis] "
             "[--complex-symmetric auto|ldlt|lu] [--repeat R] [--sweep K]\n",
             self);
  return 1;
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 3) return usage(argv[0]);
  const std::string dir = argv[1];
  const double f_hz = std::stod(argv[2]);
  ecmor::SolverOptions options;
  int repeat = 2, sweep = 0;
  for (int a = 3; a < argc; ++a) {
    const std::string key = argv[a];
    if (a + 1 >= argc) return usage(argv[0]);
    const std::string value = argv[++a];
    if (key == "--ordering")
      options.ordering = value;
    else if (key == "--complex-symmetric")
      options.complex_symmetric = value;
    else if (key == "--repeat")
      repeat = std::max(1, std::stoi(value));
    else if (key == "--sweep")
      sweep = std::max(0, std::stoi(value));
    else
      return usage(argv[0]);
  }
  const auto t_load = std::chrono::steady_clock::now();
  const ecmor::Model model = ecmor::load_model(dir);
  const double load_s = seconds(t_load);
  const auto& so = std::get<ecmor::SecondOrderModel>(model);
  const double rss_model = peak_rss_mib();
  auto solver = ecmor::make_shifted_solver(model, options);
  const ecmor::Complex s(0.0, 2.0 * ecmor::kPi * f_hz);
  const ecmor::ComplexMatrix B = so.B.cast<ecmor::Complex>();
  double first_s = 0.0, next_s = 0.0, solve_s = 0.0, residual = 0.0;
  std::string method;
  for (int r = 0; r < repeat; ++r) {
    // A slightly different shift each time: a new numeric factorisation on the same pattern.
    const ecmor::Complex sr = s * (1.0 + 1e-3 * r);
    const auto t0 = std::chrono::steady_clock::now();
    auto F = solver->factorize(sr);
    (r == 0 ? first_s : next_s) += seconds(t0);
    const auto t1 = std::chrono::steady_clock::now();
    const ecmor::ComplexMatrix X = F->solve(B);
    solve_s += seconds(t1);
    method = F->method();
    if (r == 0) {
      const std::vector<ecmor::Complex> w{1.0, sr, sr * sr};
      residual = (solver->apply_combination(w, X) - B).norm() / B.norm();
    }
  }
  double sweep_s = 0.0;
  if (sweep > 0) {
    std::vector<double> f(static_cast<std::size_t>(sweep));
    for (int k = 0; k < sweep; ++k)
      f[static_cast<std::size_t>(k)] =
          f_hz * std::pow(10.0, sweep > 1 ? -1.0 + static_cast<double>(k) / (sweep - 1) : 0.0);
    const auto t0 = std::chrono::steady_clock::now();
    (void)ecmor::frequency_response(model, *solver, f, 0);
    sweep_s = seconds(t0);
  }
  const ecmor::SolverCounters c = solver->counters();
  fmt::print(
      "N {} nnz(K) {} f {} Hz | {} ordering {} | load {:.2f} s | factorise first {:.2f} s, next "
      "{:.2f} s (x{}) | solve {:.3f} s for {} columns | residual {:.1e} | analyses {} | sweep of "
      "{} "
      "frequencies {:.2f} s ({}) | peak RSS {:.0f} MiB (model {:.0f} MiB)\n",
      so.K.rows(), so.K.nonZeros(), f_hz, method, options.ordering, load_s, first_s,
      repeat > 1 ? next_s / (repeat - 1) : 0.0, repeat - 1, solve_s / repeat, B.cols(), residual,
      c.symbolic_analyses, sweep, sweep_s, solver->concurrent() ? "parallel" : "serial",
      peak_rss_mib(), rss_model);
  return 0;
} catch (const std::exception& e) {
  fmt::print(stderr, "ecmor_bench_factorisation: {}\n", e.what());
  return 1;
}
