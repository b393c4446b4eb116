// bench_lowrank_adi: low-rank ADI on the large benchmark models, both Gramians, both shift
// strategies. Measures (never asserts) iterations, rank, residual, time and where the time goes.
// Run from the project root: ./build/bin/ecmor_bench_lowrank_adi [model ...] (default:
// triplechain_mess_n1501, rail_5177, rail_20209); --no-compress skips the final column compression,
// --max-iterations N overrides the default budget, --tolerance T the ADI tolerance.
// --band F1 F2 (Hz) runs the frequency-limited Gramians instead (lowrank_band_gramians, projection
// shifts): quadrature nodes and time, then per Gramian the iterations, the rank of the
// semidefinite factor and of L, the free residual and the residual of Z Z' (lowrank_residual),
// the most negative eigenvalue dropped, and the time.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ecmor/gramians/lowrank_adi.hpp"
#include "ecmor/model/model_io.hpp"

namespace {

/// The band mode (see the file comment).
void run_band(const std::string& name, const ecmor::Model& model, const ecmor::Band& band,
              const ecmor::AdiOptions& options) {
  using namespace ecmor;
  auto solver = make_shifted_solver(model);
  FirstOrderView view(model, *solver);
  const auto t0 = std::chrono::steady_clock::now();
  const LowRankBandGramians g = lowrank_band_gramians(view, band, options);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto& q = g.integrals.quadrature;
  fmt::print(
      "{:<24} band {:g}..{:g} Hz: quadrature {} nodes over {} ({} intervals, error "
      "estimate {:.1e} rel, {}), {:.3f} s\n",
      name, band.f_min_hz, band.f_max_hz, q.evaluations, g.integrals.variable, q.intervals,
      q.error_estimate / q.integral.norm(), q.converged ? "converged" : "NOT converged",
      g.quadrature_seconds);
  fmt::print(
      "{:<24} {:<15} {:>5} {:>6} {:>6} {:>9} {:>9} {:>5} {:>9} {:>6} {:>8} {:>8} "
      "{:>8} {:>8}\n",
      "model", "gramian", "iter", "rank", "Lcols", "residual", "res(ZZ')", "conv", "neg.eig",
      "fact", "solves", "fact[s]", "solve[s]", "total[s]");
  for (const AdiLdlResult* r : {&g.controllability, &g.observability}) {
    const double res_z = lowrank_residual(view, r->Z, r->side, r->G, r->S);
    fmt::print(
        "{:<24} {:<15} {:>5} {:>6} {:>6} {:>9.2e} {:>9.2e} {:>5} {:>9.1e} {:>6} {:>8} "
        "{:>8.3f} {:>8.3f} {:>8.3f}\n",
        name, to_string(r->side), r->iterations, r->Z.cols(), r->L.cols(), r->residual, res_z,
        r->converged ? "yes" : "no", r->most_negative_eigenvalue, r->factorizations, r->solves,
        r->counters.factorization_seconds + r->counters.analysis_seconds, r->counters.solve_seconds,
        r->seconds);
  }
  // The shifts approximate the spectrum: their range says where the band lies relative to the
  // poles (in Hz, |p| / 2 pi).
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  for (const Complex& p : g.controllability.shifts) {
    lo = std::min(lo, std::abs(p));
    hi = std::max(hi, std::abs(p));
  }
  fmt::print("{:<24} shift moduli {:.2e} .. {:.2e} Hz\n", name, lo / kTwoPi, hi / kTwoPi);
  fmt::print("{:<24} band Gramians {:.3f} s (quadrature {:.3f} s; wall {:.3f} s)\n", name,
             g.seconds, g.quadrature_seconds, wall);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ecmor;
  std::vector<std::string> names;
  bool compress = true;
  ecmor::Index max_iterations = ecmor::AdiOptions{}.max_iterations;
  double tolerance = ecmor::AdiOptions{}.tolerance;
  std::optional<Band> band;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--no-compress")
      compress = false;
    else if (arg == "--max-iterations" && i + 1 < argc)
      max_iterations = std::stol(argv[++i]);
    else if (arg == "--tolerance" && i + 1 < argc)
      tolerance = std::stod(argv[++i]);
    else if (arg == "--band" && i + 2 < argc) {
      band = Band{std::stod(argv[i + 1]), std::stod(argv[i + 2])};
      i += 2;
    } else
      names.push_back(arg);
  }
  if (names.empty()) names = {"triplechain_mess_n1501", "rail_5177", "rail_20209"};
  if (band) {
    for (const std::string& name : names) {
      try {
        AdiOptions options;
        options.compress = compress;
        options.max_iterations = max_iterations;
        options.tolerance = tolerance;
        run_band(name, load_model("models/" + name), *band, options);
      } catch (const std::exception& e) {
        fmt::print("{}: {}\n", name, e.what());
      }
    }
    return 0;
  }
  fmt::print("{:<24} {:<10} {:<15} {:>5} {:>6} {:>6} {:>9} {:>5} {:>6} {:>8} {:>8} {:>8} {:>8}\n",
             "model", "shifts", "gramian", "iter", "rank", "Zcols", "residual", "conv", "fact",
             "solves", "fact[s]", "solve[s]", "total[s]");
  for (const std::string& name : names) {
    try {
      const Model model = load_model("models/" + name);
      for (AdiShiftStrategy strategy :
           {AdiShiftStrategy::Projection, AdiShiftStrategy::Heuristic}) {
        // A fresh solver per strategy: no factorisation or analysis carried over.
        auto solver = make_shifted_solver(model);
        FirstOrderView view(model, *solver);
        AdiOptions options;
        options.shifts = strategy;
        options.compress = compress;
        options.max_iterations = max_iterations;
        options.tolerance = tolerance;
        const auto t0 = std::chrono::steady_clock::now();
        LowRankAdi adi(view, options);
        double both = 0.0;
        for (GramianSide side : {GramianSide::Controllability, GramianSide::Observability}) {
          const AdiResult r = adi.solve(side);
          both += r.seconds;
          fmt::print(
              "{:<24} {:<10} {:<15} {:>5} {:>6} {:>6} {:>9.2e} {:>5} {:>6} {:>8} {:>8.3f} "
              "{:>8.3f} {:>8.3f}\n",
              name, to_string(strategy), to_string(side), r.iterations, r.Z.cols(),
              r.uncompressed_rank, r.residual, r.converged ? "yes" : "no", r.factorizations,
              r.solves, r.counters.factorization_seconds + r.counters.analysis_seconds,
              r.counters.solve_seconds, r.seconds);
        }
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        fmt::print("{:<24} {:<10} {:<15} both Gramians {:.3f} s (wall {:.3f} s)\n", name,
                   to_string(strategy), "", both, wall);
      }
    } catch (const std::exception& e) {
      fmt::print("{}: {}\n", name, e.what());
    }
  }
  return 0;
}
