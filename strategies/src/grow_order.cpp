#include "grow_order.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "ecmor/base/error.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "support.hpp"

namespace ecmor {

const OptionSpecs<GrowOrderOptions>& GrowOrderOptions::specs() {
  using O = GrowOrderOptions;
  static const OptionSpecs<O> specs(
      {
          option("initial_order", &O::initial_order, "first order tried").range(Range::at_least(1)),
          option("growth_factor", &O::growth_factor,
                 "next order = max(n + order_step, ceil(growth_factor * n))")
              .range(Range::closed(1, 100)),
          option("order_step", &O::order_step,
                 "minimal increment (rounded up to the reducer's own step)")
              .range(Range::at_least(1)),
          option("max_order", &O::max_order,
                 "order budget, >= initial_order (the reducer's own maximum also applies)")
              .range(Range::at_least(1)),
          option("max_iterations", &O::max_iterations,
                 "iteration budget, counting grow, verify and shrink rows")
              .range(Range::at_least(1)),
          option("shrink", &O::shrink, "bisect to the smallest passing order after the first pass"),
          strategy_support::stagnation_window_option(
              &O::stagnation_window,
              "stop as stagnated when the best error has not improved by stagnation_ratio over "
              "this many growth steps; 0 = never (the default: a modal or Krylov error often "
              "plateaus before it drops)"),
          strategy_support::stagnation_ratio_option(
              &O::stagnation_ratio,
              "stagnated when best error >= stagnation_ratio x the best error "
              "stagnation_window growth steps earlier"),
      },
      {[](const O& o, const OptionCheck<O>& c) {
        if (o.max_order < o.initial_order) {
          c.fail(o.max_order,
                 "must be >= " + c.key(o.initial_order) + " = " + std::to_string(o.initial_order));
        }
      }});
  return specs;
}

using strategy_support::Candidate;
using strategy_support::sci;
using strategy_support::Stagnation;

StrategyResult GrowOrder::run(StrategyContext& ctx) {
  strategy_support::StrategyRun run(ctx);
  Reducer& reducer = *ctx.reducer;
  const Index step = std::max<Index>(m_options.order_step, reducer.order_step());
  const Index max_order = std::min(m_options.max_order, reducer.max_order());
  auto try_order = [&](Index order, const std::string& phase) -> Candidate {
    return run.assess(reducer.reduce(ReductionRequest{order, {}}), phase);
  };
  auto finish = [&](Termination t, std::string message) {
    return run.finish(t, std::move(message));
  };

  return strategy_support::guarded(run, [&]() -> StrategyResult {
    // Phase 1: grow until a verified pass.
    Index order = std::min(m_options.initial_order, max_order);
    Index last_fail = 0;  // largest order known to fail
    Index previous_delivered = -1;
    Stagnation stagnation(m_options.stagnation_window, m_options.stagnation_ratio);
    while (true) {
      if (run.iterations() >= m_options.max_iterations) {
        return finish(Termination::IterationLimit, "iteration budget " +
                                                       std::to_string(m_options.max_iterations) +
                                                       " used up before the tolerance was met");
      }
      auto next_order = [&](Index n) {
        Index next = std::max<Index>(
            n + step,
            static_cast<Index>(std::ceil(m_options.growth_factor * static_cast<double>(n))));
        next = ((next + step - 1) / step) * step;
        return std::min(next, max_order);
      };
      ReducerResult reduced = reducer.reduce(ReductionRequest{order, {}});
      const Index delivered = reduced.V.cols();
      if (delivered == previous_delivered) {
        // The reducer cannot deliver a larger model at this request (e.g. it adds modes in
        // complex-conjugate pairs, or deflated a direction): the same model again would only repeat
        // the last evaluation, so ask for more until the order budget is reached.
        if (order >= max_order) {
          if (m_options.max_order < reducer.max_order()) {
            return finish(Termination::MaxOrderReached,
                          "order budget " + std::to_string(max_order) + " reached (delivered " +
                              std::to_string(delivered) + "): " + run.shortfall());
          }
          return finish(Termination::ReducerExhausted,
                        "the reducer delivers at most order " + std::to_string(delivered) +
                            " (requested " + std::to_string(order) + "); " + run.shortfall());
        }
        order = next_order(order);
        continue;
      }
      const Candidate c = run.assess(std::move(reduced), "grow");
      if (run.stopped())
        return finish(Termination::Interrupted,
                      "stopped by request at order " + std::to_string(c.result.V.cols()));
      if (c.passed) break;
      last_fail = std::max(last_fail, delivered);
      previous_delivered = delivered;
      if (run.stagnated(stagnation)) {
        return finish(Termination::Stagnated,
                      "band error stagnated at " + sci(stagnation.last()) + " over the last " +
                          std::to_string(stagnation.window()) + " growth steps (order " +
                          std::to_string(delivered) + "); tolerance " + sci(ctx.tolerance));
      }
      if (delivered >= max_order) {
        if (reducer.max_order() <= m_options.max_order) {
          return finish(Termination::ReducerExhausted, "the reducer delivers at most order " +
                                                           std::to_string(delivered) + "; " +
                                                           run.shortfall());
        }
        return finish(Termination::MaxOrderReached,
                      "order budget " + std::to_string(max_order) + " reached: " + run.shortfall());
      }
      order = next_order(order);
    }

    std::string shrink_note;
    // Phase 2: bisect between the largest failing and the smallest passing order. The band error
    // of nested bases is not guaranteed monotone in the order, so this finds the smallest passing
    // order under the assumption that it is monotone between the two (documented).
    if (m_options.shrink) {
      Index lo = last_fail;                     // fails (or 0)
      Index hi = run.smallest_pass()->order();  // passes
      // Bisection on requested orders: a failing request raises lo to the request even when the
      // reducer delivered less (pairs, deflation), a passing one lowers hi to what was delivered;
      // each step moves one of them, so the loop ends.
      while (hi - lo > step && run.iterations() < m_options.max_iterations) {
        Index mid = lo + ((hi - lo) / (2 * step)) * step;
        if (mid <= lo) mid = lo + step;
        if (mid >= hi) break;
        const Candidate c = try_order(mid, "shrink");
        if (run.stopped()) break;
        const Index delivered = c.result.V.cols();
        if (c.passed && delivered < hi) {
          hi = delivered;
        } else {
          lo = mid;  // failed, or passed without being smaller than the best so far
        }
      }
      if (run.stopped() || hi - lo > step) shrink_note = " (search for a smaller order cut short)";
    }
    return finish(Termination::Converged, "band error " +
                                              sci(run.smallest_pass()->error.sup_relative) +
                                              " <= tolerance " + sci(ctx.tolerance) + " at order " +
                                              std::to_string(run.smallest_pass()->order()) +
                                              run.verified_phrase() + shrink_note);
  });
}

}  // namespace ecmor
