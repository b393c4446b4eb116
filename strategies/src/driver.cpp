#include "ecmor/strategies/driver.hpp"

#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <optional>
#include <nlohmann/json.hpp>

#include "ecmor/atomic_file.hpp"
#include "ecmor/error.hpp"
#include "ecmor/interrupt.hpp"
#include "ecmor/frequency_response.hpp"
#include "ecmor/hinf_norm.hpp"
#include "ecmor/lyapunov.hpp"
#include "ecmor/matrix_market.hpp"
#include "ecmor/model_io.hpp"
#include "ecmor/parallel.hpp"
#include "ecmor/recent_factorizations.hpp"
#include "ecmor/version.hpp"

namespace ecmor {

int RunSummary::exit_code() const {
  if (termination == Termination::Converged) return 0;
  return has_model ? 2 : 1;
}

double peak_memory_mb() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

namespace {

nlohmann::json counters_json(const SolverCounters& c) {
  nlohmann::json j = nlohmann::json::object();
  for_each_counter(c, [&](const char* name, auto value) { j[name] = value; });
  return j;
}

// The verified error curve, for plots and for users who want to look rather than read.
void write_error_curve(const std::filesystem::path& path, const BandError& e) {
  write_file_atomically(path, [&](std::ostream& os) {
    // exact: 1 where the full model was solved, 0 where its response is the estimator's
    // reference model's (estimate mode).
    os << "f_hz,relative_spectral,relative_frobenius,absolute_spectral,reference_spectral,exact\n";
    os << std::setprecision(10);
    for (std::size_t k = 0; k < e.f_hz.size(); ++k) {
      os << e.f_hz[k] << ',' << e.relative_spectral[k] << ',' << e.relative_frobenius[k] << ','
         << e.absolute[k] << ',' << e.reference[k] << ','
         << (k < e.exact.size() ? static_cast<int>(e.exact[k]) : 1) << '\n';
    }
  });
}

struct HinfReport {
  double value = 0.0;
  double f_peak_hz = -1.0;  ///< < 0: not known
  bool certified = false;
  std::string scope, method;
};

// The error system's H-infinity norm, stating how it was obtained: exact (certified level-set
// bracket over all frequencies) for small full models, else the sampled band supremum.
HinfReport hinf_of_error(const Model& full, const ReducedModel& reduced, const BandError& verified,
                         Index dense_states) {
  HinfReport r;
  const Index states = std::holds_alternative<SecondOrderModel>(full) ? 2 * size_of(full)
                                                                        : size_of(full);
  std::string why_sampled = fmt::format("the full model has {} first-order states (dense "
                                        "level-set method up to error.hinf_dense_states = {})",
                                        states, dense_states);
  if (states <= dense_states) {
    try {
      const HinfResult h = hinf_error_norm(densify(full), reduced);
      r.value = h.value;
      r.f_peak_hz = h.f_peak_hz;
      r.certified = h.converged;
      r.scope = "all frequencies";
      r.method = h.method + ", dense; " + h.message;
      return r;
    } catch (const Error& e) {
      why_sampled = std::string("the dense level-set method refused: ") + e.what();
    }
  }
  r.value = verified.hinf_absolute;
  r.scope = "band";
  r.method = "sup of sigma_max(H - Hr) on the independent re-check grid (sampled: a lower bound "
             "of the band H-infinity norm); " +
             why_sampled;
  return r;
}

}  // namespace

namespace {

/// Wraps the configured reducer to measure the reduction proper: wall time and solver work inside
/// setup() and reduce(), apart from the error estimation around them. setup() counts: the low-rank
/// ADI of balanced truncation factorises there (rail_5177_bt: 123 Cholesky factorisations that the
/// summary once left out of the reducer's count).
class TimedReducer final : public Reducer {
 public:
  TimedReducer(Reducer& inner, const RecentFactorizations& solver)
      : m_inner(inner), m_solver(solver) {}
  void setup(const ReductionContext& context) override {
    const Account account{*this};
    m_inner.setup(context);
  }
  ReducerResult reduce(const ReductionRequest& request) override {
    const Account account{*this};
    ++m_calls;
    return m_inner.reduce(request);
  }
  Index max_order() const override { return m_inner.max_order(); }
  Index order_step() const override { return m_inner.order_step(); }

  double seconds() const { return m_seconds; }
  Index calls() const { return m_calls; }
  const SolverCounters& counters() const { return m_counters; }
  /// Factorisations the reducer asked for and got from the error control's full solves.
  std::int64_t reuses() const { return m_reuses; }

 private:
  // Counts the time and solver work of one call, also when it throws: the work was done.
  struct Account {
    explicit Account(TimedReducer& reducer)
        : self(reducer),
          start(std::chrono::steady_clock::now()),
          before(reducer.m_solver.counters()),
          reuses_before(reducer.m_solver.reuses()) {}
    ~Account() {
      self.m_seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      self.m_counters += self.m_solver.counters() - before;
      self.m_reuses += self.m_solver.reuses() - reuses_before;
    }
    Account(const Account&) = delete;
    Account& operator=(const Account&) = delete;
    TimedReducer& self;
    std::chrono::steady_clock::time_point start;
    SolverCounters before;
    std::int64_t reuses_before;
  };

  Reducer& m_inner;
  const RecentFactorizations& m_solver;
  double m_seconds = 0.0;
  Index m_calls = 0;
  SolverCounters m_counters;
  std::int64_t m_reuses = 0;
};

}  // namespace

namespace {

/// A member ready to run: created (and its parameters validated) before any heavy work.
struct PreparedMember {
  PortfolioMember member;
  std::shared_ptr<Reducer> reducer;
  std::unique_ptr<Strategy> strategy;
  ReducerInfo info;
};

std::vector<PreparedMember> prepare_members(const RunConfig& config, Registry& registry) {
  std::vector<PortfolioMember> members = config.portfolio;
  const bool portfolio = !members.empty();
  if (!portfolio) {
    members.push_back(PortfolioMember{config.reducer_name, config.reducer_params,
                                      config.strategy_name, config.strategy_params});
  }
  std::vector<PreparedMember> out;
  for (std::size_t k = 0; k < members.size(); ++k) {
    PreparedMember p;
    p.member = members[k];
    p.reducer = registry.create(p.member.reducer_name, p.member.reducer_params);
    p.strategy = make_strategy(p.member.strategy_name, p.member.strategy_params);
    for (const Registry::Entry& e : registry.entries()) {
      if (e.info.name == p.member.reducer_name) p.info = e.info;
    }
    if (p.strategy->moves_points() && !p.info.uses_expansion_points) {
      const std::string where =
          portfolio ? fmt::format(" (strategy.members[{}])", k + 1) : std::string();
      throw ConfigError(config.source.string() + ": strategy '" + p.member.strategy_name +
                        "' moves expansion points, but reducer '" + p.member.reducer_name +
                        "' does not use them; use strategy grow_order with it" + where);
    }
    out.push_back(std::move(p));
  }
  return out;
}

/// Index of the reported attempt: the smallest order meeting the target (ties: less time), else
/// the smallest band error among members with a model; -1 when no member has one.
int select_winner(const std::vector<PortfolioAttempt>& attempts) {
  int best = -1;
  for (std::size_t k = 0; k < attempts.size(); ++k) {
    const PortfolioAttempt& a = attempts[k];
    if (!a.has_model) continue;
    if (best < 0) {
      best = static_cast<int>(k);
      continue;
    }
    const PortfolioAttempt& b = attempts[static_cast<std::size_t>(best)];
    // Ties on the order go to the faster member; under MPI to the first one, since the ranks'
    // clocks differ and every rank must report the same winner.
    const bool faster = process_count() == 1 && a.seconds < b.seconds;
    const bool better = a.met != b.met ? a.met
                        : a.met ? (a.order != b.order ? a.order < b.order : faster)
                                : a.band_error < b.band_error;
    if (better) best = static_cast<int>(k);
  }
  return best;
}

}  // namespace

std::vector<PortfolioMember> default_portfolio(const Model& model, const Registry& registry) {
  const bool second_order = kind_of(model) == ModelKind::SecondOrder;
  auto symmetric = [](const SparseMatrix& A) { return relative_asymmetry(A) <= 1e-14; };
  bool modal_suits = second_order;
  if (const auto* d = std::get_if<DescriptorModel>(&model))
    modal_suits = symmetric(d->E) && symmetric(d->A);
  struct Candidate {
    const char* reducer;
    const char* strategy;
    bool suits;
  };
  const Candidate candidates[] = {{"krylov", "greedy_points", true},
                                  {"balanced", "grow_order", true},
                                  {"modal", "grow_order", modal_suits}};
  std::vector<PortfolioMember> members;
  for (const Candidate& c : candidates) {
    const auto& entries = registry.entries();
    const auto it = std::find_if(entries.begin(), entries.end(),
                                 [&](const Registry::Entry& e) { return e.info.name == c.reducer; });
    if (it == entries.end() || !c.suits) continue;
    if (second_order ? !it->info.second_order : !it->info.descriptor) continue;
    PortfolioMember m;
    m.reducer_name = c.reducer;
    m.reducer_params = ParameterMap(std::string("reducer '") + c.reducer + "'");
    m.strategy_name = c.strategy;
    m.strategy_params = ParameterMap(std::string("strategy '") + c.strategy + "'");
    if (m.strategy_name == "greedy_points") m.strategy_params.set("moments", 2LL);
    members.push_back(std::move(m));
  }
  if (members.empty()) {
    throw ConfigError(
        "strategy 'portfolio' without members: none of the bundled reducers krylov, balanced, "
        "modal is loaded for this model; give strategy.members");
  }
  return members;
}

RunSummary run_reduction(const RunConfig& given, Registry& registry, RunObserver* observer) {
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };

  const Model model = load_model(given.model);
  RunConfig config = given;
  if (config.is_portfolio() && config.portfolio.empty())
    config.portfolio = default_portfolio(model, registry);
  const double load_seconds = elapsed();
  if (observer) observer->on_model_loaded(config, model, load_seconds);

  // Bad configuration (of every member) is found before any heavy work.
  std::vector<PreparedMember> members = prepare_members(config, registry);
  const bool portfolio = !config.portfolio.empty();

  std::unique_ptr<ShiftedSolver> backend = make_shifted_solver(model, config.solver);
  // Shared by the error control and the reducers: the most recent factorisation serves the
  // reducer when it asks for P(s) where the error control has just solved (a greedy point).
  const auto solver = std::make_unique<RecentFactorizations>(*backend, 1);
  ResponseCache cache(model, *solver, config.threads);
  if (observer) cache.set_progress([observer](const SweepProgress& p) { observer->on_sweep(p); });
  BandErrorOptions error_options = config.error;
  error_options.norm = config.norm;

  // The time limit acts as an interrupt: strategies poll stop_requested() and finish with the
  // best model so far; the message then says which of the two ended the run.
  bool out_of_time = false;
  auto time_is_up = [&] {
    if (config.time_limit_s > 0.0 && elapsed() > config.time_limit_s) out_of_time = true;
    return out_of_time;
  };
  bool user_stop = false;
  // Collective under MPI: a time limit or a signal seen on one rank stops every rank at the same
  // point (the solves are collective operations, entered by all ranks in the same order).
  auto stop_requested = [&] {
    if (observer != nullptr && observer->stop_requested()) user_stop = true;
    const bool local = time_is_up() || user_stop;
    if (any_process(local) && !local) user_stop = true;
    return out_of_time || user_stop;
  };

  // The estimator samples the full model before any reduction (dense mode: its whole grid;
  // estimate mode: the reference model's seeds): a signal ends that sweep too. The time limit
  // does not: it bounds the search for a model, and without this sampling there is none.
  auto signalled = [&] {
    if (observer != nullptr && observer->stop_requested()) user_stop = true;
    if (any_process(user_stop)) user_stop = true;
    return user_stop;
  };
  std::unique_ptr<BandErrorEstimator> estimator_holder;
  try {
    InterruptScope interrupt(signalled);
    estimator_holder = std::make_unique<BandErrorEstimator>(cache, config.band, error_options);
  } catch (const Interrupted& e) {
    RunSummary summary;
    summary.termination = Termination::Interrupted;
    summary.message = fmt::format(
        "stopped by request before the first reduction, while sampling the full model ({} "
        "frequencies done): {}",
        cache.size(), e.what());
    summary.tolerance = config.tolerance;
    summary.output_dir = config.output_dir;
    summary.reducer = config.reducer_name;
    summary.strategy = config.strategy_name;
    summary.full_order = size_of(model);
    summary.counters = solver->counters();
    summary.full_evaluations = cache.size();
    summary.full_response_seconds = cache.seconds();
    summary.load_seconds = load_seconds;
    summary.seconds = elapsed();
    summary.peak_memory_mb = peak_memory_mb();
    if (observer) observer->on_finished(summary);
    return summary;
  }
  BandErrorEstimator& estimator = *estimator_holder;
  // The full model's rigid-body modes (the null space of K), before any reduction: every reduced
  // model is judged against them (a free body's reduced model keeps its poles at s = 0).
  const double rigid_start = elapsed();
  const RigidBodyModes rigid = rigid_body_modes(model, *solver);
  const double rigid_seconds = elapsed() - rigid_start;
  // Created at the first record: a reducer that refuses the model in setup() leaves no output
  // directory behind (bad input is reported before anything is written).
  std::optional<HistoryWriter> history;
  Index recorded = 0;
  // Under MPI (PETSc backend) every rank runs this driver; rank 0 alone writes the outputs.
  const bool writer = process_rank() == 0;
  auto record = [&](const IterationRecord& r) {
    // A write error is rank 0's alone; made collective, so that every rank leaves the strategy
    // at the same record instead of the others waiting in the next collective solve.
    std::string failure;
    if (writer) {
      try {
        if (!history) history.emplace(config.output_dir);
        history->append(r);
      } catch (const Error& e) {
        failure = e.what();
      }
    }
    ++recorded;
    if (any_process(!failure.empty()))
      throw IoError(failure.empty() ? std::string("rank 0 could not write the history") : failure);
  };

  std::vector<PortfolioAttempt> attempts;
  std::vector<StrategyResult> results;
  double reducer_seconds = 0.0;
  Index reducer_calls = 0;
  SolverCounters reducer_counters;
  std::int64_t reducer_reuses = 0;
  Index smallest_met_order = 0;  // of the members so far; 0: none met yet
  for (std::size_t k = 0; k < members.size(); ++k) {
    PreparedMember& m = members[k];
    PortfolioAttempt attempt;
    attempt.reducer = m.member.reducer_name;
    attempt.strategy = m.member.strategy_name;
    if (k > 0 && stop_requested()) {
      attempt.termination = "not_run";
      attempt.message = out_of_time ? "the time limit was used up before it started"
                                    : "interrupted before it started";
      attempts.push_back(attempt);
      results.emplace_back();
      continue;
    }
    if (observer && portfolio) observer->on_member_started(k, members.size(), attempt.label());
    const double member_start = elapsed();
    TimedReducer timed(*m.reducer, *solver);
    const Index offset = recorded;
    bool pruned = false;
    StrategyContext ctx;
    ctx.reducer = &timed;
    ctx.reducer_info = m.info;
    ctx.estimator = &estimator;
    ctx.tolerance = config.tolerance;
    ctx.full_rigid = &rigid;
    ctx.verify_factor = config.verify_factor;
    ctx.start = start;
    ctx.counters = [&] { return solver->counters(); };
    ctx.full_evaluations = [&] { return cache.size(); };
    ctx.stop_requested = stop_requested;
    ctx.on_iteration = [&](const IterationRecord& rec) {
      IterationRecord r = rec;
      r.iteration += offset;  // one numbering over all members
      r.diagnostics["peak_memory_mb"] = peak_memory_mb();
      if (portfolio) {
        r.diagnostics["portfolio_member"] = static_cast<double>(k + 1);
        r.note = "[" + attempt.label() + "] " + r.note;
      }
      record(r);
      const bool go_on = observer ? observer->on_iteration(r) : true;
      // A grow_order member's order only grows: once it reaches the smallest order that met the
      // target without meeting it, it cannot win.
      if (portfolio && config.portfolio_prune && m.member.strategy_name == "grow_order" &&
          smallest_met_order > 0 && r.order >= smallest_met_order && !r.meets_tolerance) {
        pruned = true;
        return false;
      }
      return !any_process(time_is_up() || !go_on);
    };

    StrategyResult result;
    bool set_up = false;
    try {
      // The stop condition also reaches inside reducer calls (interrupt.hpp): a time limit or a
      // signal ends an ARPACK run, an IRKA or ADI iteration within a fraction of a second.
      InterruptScope interrupt(stop_requested);
      set_up = false;
      timed.setup(ReductionContext{&model, solver.get(), config.band});
      set_up = true;
      result = m.strategy->run(ctx);
    } catch (const Interrupted& e) {
      // Stopped inside the reducer's setup (e.g. the Gramians of balanced truncation), before
      // any model, or inside a strategy that does not handle the stop itself (the bundled ones
      // do, keeping their best model): the run ends as interrupted, not as failed.
      result = StrategyResult{};
      result.termination = Termination::Interrupted;
      result.message = (set_up ? "stopped in strategy '" + m.member.strategy_name + "': "
                               : std::string("stopped during the reducer's setup: ")) +
                       e.what();
    } catch (const std::exception& e) {
      if (!portfolio) throw;  // a plain run reports its error as before
      // The next member may well do the job (e.g. balanced truncation refuses an undamped
      // model that modal reduction handles): record the failure and go on.
      result = StrategyResult{};
      result.termination = Termination::Failed;
      result.message = e.what();
      IterationRecord r;
      r.iteration = recorded + 1;
      r.phase = "failed";
      r.band_error = std::numeric_limits<double>::quiet_NaN();
      r.seconds = elapsed();
      r.step_seconds = elapsed() - member_start;
      r.counters = solver->counters();
      r.full_evaluations = cache.size();
      r.note = "[" + attempt.label() + "] failed: " + e.what();
      r.diagnostics["portfolio_member"] = static_cast<double>(k + 1);
      record(r);
      if (observer) observer->on_iteration(r);
    }
    if (out_of_time && result.termination == Termination::Interrupted) {
      result.message = fmt::format("time limit strategy.time_limit_s = {} s used up: {}",
                                   config.time_limit_s, result.message);
    }
    attempt.termination = pruned ? std::string("pruned") : to_string(result.termination);
    attempt.message = pruned
                          ? fmt::format(
                                "stopped at order {} >= {}, the smallest order that met the target "
                                "so far: {}",
                                result.history.empty() ? 0 : result.history.back().order,
                                smallest_met_order, result.message)
                          : result.message;
    attempt.has_model = result.best.has_value();
    attempt.order = attempt.has_model ? result.best->V.cols() : 0;
    attempt.band_error = attempt.has_model ? result.best_error.sup_relative : 0.0;
    attempt.met = result.met();
    attempt.seconds = elapsed() - member_start;
    attempt.reducer_seconds = timed.seconds();
    attempt.iterations = static_cast<Index>(result.history.size());
    if (attempt.met && (smallest_met_order == 0 || attempt.order < smallest_met_order)) {
      smallest_met_order = attempt.order;
    }
    reducer_seconds += timed.seconds();
    reducer_calls += timed.calls();
    reducer_counters += timed.counters();
    reducer_reuses += timed.reuses();
    attempts.push_back(attempt);
    results.push_back(std::move(result));
  }

  const int winner = select_winner(attempts);
  StrategyResult result;
  if (winner >= 0) {
    attempts[static_cast<std::size_t>(winner)].selected = true;
    result = std::move(results[static_cast<std::size_t>(winner)]);
  } else {
    // No model at all: the first failure (plain run: the only attempt) says why.
    result = results.empty() ? StrategyResult{} : std::move(results.front());
  }
  if (portfolio) {
    std::size_t met = 0;
    std::vector<std::string> failures;
    for (const PortfolioAttempt& a : attempts) {
      met += a.met ? 1 : 0;
      if (a.termination == "failed") failures.push_back(a.label() + ": " + a.message);
    }
    if (winner >= 0) {
      const PortfolioAttempt& w = attempts[static_cast<std::size_t>(winner)];
      result.message = fmt::format("portfolio: {} of {} members met the target; {} reported: {}",
                                   met, attempts.size(), w.label(), result.message);
    } else {
      result.termination = Termination::Failed;
      result.message =
          fmt::format("portfolio: no member produced a model ({})", fmt::join(failures, "; "));
    }
    // A stop request ends the whole run as interrupted, even when a member already met the
    // target: the members after it did not run, so "smallest" is not established.
    if ((user_stop || out_of_time) && winner >= 0) {
      for (const PortfolioAttempt& a : attempts) {
        if (a.termination == "not_run" || a.termination == "interrupted") {
          result.termination = Termination::Interrupted;
          result.message = (out_of_time ? fmt::format("time limit strategy.time_limit_s = {} s "
                                                      "used up; ",
                                                      config.time_limit_s)
                                        : std::string("interrupted; ")) +
                           result.message;
          break;
        }
      }
    }
  }

  RunSummary summary;
  summary.termination = result.termination;
  summary.message = result.message;
  summary.tolerance = config.tolerance;
  summary.output_dir = config.output_dir;
  summary.iterations = recorded;
  summary.attempts = attempts;
  if (winner >= 0) {
    summary.reducer = attempts[static_cast<std::size_t>(winner)].reducer;
    summary.strategy = attempts[static_cast<std::size_t>(winner)].strategy;
  } else {
    summary.reducer = config.reducer_name;
    summary.strategy = config.strategy_name;
  }
  summary.load_seconds = load_seconds;
  summary.full_order = size_of(model);

  nlohmann::json j;
  if (result.best) {
    const ReducerResult& best = *result.best;
    if (writer) {
      write_reduction(config.output_dir, best.model, best.V, best.W, config.output_format);
    }
    // The reported model is always re-checked independently, converged or not (a stop request
    // no longer applies here: the check of the model being written is part of writing it).
    const BandError verified = estimator.verify(best.model, config.verify_factor);
    if (writer) write_error_curve(config.output_dir / "band_error.csv", verified);
    summary.has_model = true;
    summary.order = best.V.cols();
    // Estimate mode: the reported error is the re-check's, measured against the full model at
    // every frequency it solved; the strategy's value of a model that never passed is an estimate.
    const bool estimate_mode = estimator.mode() == ErrorVerify::Estimate;
    summary.band_error = estimate_mode ? verified.sup_relative : result.best_error.sup_relative;
    summary.f_peak_hz = estimate_mode ? verified.f_peak_hz : result.best_error.f_peak_hz;
    summary.verified_band_error = verified.sup_relative;
    summary.error_mode = to_string(estimator.mode());
    summary.error_mode_switch = estimator.switch_note();
    summary.checked_frequencies = verified.checked_samples;
    summary.verified_f_peak_hz = verified.f_peak_hz;
    summary.hinf_absolute = verified.hinf_absolute;
    summary.h2_absolute = verified.h2_absolute;
    summary.stability = reduced_model_stability(best.model, rigid);
    summary.stable = summary.stability.accepted();
    const double hinf_start = elapsed();
    const HinfReport hinf = hinf_of_error(model, best.model, verified, config.hinf_dense_states);
    const double hinf_seconds = elapsed() - hinf_start;
    summary.hinf_error = hinf.value;
    summary.hinf_method = hinf.method;
    summary.hinf_scope = hinf.scope;
    j["hinf_error"] = {{"value", hinf.value},
                       {"scope", hinf.scope},
                       {"certified", hinf.certified},
                       {"f_peak_hz", hinf.f_peak_hz >= 0.0 ? nlohmann::json(hinf.f_peak_hz)
                                                           : nlohmann::json(nullptr)},
                       {"method", hinf.method},
                       {"seconds", hinf_seconds}};
    if (summary.termination == Termination::Converged && !verified.within(config.tolerance)) {
      // Cannot happen for strategies that verify before accepting; guard the contract anyway.
      summary.termination = Termination::Failed;
      summary.message = "reported model fails the independent re-check: " + result.message;
    }
    j["undefined_frequencies_hz"] = verified.undefined_f_hz;
    j["sampling"] = {{"estimator", result.best_error.sampling()}, {"verify", verified.sampling()}};
    // What the accepted error rests on: every frequency where the full model was solved (all of
    // them enter the check), and how well the estimate predicted the error there.
    auto number_or_null = [](double v) {
      return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
    };
    j["error_control"] = {
        {"mode", to_string(estimator.mode())},
        {"switch", estimator.switch_note().empty() ? nlohmann::json(nullptr)
                                                   : nlohmann::json(estimator.switch_note())},
        {"reference_order", estimator.reference_order()},
        {"checked_frequencies", verified.checked_samples},
        {"checked_f_hz", estimate_mode ? nlohmann::json(cache.frequencies()) : nlohmann::json(nullptr)},
        {"estimate_sup_unchecked", number_or_null(verified.estimate_sup)},
        {"reference_floor", verified.reference_floor},
        {"effectivity",
         {{"count", verified.effectivity_count},
          {"min", number_or_null(verified.effectivity_min)},
          {"median", number_or_null(verified.effectivity_median)},
          {"max", number_or_null(verified.effectivity_max)}}}};
    j["points"] = nlohmann::json::array();
    for (const ExpansionPoint& p : best.points) {
      j["points"].push_back({{"re", p.s.real()}, {"im", p.s.imag()}, {"moments", p.moments}});
    }
  }
  // The full model's own stability, after the reduction so that a refusal or bad configuration is
  // reported first; dense for small models, structural (K, D inertia) for large second-order ones.
  const double stability_start = elapsed();
  summary.full_stability = full_model_stability(model, config.stability_dense_states, rigid);
  const double stability_seconds = elapsed() - stability_start;
  const StabilityReport& fs = summary.full_stability;
  // A free body whose reduced model keeps its rigid-body modes is the expected case, not a
  // warning: both have the same poles at s = 0 and damped elastic poles.
  const bool rigid_like_full = summary.has_model &&
                               summary.stability.verdict == ReducedVerdict::RigidLikeFull &&
                               fs.verdict == Stability::Marginal && rigid.count > 0;
  if ((fs.verdict == Stability::Unstable || fs.verdict == Stability::Marginal) &&
      !rigid_like_full) {
    summary.warnings.push_back(fmt::format(
        "the full model is {} ({}){}", to_string(fs.verdict), fs.reason,
        summary.has_model && summary.stable
            ? "; the reduced model is stable, so it can represent the full model in the band "
              "only, not in the time domain"
            : ""));
  }
  j["full_model_stability"] = {
      {"verdict", to_string(fs.verdict)},
      {"method", fs.method},
      {"reason", fs.reason},
      {"max_real_pole", fs.dense ? nlohmann::json(fs.max_real_pole) : nlohmann::json(nullptr)},
      {"seconds", stability_seconds}};
  if (summary.has_model) {
    const ReducedStability& st = summary.stability;
    j["stability"] = {{"verdict", st.label},
                      {"accepted", st.accepted()},
                      {"reason", st.reason},
                      {"rigid_modes", st.rigid_modes},
                      {"full_rigid_modes", st.full_rigid_modes},
                      {"zero_radius_rad_s", st.zero_radius},
                      {"poles_at_zero", st.zero_poles},
                      {"full_rigid_method", rigid.describe()},
                      {"full_rigid_seconds", rigid_seconds}};
  }
  j["warnings"] = summary.warnings;
  summary.counters = solver->counters();
  summary.reducer_seconds = reducer_seconds;
  summary.reducer_calls = reducer_calls;
  summary.reducer_counters = reducer_counters;
  summary.reducer_reused_factorizations = reducer_reuses;
  summary.full_response_seconds = cache.seconds();
  summary.full_evaluations = cache.size();
  summary.seconds = elapsed();
  summary.peak_memory_mb = peak_memory_mb();

  j["ecmor_version"] = ECMOR_VERSION_STRING;
  j["config"] = config.source.string();
  j["termination"] = to_string(summary.termination);
  j["message"] = summary.message;
  j["target_met"] = summary.termination == Termination::Converged;
  j["has_model"] = summary.has_model;
  j["final_order"] = summary.order;
  j["band_error"] = summary.band_error;
  j["f_peak_hz"] = summary.f_peak_hz;
  j["verified_band_error"] = summary.verified_band_error;
  j["verified_f_peak_hz"] = summary.verified_f_peak_hz;
  j["verify_factor"] = config.verify_factor;
  j["band_hinf_absolute_error"] = summary.hinf_absolute;
  j["band_h2_absolute_error"] = summary.h2_absolute;
  j["stable"] = summary.stable;
  j["tolerance"] = config.tolerance;
  j["norm"] = to_string(config.norm);
  j["band"] = {{"f_min_hz", config.band.f_min_hz}, {"f_max_hz", config.band.f_max_hz}};
  // The model as the YAML named it: `dir`, or `file` with the renamed `variables`.
  if (is_mat_path(config.model.path)) {
    j["model"] = {{"file", config.model.path.string()}, {"variables", config.model.variables}};
  } else {
    j["model"] = {{"dir", config.model.path.string()}};
  }
  j["model"].update({{"kind", to_string(kind_of(model))},
                     {"N", size_of(model)},
                     {"inputs", inputs_of(model)},
                     {"outputs", outputs_of(model)}});
  j["backend"] = {{"name", config.solver.backend}, {"solver", solver->backend()},
                  {"ranks", process_count()}};
  j["reducer"] = config.reducer_name;
  j["strategy"] = config.strategy_name;
  if (portfolio) {
    nlohmann::json list = nlohmann::json::array();
    for (const PortfolioAttempt& a : attempts) {
      list.push_back({{"reducer", a.reducer},
                      {"strategy", a.strategy},
                      {"termination", a.termination},
                      {"message", a.message},
                      {"target_met", a.met},
                      {"has_model", a.has_model},
                      {"order", a.order},
                      {"band_error", a.band_error},
                      {"seconds", a.seconds},
                      {"reducer_seconds", a.reducer_seconds},
                      {"iterations", a.iterations},
                      {"selected", a.selected}});
    }
    j["portfolio"] = {
        {"winner", winner >= 0 ? nlohmann::json(summary.reducer + "/" + summary.strategy)
                               : nlohmann::json(nullptr)},
        {"prune", config.portfolio_prune},
        {"members", list}};
  }
  j["iterations"] = summary.iterations;
  j["seconds"] = {{"total", summary.seconds},
                  {"load", summary.load_seconds},
                  {"reducer", summary.reducer_seconds},
                  {"full_response", summary.full_response_seconds}};
  j["reducer_calls"] = summary.reducer_calls;
  j["reducer_counters"] = counters_json(summary.reducer_counters);
  j["reducer_reused_factorizations"] = summary.reducer_reused_factorizations;
  j["counters"] = counters_json(summary.counters);
  j["full_evaluations"] = summary.full_evaluations;
  j["peak_memory_mb"] = summary.peak_memory_mb;
  if (writer) write_text_atomically(config.output_dir / "summary.json", j.dump(2) + "\n");

  if (observer) observer->on_finished(summary);
  return summary;
}

}  // namespace ecmor
