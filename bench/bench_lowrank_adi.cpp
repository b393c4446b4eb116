// bench_lowrank_adi: low-rank ADI on the large shared models, both Gramians, both shift strategies.
// Measures (never asserts) iterations, rank, residual, time and where the time goes. Run from the
// project root: ./build/bin/ecmor_bench_lowrank_adi [model ...] (default: triplechain_mess_n1501,
// rail_5177, rail_20209); --no-compress skips the final column compression,
// --max-iterations N overrides the default budget.
#include <fmt/format.h>

#include <chrono>
#include <exception>
#include <string>
#include <vector>

#include "ecmor/lowrank_adi.hpp"
#include "ecmor/model_io.hpp"

int main(int argc, char** argv) {
  using namespace ecmor;
  std::vector<std::string> names;
  bool compress = true;
  ecmor::Index max_iterations = ecmor::AdiOptions{}.max_iterations;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--no-compress")
      compress = false;
    else if (arg == "--max-iterations" && i + 1 < argc)
      max_iterations = std::stol(argv[++i]);
    else
      names.push_back(arg);
  }
  if (names.empty()) names = {"triplechain_mess_n1501", "rail_5177", "rail_20209"};
  fmt::print("{:<24} {:<10} {:<15} {:>5} {:>6} {:>6} {:>9} {:>5} {:>6} {:>8} {:>8} {:>8} {:>8}\n",
             "model", "shifts", "gramian", "iter", "rank", "Zcols", "residual", "conv", "fact",
             "solves", "fact[s]", "solve[s]", "total[s]");
  for (const std::string& name : names) {
    try {
      const Model model = load_model("../shared/models/" + name);
      for (AdiShiftStrategy strategy : {AdiShiftStrategy::Projection, AdiShiftStrategy::Heuristic}) {
        // A fresh solver per strategy: no factorisation or analysis carried over.
        auto solver = make_shifted_solver(model);
        FirstOrderView view(model, *solver);
        AdiOptions options;
        options.shifts = strategy;
        options.compress = compress;
        options.max_iterations = max_iterations;
        const auto t0 = std::chrono::steady_clock::now();
        LowRankAdi adi(view, options);
        double both = 0.0;
        for (GramianSide side : {GramianSide::Controllability, GramianSide::Observability}) {
          const AdiResult r = adi.solve(side);
          both += r.seconds;
          fmt::print("{:<24} {:<10} {:<15} {:>5} {:>6} {:>6} {:>9.2e} {:>5} {:>6} {:>8} {:>8.3f} "
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
