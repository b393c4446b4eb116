#include "support.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <sstream>

#include "ecmor/base/error.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace ecmor::strategy_support {

std::string sci(double v) {
  std::ostringstream os;
  os.precision(3);
  os << std::scientific << v;
  return os.str();
}

ReducerResult reduce_at(Reducer& reducer, const std::vector<ExpansionPoint>& points) {
  ReducerResult r = reducer.reduce(ReductionRequest{0, points});
  if (r.points.empty()) r.points = points;
  return r;
}

ReducedStability judge_stability(const StrategyContext& context, const ReducedModel& model,
                                 Index unstable) {
  static const RigidBodyModes kNoRigidModes{};
  return reduced_model_stability(model, context.full_rigid ? *context.full_rigid : kNoRigidModes,
                                 unstable);
}

StrategyRun::StrategyRun(StrategyContext& context)
    : m_ctx(context), m_last(std::chrono::steady_clock::now()) {}

void StrategyRun::record(const std::string& phase, const ReducerResult& r, const BandError& e,
                         bool meets, bool stable, const std::map<std::string, double>& extra) {
  IterationRecord rec;
  rec.iteration = ++m_iteration;
  rec.phase = phase;
  rec.order = r.V.cols();
  rec.points = r.points;
  rec.band_error = e.sup_relative;
  rec.f_peak_hz = e.f_peak_hz;
  rec.meets_tolerance = meets;
  rec.stable = stable;
  const auto now = std::chrono::steady_clock::now();
  rec.seconds = std::chrono::duration<double>(now - m_ctx.start).count();
  rec.step_seconds = std::chrono::duration<double>(now - m_last).count();
  m_last = now;
  if (m_ctx.counters) rec.counters = m_ctx.counters();
  if (m_ctx.full_evaluations) rec.full_evaluations = m_ctx.full_evaluations();
  rec.sampling = e.sampling();
  rec.note = r.note;
  if (!stable) rec.note += rec.note.empty() ? "UNSTABLE reduced model" : "; UNSTABLE reduced model";
  rec.diagnostics = r.diagnostics;
  if (e.reference_order > 0) {
    // Estimate mode: what was checked against the full model, and how well the estimate did.
    rec.diagnostics["checked_samples"] = static_cast<double>(e.checked_samples);
    rec.diagnostics["new_full_solves"] = static_cast<double>(e.new_full_solves);
    rec.diagnostics["reference_order"] = static_cast<double>(e.reference_order);
    rec.diagnostics["estimate_sup"] = e.estimate_sup;
    rec.diagnostics["reference_floor"] = e.reference_floor;
    if (e.effectivity_count > 0) {
      rec.diagnostics["effectivity_min"] = e.effectivity_min;
      rec.diagnostics["effectivity_median"] = e.effectivity_median;
      rec.diagnostics["effectivity_max"] = e.effectivity_max;
    }
  }
  for (const auto& [k, v] : extra) rec.diagnostics[k] = v;
  m_out.history.push_back(rec);
  if (m_ctx.on_iteration && !m_ctx.on_iteration(rec)) m_stop = true;
}

Candidate StrategyRun::assess(ReducerResult result, const std::string& phase,
                              const std::map<std::string, double>& extra, bool verify) {
  Candidate c;
  c.result = std::move(result);
  // Estimate mode: the reference model takes the candidate's bases, so that it is at least as
  // rich as the model it judges (no-op in dense mode).
  m_ctx.estimator->offer_basis(c.result.V);
  const Matrix& V = c.result.V;
  const Matrix& W = c.result.W;
  if (W.size() > 0 && !(W.rows() == V.rows() && W.cols() == V.cols() && W == V))
    m_ctx.estimator->offer_basis(c.result.W);
  c.error = m_ctx.estimator->evaluate(c.result.model);
  // The estimator computes the poles for its pole samples; its count decides when it is 0.
  c.stability = judge_stability(m_ctx, c.result.model, c.error.unstable_poles);
  c.stable = c.stability.accepted();
  const bool meets = c.error.within(m_ctx.tolerance);
  record(phase, c.result, c.error, meets, c.stable, extra);
  c.pending = meets && c.stable;
  if (verify && c.pending && !stopped()) {
    confirm(c, extra);
    return c;
  }
  // A model passes only after the independent re-check; one left unverified because the run was
  // stopped right after its estimate does not count.
  track(c);
  return c;
}

void StrategyRun::confirm(Candidate& c, const std::map<std::string, double>& extra) {
  if (!c.pending || stopped()) return;
  c.pending = false;
  // "Converged" must hold on an independent check: a denser grid that shares no frequency with
  // the estimator's (dense mode), or full solves where the estimate peaks, at random and at the
  // band edges (estimate mode).
  BandError check = m_ctx.estimator->verify(c.result.model, m_ctx.verify_factor);
  c.passed = check.within(m_ctx.tolerance);
  record("verify", c.result, check, c.passed, c.stable, extra);
  // Report the larger of the two values of the supremum; in estimate mode the check's, which
  // is measured against the full model at every frequency it solved (never an estimate).
  if (check.sup_relative > c.error.sup_relative || m_ctx.estimator->mode() == ErrorVerify::Estimate)
    c.error = std::move(check);
  track(c);
}

void StrategyRun::track(const Candidate& c) {
  // An unstable model is kept as "most accurate" only when no stable one has been seen.
  const bool better = m_rank_afresh || !m_most_accurate || (c.stable && !m_most_accurate->stable) ||
                      (c.stable == m_most_accurate->stable &&
                       c.error.sup_relative < m_most_accurate->error.sup_relative);
  if (better) {
    m_most_accurate = c;
    m_rank_afresh = false;
  }
  if (std::isfinite(c.error.reference_floor))
    m_largest_floor = std::max(m_largest_floor, c.error.reference_floor);
  if (c.passed && (!m_smallest_pass || c.order() < m_smallest_pass->order())) m_smallest_pass = c;
}

void StrategyRun::record_trial(const std::string& phase, const ReducerResult& result,
                               const BandError& error, const std::map<std::string, double>& extra) {
  record(phase, result, error, error.sup_relative <= m_ctx.tolerance,
         judge_stability(m_ctx, result.model, error.unstable_poles).accepted(), extra);
}

double StrategyRun::best_error() const {
  return m_most_accurate ? m_most_accurate->error.sup_relative
                         : std::numeric_limits<double>::infinity();
}

bool StrategyRun::stagnated(Stagnation& s) {
  if (!s.record(best_error())) return false;
  const ErrorVerify mode = m_ctx.estimator->mode();
  if (!m_ctx.estimator->escalate("the band error stagnated at " + sci(s.last()) + " over " +
                                 std::to_string(s.window()) + " steps"))
    return true;
  // Estimated errors do not rank candidates against dense ones: the next candidate assessed
  // replaces the most accurate one, which is kept until then (a run that ends first reports it).
  if (m_ctx.estimator->mode() != mode) m_rank_afresh = true;
  s.reset();
  m_escalated = true;
  return false;
}

std::string StrategyRun::shortfall() const {
  const double e = best_error();
  if (m_most_accurate && !m_most_accurate->stable && e <= m_ctx.tolerance) {
    // Without rigid-body modes in the full model "as stable as the full model" means
    // asymptotically stable.
    const bool rigid = m_ctx.full_rigid != nullptr && m_ctx.full_rigid->count > 0;
    // Fewer rigid-body modes than the full model is a shortcoming of the basis, not of the full
    // model: say what would keep them all.
    const bool subset = m_most_accurate->stability.verdict == ReducedVerdict::RigidSubset;
    return "band error " + sci(e) + " <= tolerance " + sci(m_ctx.tolerance) +
           ", but the model is " +
           (rigid ? "not as stable as the full model (" : "not asymptotically stable (") +
           m_most_accurate->stability.reason +
           (subset ? "; a basis holding the null space of K keeps every rigid-body mode: modal "
                     "and krylov put it first)"
                   : "; an undamped or unstable full model has no stable approximation)");
  }
  return "band error " + sci(e) + " > tolerance " + sci(m_ctx.tolerance);
}

StrategyResult StrategyRun::finish(Termination t, std::string message) {
  m_out.termination = t;
  m_out.message = std::move(message);
  // A run that misses a tolerance below what the evaluation resolves says so: its best error sits
  // at the reference floor (the rounding of the reference model where the full model was solved).
  // "At" means within kFloorBand of it: the floor is the largest rounding seen at up to 8 solved
  // frequencies, while the error peaks elsewhere (at a resonance), where the rounding differs by
  // a few times. The floor is the largest measured over the run's candidates: it is re-measured
  // whenever the reference model grows, and the most accurate candidate's own value may be one of
  // its low readings. Measured on the clamped solid of test_free_body, same binary: with OpenBLAS's
  // AVX-512 kernels best error 1.34e-8, the most accurate candidate's floor 1.36e-10, the largest
  // 1.54e-8 (0.9x); with its Haswell kernels 1.03e-8, 7.9e-9 and 7.9e-9 (1.3x).
  constexpr double kFloorBand = 10.0;
  if (!m_smallest_pass && m_most_accurate) {
    const double floor = m_largest_floor;
    if (floor > 0.0 && std::isfinite(floor) && best_error() <= kFloorBand * floor &&
        m_ctx.tolerance < floor) {
      m_out.message += "; the band error " + sci(best_error()) + " is at the reference floor " +
                       sci(floor) +
                       " (the rounding of the error's evaluation on this model): a tolerance "
                       "below it cannot be certified";
    }
  }
  const std::optional<Candidate>& chosen = m_smallest_pass ? m_smallest_pass : m_most_accurate;
  if (chosen) {
    m_out.best = chosen->result;
    m_out.best_error = chosen->error;
  }
  return m_out;
}

std::string StrategyRun::failure(const std::string& what, bool foreign) const {
  const std::string& name = m_ctx.reducer_info.name;
  const bool named = name.empty() || what.rfind(name + ":", 0) == 0 ||
                     what.rfind(name + " ", 0) == 0 ||
                     what.find("reducer '" + name + "'") != std::string::npos;
  return fmt::format("reduction failed in iteration {}{}{}: {}", m_iteration + 1,
                     named ? std::string() : " (" + name + ")",
                     foreign ? " (unexpected exception)" : "", what);
}

std::string StrategyRun::interruption(const std::string& what) const {
  const std::string& name = m_ctx.reducer_info.name;
  return fmt::format("stopped during iteration {}{}: {}{}", m_iteration + 1,
                     name.empty() ? std::string() : " (" + name + ")", what,
                     m_smallest_pass ? std::string() : "; " + shortfall());
}

std::string StrategyRun::verified_phrase() const {
  if (m_ctx.estimator != nullptr && m_ctx.estimator->mode() == ErrorVerify::Estimate)
    return " (checked by full solves where the estimate peaks, at random and at the band edges)";
  return " (verified on a " + std::to_string(m_ctx.verify_factor) + "x denser independent grid)";
}

double band_centre_hz(const Band& band) { return std::sqrt(band.f_min_hz * band.f_max_hz); }

double hz_of(const ExpansionPoint& p) { return p.s.imag() / kTwoPi; }

PointStep step_toward(const std::vector<ExpansionPoint>& points, double f_hz, double separation,
                      Index moments) {
  std::size_t nearest = 0;
  double distance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double d = std::abs(std::log(f_hz / hz_of(points[i])));
    if (d < distance) {
      distance = d;
      nearest = i;
    }
  }
  PointStep step{points};
  if (distance <= separation) {
    ExpansionPoint& p = step.points[nearest];
    p.moments += 1;
    step.at_hz = hz_of(p);
    step.moments_there = p.moments;
  } else {
    step.points.push_back(point_at_hz(f_hz, moments));
    step.adds_point = true;
    step.at_hz = f_hz;
    step.moments_there = moments;
  }
  return step;
}

void require_point_reducer(const StrategyContext& context, const std::string& strategy) {
  if (!context.reducer_info.uses_expansion_points) {
    const std::string name =
        context.reducer_info.name.empty() ? "this reducer" : "'" + context.reducer_info.name + "'";
    throw ConfigError("strategy '" + strategy + "' moves expansion points, but reducer " + name +
                      " does not use expansion points; use strategy grow_order with it");
  }
}

}  // namespace ecmor::strategy_support
