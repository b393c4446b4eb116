// adi_options.cpp: the low-rank ADI solver's options, stated once: AdiOptions::validate() and the
// balanced plugin's adi_* keys (its option_specs(), through Option::prefixed) apply these specs.
#include <string>
#include <utility>
#include <vector>

#include "ecmor/base/options.hpp"
#include "ecmor/gramians/lowrank_adi.hpp"

namespace ecmor {

const std::vector<std::pair<std::string, AdiShiftStrategy>>& adi_shift_strategy_names() {
  static const NameList<AdiShiftStrategy> names = {{"projection", AdiShiftStrategy::Projection},
                                                   {"heuristic", AdiShiftStrategy::Heuristic}};
  return names;
}

std::string to_string(AdiShiftStrategy strategy) {
  return name_of(adi_shift_strategy_names(), strategy);
}

AdiShiftStrategy parse_adi_shift_strategy(const std::string& name) {
  return value_of(adi_shift_strategy_names(), name, "shifts");
}

const OptionSpecs<AdiOptions>& AdiOptions::specs() {
  using A = AdiOptions;
  static const OptionSpecs<A> specs({
      option("tolerance", &A::tolerance,
             "low-rank ADI: stop when ||R||_2 / ||B B'||_2 (C'C) <= this")
          .range(Range::open(0, 1)),
      option("max_iterations", &A::max_iterations,
             "low-rank ADI: iteration budget per Gramian (a complex pair counts as two)")
          .range(Range::at_least(1)),
      choice("shifts", &A::shifts, adi_shift_strategy_names(),
             "low-rank ADI shifts: projection (self-generating, Benner-Kuerschner-Saak) or "
             "heuristic (Penzl)"),
      option("max_shifts", &A::max_shifts, "low-rank ADI: shifts per generated set")
          .range(Range::at_least(1)),
      option("projection_columns", &A::projection_columns,
             "projection shifts: project on at most this many of the last columns of Z; 0 = "
             "max_shifts times the columns of B (C')")
          .range(Range::at_least(0)),
      option("arnoldi_steps", &A::arnoldi_steps,
             "heuristic shifts: Arnoldi steps on E^-1 A (large eigenvalues)")
          .range(Range::at_least(1)),
      option("inverse_arnoldi_steps", &A::inverse_arnoldi_steps,
             "heuristic shifts: Arnoldi steps on A^-1 E (small eigenvalues)")
          .range(Range::at_least(1)),
      option("unstable_ritz_residual", &A::unstable_ritz_residual,
             "a Ritz value with Re >= 0 whose relative residual is at most this is an eigenvalue "
             "(the model is refused as not asymptotically stable); above it, it is mirrored")
          .range(Range::closed_open(0, 1)),
      option("compress", &A::compress,
             "compress Z at the end to its singular directions above compression_tolerance"),
      option("compression_tolerance", &A::compression_tolerance,
             "relative singular-value tolerance of the compression of Z")
          .range(Range::closed_open(0, 1)),
  });
  return specs;
}

void AdiOptions::validate() const { specs().validate(*this, "AdiOptions"); }

}  // namespace ecmor
