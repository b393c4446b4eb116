// import.cpp: `ecmor import calculix CONFIG`: reads the import YAML, runs the import (core,
// calculix.hpp) and prints what was written. No numerics here.
#include <fmt/format.h>

#include "commands.hpp"
#include "ecmor/interop/calculix.hpp"

namespace ecmor::app {

int import_calculix(const std::filesystem::path& config, const CommonOptions& common) {
  return guarded([&] {
    CalculixImportConfig c = load_calculix_import_config(config);
    if (!common.output_dir.empty())
      c.output_dir = std::filesystem::absolute(common.output_dir).lexically_normal();
    const CalculixImportSummary s = import_calculix(c);
    if (!common.quiet) {
      fmt::print("deck     {}\n", c.deck.string());
      if (c.run)
        fmt::print("ccx      {:.2f} s (the deck it ran and its log: {})\n", s.ccx_seconds,
                   s.calculix_dir.string());
      for (std::size_t k = 0; k < s.input_labels.size(); ++k)
        fmt::print("input  {:>3}  {}\n", k + 1, s.input_labels[k]);
      for (std::size_t k = 0; k < s.output_labels.size(); ++k)
        fmt::print("output {:>3}  {}\n", k + 1, s.output_labels[k]);
    }
    fmt::print(
        "imported {}: second order model, N = {}, {} input(s), {} output(s), {} nodes; "
        "D = {:g} M + {:g} K\n",
        c.output_dir.string(), s.size, s.inputs, s.outputs, s.nodes, c.alpha, c.beta);
    return 0;
  });
}

}  // namespace ecmor::app
