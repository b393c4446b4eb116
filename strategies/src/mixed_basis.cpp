#include "mixed_basis.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "ecmor/base/error.hpp"
#include "support.hpp"

namespace ecmor {

namespace {

constexpr const char* kStrategy = "mixed_basis";

using strategy_support::Candidate;
using strategy_support::sci;

using strategy_support::hz_of;

// The frequencies of the `count` largest local maxima of the relative error, largest first, no
// two within `separation` in |ln f|.
std::vector<double> error_peaks(const BandError& e, double separation, Index count) {
  std::vector<double> out;
  for (double f : largest_local_maxima_hz(e, static_cast<Index>(e.f_hz.size()))) {
    if (static_cast<Index>(out.size()) >= count) break;
    if (!(f > 0.0)) continue;
    if (std::none_of(out.begin(), out.end(),
                     [&](double g) { return std::abs(std::log(f / g)) <= separation; }))
      out.push_back(f);
  }
  return out;
}

using End = std::optional<StrategyResult>;

// The model of a modal block of `block` columns and `points` (the block alone without points: a
// modal block needs points, ReductionRequest).
ReductionRequest request(const std::vector<ExpansionPoint>& points, Index block) {
  if (points.empty()) return ReductionRequest{block, {}};
  return ReductionRequest{0, points, block};
}

class Run {
 public:
  Run(const MixedBasisOptions& o, strategy_support::StrategyRun& run)
      : m_o(o),
        m_run(run),
        m_reducer(*run.context().reducer),
        m_max_order(std::min(o.max_order, m_reducer.max_order())),
        m_separation(o.min_separation * std::log(run.context().estimator->band().f_max_hz /
                                                 run.context().estimator->band().f_min_hz)),
        m_stagnation(o.stagnation_window, o.stagnation_ratio) {}

  StrategyResult go() {
    if (End end = block_phase()) return std::move(*end);
    while (true) {
      if (End end = point_step()) return std::move(*end);
    }
  }

 private:
  double tolerance() { return m_run.context().tolerance; }

  StrategyResult converged() {
    const Candidate& best = *m_run.smallest_pass();
    return m_run.finish(Termination::Converged,
                        "band error " + sci(best.error.sup_relative) + " <= tolerance " +
                            sci(tolerance()) + " at order " + std::to_string(best.order()) + " (" +
                            std::to_string(m_block) + "-column modal block, " +
                            std::to_string(best.result.points.size()) + " points)" +
                            m_run.verified_phrase());
  }

  End stopped() {
    if (!m_run.stopped()) return std::nullopt;
    return m_run.finish(Termination::Interrupted,
                        "stopped by request at order " + std::to_string(m_current.order()) +
                            "; best band error " + sci(m_run.best_error()));
  }

  End iteration_budget() {
    if (m_run.iterations() < m_o.max_iterations) return std::nullopt;
    return m_run.finish(Termination::IterationLimit,
                        "iteration budget max_iterations = " + std::to_string(m_o.max_iterations) +
                            " used up at order " + std::to_string(m_current.order()) + "; " +
                            m_run.shortfall());
  }

  // Block steps of block_step columns until `patience` steps in a row gain less than min_gain.
  End block_phase() {
    double best = std::numeric_limits<double>::infinity();
    Index strikes = 0;
    std::optional<Candidate> best_c;
    Index steps = 0, best_step = 0;
    const Index cap = std::max<Index>(
        1, static_cast<Index>(m_o.block_fraction * static_cast<double>(m_max_order)));
    for (Index order = std::min(m_o.block_step, cap);; order += m_o.block_step) {
      order = std::min(order, cap);
      if (End end = iteration_budget()) return end;
      ReducerResult r = m_reducer.reduce(ReductionRequest{order, {}});
      const Index delivered = r.V.cols();
      const bool new_columns = !best_c || delivered > m_current.order();
      m_current = m_run.assess(std::move(r), "block");
      if (m_current.passed) return converged();
      if (End end = stopped()) return end;
      const double e = m_current.error.sup_relative;
      strikes = e < (1.0 - m_o.min_gain) * best ? 0 : strikes + 1;
      ++steps;
      if (e < best || !best_c) {
        best_step = steps;
        best = e;
        best_c = m_current;
        m_block = delivered;
      }
      if (!new_columns || delivered < order || strikes >= m_o.patience || order >= cap) break;
    }
    m_current = std::move(*best_c);
    // Modes that never helped: the first block was the best, and no better than no model.
    if (!(best < 1.0) && best_step == 1 && steps > 1) return without_block();
    if (m_block >= m_max_order) {
      return m_run.finish(Termination::MaxOrderReached,
                          "order budget max_order = " + std::to_string(m_max_order) +
                              " reached by the modal block alone; " + m_run.shortfall());
    }
    return std::nullopt;
  }

  // More modes only made it worse, and the smallest block did no better than no model at all
  // (band error >= 1: modes far from what the band needs, e.g. a model whose response is not
  // modal): the points start from an empty block, with one point at the band centre, as
  // greedy_points does. (A block whose error falls, even from above 1, is kept: beam.)
  End without_block() {
    m_block = 0;
    m_points = {point_at_hz(strategy_support::band_centre_hz(m_run.context().estimator->band()),
                            m_o.moments)};
    m_current = m_run.assess(m_reducer.reduce(request(m_points, 0)), "initial");
    if (m_current.passed) return converged();
    return stopped();
  }

  // One point step: the best of the candidate peaks, or more modes when none lowers the error.
  End point_step() {
    if (End end = iteration_budget()) return end;
    if (m_run.stagnated(m_stagnation)) {
      return m_run.finish(Termination::Stagnated,
                          "band error stagnated at " + sci(m_stagnation.last()) +
                              " over the last " + std::to_string(m_stagnation.window()) +
                              " point steps (was " + sci(m_stagnation.before()) + "; order " +
                              std::to_string(m_current.order()) + "); tolerance " +
                              sci(tolerance()));
    }
    if (m_run.escalated()) {
      // The error curve the next points come from, now against the full model.
      m_current = m_run.assess(m_current.result, "escalate");
      if (m_current.passed) return converged();
      if (End end = stopped()) return end;
    }
    const std::vector<double> peaks = error_peaks(m_current.error, m_separation, m_o.candidates);
    std::optional<Candidate> best;
    std::vector<ExpansionPoint> best_points;
    bool over_budget = false;
    for (double f : peaks) {
      if (End end = iteration_budget()) return end;
      std::vector<ExpansionPoint> points =
          strategy_support::step_toward(m_points, f, m_separation, m_o.moments).points;
      ReducerResult r = m_reducer.reduce(request(points, m_block));
      if (r.V.cols() <= m_current.order()) continue;  // deflated: nothing new there
      if (r.V.cols() > m_max_order) {
        over_budget = true;
        continue;
      }
      Candidate t = m_run.assess(std::move(r), "try_point", {{"added_point_hz", f}});
      if (t.passed) return converged();
      if (End end = stopped()) return end;
      if (!best || t.error.sup_relative < best->error.sup_relative) {
        best = std::move(t);
        best_points = std::move(points);
      }
    }
    if (best && best->error.sup_relative < m_current.error.sup_relative) {
      m_points = std::move(best_points);
      m_current = std::move(*best);
      return std::nullopt;
    }
    return add_modes(over_budget);
  }

  // No point lowered the error: fallback_modes more modes in the block, kept whatever they give.
  End add_modes(bool points_over_budget) {
    const Index block = m_block + m_o.fallback_modes;
    const std::string why = points_over_budget ? "every candidate point exceeds max_order"
                                               : "no candidate point lowers the error";
    ReducerResult r = m_reducer.reduce(request(m_points, block));
    if (r.V.cols() > m_max_order) {
      return m_run.finish(Termination::MaxOrderReached,
                          "order budget max_order = " + std::to_string(m_max_order) + " reached (" +
                              why + ", and " + std::to_string(m_o.fallback_modes) +
                              " more modes give order " + std::to_string(r.V.cols()) + "); " +
                              m_run.shortfall());
    }
    if (r.V.cols() <= m_current.order()) {
      return m_run.finish(Termination::ReducerExhausted,
                          "the reducer has no more modes (" + why + "; order " +
                              std::to_string(m_current.order()) + "); " + m_run.shortfall());
    }
    m_block = block;
    m_current = m_run.assess(std::move(r), "add_modes");
    if (m_current.passed) return converged();
    return stopped();
  }

  const MixedBasisOptions& m_o;
  strategy_support::StrategyRun& m_run;
  Reducer& m_reducer;
  const Index m_max_order;
  const double m_separation;  // frequencies closer than this in |ln f| are one point
  strategy_support::Stagnation m_stagnation;
  Index m_block = 0;  // columns of the modal block requested (ReductionRequest::modes)
  std::vector<ExpansionPoint> m_points;
  Candidate m_current;  // the model the next step starts from
};

}  // namespace

const OptionSpecs<MixedBasisOptions>& MixedBasisOptions::specs() {
  using O = MixedBasisOptions;
  static const OptionSpecs<O> specs({
      option("block_step", &O::block_step, "columns added per step of the modal block phase")
          .range(Range::at_least(1)),
      option("min_gain", &O::min_gain,
             "a block step gains when it lowers the best band error by at least this fraction")
          .range(Range::closed_open(0, 1)),
      option("patience", &O::patience, "block steps in a row without gain that end the block phase")
          .range(Range::at_least(1)),
      option("block_fraction", &O::block_fraction,
             "the block phase ends at this fraction of max_order, leaving room for points")
          .range(Range::open_closed(0, 1)),
      option("candidates", &O::candidates,
             "largest local maxima of the band error tried as the next point (1: plain greedy)")
          .range(Range::at_least(1)),
      option("moments", &O::moments, "moments at each new point").range(Range::at_least(1)),
      option("min_separation", &O::min_separation,
             "fraction of the band's width in ln f within which a peak counts as on an existing "
             "point (then one moment more there)")
          .range(Range::closed_open(0, 1)),
      option("fallback_modes", &O::fallback_modes,
             "modes added to the block when no candidate point lowers the error")
          .range(Range::at_least(1)),
      option("max_order", &O::max_order,
             "reduced order budget (the reducer's maximum also applies)")
          .range(Range::at_least(1)),
      option("max_iterations", &O::max_iterations, "history-row budget; every tried point is a row")
          .range(Range::at_least(1)),
      strategy_support::stagnation_window_option(
          &O::stagnation_window,
          "point steps over which the best error must fall; 0: never stagnates"),
      strategy_support::stagnation_ratio_option(
          &O::stagnation_ratio,
          "stagnated when best error >= stagnation_ratio x its value stagnation_window point "
          "steps earlier"),
  });
  return specs;
}

StrategyResult MixedBasis::run(StrategyContext& ctx) {
  if (ctx.estimator == nullptr || ctx.reducer == nullptr) {
    throw ConfigError(std::string("strategy '") + kStrategy + "': no reducer or estimator given");
  }
  if (!ctx.reducer_info.modal_block) {
    const std::string name =
        ctx.reducer_info.name.empty() ? "this reducer" : "'" + ctx.reducer_info.name + "'";
    throw ConfigError(std::string("strategy '") + kStrategy +
                      "' unites a modal block with expansion points, but reducer " + name +
                      " does not compute modes; use reducer modal");
  }
  strategy_support::StrategyRun run(ctx);
  return strategy_support::guarded(run,
                                   [&]() -> StrategyResult { return Run(m_options, run).go(); });
}

}  // namespace ecmor
