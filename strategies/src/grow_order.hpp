#pragma once
/// \file grow_order.hpp
/// grow_order: increase the reduced order until the relative band error meets the tolerance (and
/// the independent re-check agrees), then bisect back to the smallest order that still meets it.

#include "ecmor/base/options.hpp"
#include "ecmor/strategies/strategy.hpp"

namespace ecmor {

/// Settings of grow_order; the initialisers are the defaults, specs() the keys, ranges and
/// documentation.
struct GrowOrderOptions {
  Index initial_order = 2;     ///< first order tried
  double growth_factor = 1.5;  ///< next order = max(n + order_step, ceil(growth_factor * n))
  Index order_step = 1;        ///< minimal increment (rounded up to the reducer's order_step)
  Index max_order = 200;       ///< order budget, >= initial_order
  Index max_iterations = 200;  ///< iteration budget (grow + shrink + verify)
  bool shrink = true;          ///< bisect to the smallest passing order after the first pass
  /// Stagnated when the best error has not improved by stagnation_ratio over this many growth
  /// steps (0: never). The ratio compares the new best with the best `window` steps earlier.
  Index stagnation_window = 0;
  double stagnation_ratio = 0.99;

  /// Keys, ranges and documentation of the fields above.
  static const OptionSpecs<GrowOrderOptions>& specs();
  /// Reads every option from `params`. \throws ConfigError naming the key, value and rule.
  static GrowOrderOptions from(const ParameterMap& params) { return specs().read(params); }
};

class GrowOrder final : public Strategy {
 public:
  explicit GrowOrder(GrowOrderOptions options) : m_options(options) {}
  StrategyResult run(StrategyContext& context) override;
  bool order_only_grows() const override { return true; }

 private:
  GrowOrderOptions m_options;
};

}  // namespace ecmor
