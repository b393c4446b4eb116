// config.cpp: the YAML run configuration. Everything the user can get wrong is reported with the
// file, the line and the key, because a run that starts with a silently misread setting wastes
// hours (a misspelt `tolerence` would otherwise leave the default tolerance in force).
#include "ecmor/run/config.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"

namespace ecmor {

namespace {

const std::vector<std::string> kSections = {"model",    "band",    "target", "reducer",
                                            "strategy", "error",   "solver", "backend",
                                            "output",   "plugins", "check",  "compress"};

// The keys of a portfolio's strategy section that are not options: `members` (a list of
// mappings) and the run's time_limit_s.
const std::vector<std::string> kPortfolioStructure = {"name", "members", "time_limit_s"};

// The portfolio strategy's own options (the defaults are RunConfig's).
const OptionSpecs<RunConfig>& portfolio_specs() {
  static const OptionSpecs<RunConfig> specs({
      option("prune", &RunConfig::portfolio_prune,
             "stop a grow_order member once its order reaches the smallest order that met the "
             "target so far without meeting it (it can no longer win)"),
      option("race", &RunConfig::portfolio_race,
             "once a member has met the target, stop each later member when it has made more "
             "than this many times the full-model factorisations of the member ahead (the "
             "smallest order met, ties to the faster); a model it met before stays in the race; "
             "0 = no limit")
          .range(Range::at_least(0)),
  });
  return specs;
}

// The error section: the band error estimator's options and the run's checks of the reported
// model (the defaults are RunConfig's and BandErrorOptions').
const OptionSpecs<RunConfig>& error_specs() {
  using E = BandErrorOptions;
  using C = RunConfig;
  static const OptionSpecs<C> specs = [] {
    const OptionSpecs<E> estimator({
        option("grid_points", &E::grid_points, "initial log-spaced frequencies over the band")
            .range(Range::closed(2, 1e6)),
        option("pole_samples", &E::pole_samples,
               "also sample at Im(p)/2π of the reduced poles inside the band (resonances)"),
        option("max_pole_samples", &E::max_pole_samples,
               "at most this many pole samples, least damped first")
            .range(Range::at_least(0)),
        option("refine_peaks", &E::refine_peaks, "local maxima of the error refined per evaluation")
            .range(Range::at_least(0)),
        option("refine_evaluations", &E::refine_evaluations,
               "golden-section steps per refined peak at most; a peak stops earlier when its "
               "value has not risen for 6 steps")
            .range(Range::closed(0, 200)),
        option("zero_threshold", &E::zero_threshold,
               "`‖H(f)‖ <= zero_threshold · max_f ‖H‖` counts as \"H vanishes\": relative error "
               "undefined there, excluded and reported")
            .range(Range::closed_open(0, 1)),
        // Mapped here rather than by parse_error_verify (band_error.cpp): the config reader
        // stays free of the error engine (the fuzz build links the readers alone).
        choice("verify", &E::verify,
               {{"dense", ErrorVerify::Dense},
                {"estimate", ErrorVerify::Estimate},
                {"auto", ErrorVerify::Auto}},
               "how the full model's H is obtained: `dense` = a full-model solve (sparse "
               "factorisation) at every sample; `estimate` = a reference model grown from the "
               "run's full solves stands in for H, and full solves are made only where the "
               "estimate peaks, at random and at the band edges; `auto` = `dense` up to "
               "`dense_max_states`, else `estimate` until its reference model has cost more than "
               "the dense sampling would (counted in flops, so every run decides alike), then "
               "`dense` ([error-measures.md](error-measures.md#the-estimator-error-control-"
               "without-a-full-solve-per-frequency-errorverify))"),
        option("dense_max_states", &E::dense_max_states,
               "`auto` chooses `dense` for full models with at most this many states N")
            .range(Range::at_least(0)),
        option("estimate_points", &E::estimate_points,
               "estimate mode: log-spaced samples of the estimate (no full solve each)")
            .range(Range::closed(2, 1e6)),
        option("reference_points", &E::reference_points,
               "estimate mode: full solves that seed the reference model: the band edges and "
               "golden-ratio points in log f between them")
            .range(Range::closed(2, 10000)),
        option("check_peaks", &E::check_peaks,
               "estimate mode: largest local maxima of the estimate solved per round of the "
               "re-check")
            .range(Range::at_least(1)),
        option("random_checks", &E::random_checks,
               "estimate mode: log-uniform random frequencies solved per re-check (fixed seed)")
            .range(Range::at_least(0)),
        option("check_rounds", &E::check_rounds,
               "estimate mode: rounds of (estimate, solve its peaks) per re-check")
            .range(Range::at_least(1)),
        option("probe_solves", &E::probe_solves,
               "estimate mode: full solves per evaluation at the estimate's peak when it has none "
               "there")
            .range(Range::at_least(0)),
    });
    std::vector<Option<C>> options;
    for (const auto& o : estimator.options()) options.push_back(o.nested(&C::error));
    // The re-check grid must be denser than the estimator's to be a check at all.
    options.push_back(option("verify_factor", &C::verify_factor,
                             "dense mode: the independent re-check grid is this many times "
                             "denser than `grid_points`")
                          .range(Range::at_least(2)));
    // Both bounds keep the dense eigenproblems to seconds.
    options.push_back(
        option("hinf_dense_states", &C::hinf_dense_states,
               "full models with at most this many first-order states (2N for second order) get "
               "the reported model's error H∞ norm over all frequencies by the dense level-set "
               "method (certified); larger ones the sampled band supremum. `summary.json`'s "
               "`hinf_error` says which")
            .range(Range::closed(0, 6000)));
    options.push_back(
        option("stability_dense_states", &C::stability_dense_states,
               "the full model's stability (`summary.json` `full_model_stability`): symmetric "
               "second-order models by the inertia of K and D first (sparse Cholesky: K not "
               "positive definite means a pole at 0 or in the right half-plane, K and D positive "
               "definite asymptotic stability); where that cannot decide (unsymmetric K or D, D "
               "semidefinite) and for descriptor models, the dense eigenvalues up to this many "
               "first-order states (about 3 s at 900; QZ for singular E); above, `unknown`. 0: "
               "never dense")
            .range(Range::closed(0, 6000)));
    return OptionSpecs<C>(std::move(options));
  }();
  return specs;
}

// The solver section: the sparse shifted solver (SolverOptions::specs()) and the run's threads.
const OptionSpecs<RunConfig>& solver_specs() {
  using C = RunConfig;
  static const OptionSpecs<C> specs = [] {
    std::vector<Option<C>> options = {
        option("threads", &C::threads,
               "the run's threads, ecmor's loops and the BLAS together: 0 = the process's "
               "budget (`ECMOR_THREADS`, else `OMP_NUM_THREADS`, else the cores it may use, "
               "fewer while other processes keep cores busy), n = exactly n "
               "([user-guide.md](user-guide.md#threads))")
            .range(Range::closed(0, 65536)),
    };
    for (const auto& o : SolverOptions::specs().options()) options.push_back(o.nested(&C::solver));
    return OptionSpecs<C>(std::move(options));
  }();
  return specs;
}

// The backend section: which shifted solver does the sparse work (SolverOptions::backend_specs()).
const OptionSpecs<RunConfig>& backend_specs() {
  static const OptionSpecs<RunConfig> specs = [] {
    std::vector<Option<RunConfig>> options;
    for (const auto& o : SolverOptions::backend_specs().options())
      options.push_back(o.nested(&RunConfig::solver));
    return OptionSpecs<RunConfig>(std::move(options));
  }();
  return specs;
}

// The sections of plain key/value options, read through their specs.
const std::vector<std::pair<std::string, const OptionSpecs<RunConfig>*>>& option_sections() {
  static const std::vector<std::pair<std::string, const OptionSpecs<RunConfig>*>> sections = {
      {"error", &error_specs()}, {"solver", &solver_specs()}, {"backend", &backend_specs()}};
  return sections;
}

std::string node_kind(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Map:
      return "a mapping";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Scalar:
      return "a scalar";
    case YAML::NodeType::Null:
      return "nothing";
    default:
      return "an undefined node";
  }
}

/// A scalar read as YAML 1.2 core types, in the order the header documents.
ParameterValue::Storage classify_scalar(const YAML::Node& node) {
  const std::string& text = node.Scalar();
  // Quoted scalars ("123", 'true') carry the non-specific tag "!": the user asked for a string.
  if (node.Tag() == "!") return text;
  if (text == "true" || text == "True" || text == "TRUE" || text == "yes" || text == "Yes" ||
      text == "YES")
    return true;
  if (text == "false" || text == "False" || text == "FALSE" || text == "no" || text == "No" ||
      text == "NO")
    return false;
  // from_chars rejects a leading '+', which YAML allows.
  std::string_view digits = text;
  if (digits.size() > 1 && digits[0] == '+' && digits[1] != '-' && digits[1] != '+')
    digits.remove_prefix(1);
  const char* first = digits.data();
  const char* last = digits.data() + digits.size();
  long long integer = 0;
  auto [iend, ierr] = std::from_chars(first, last, integer);
  if (ierr == std::errc() && iend == last && !digits.empty()) return integer;
  double real = 0.0;
  auto [dend, derr] = std::from_chars(first, last, real);
  if (derr == std::errc() && dend == last && !digits.empty()) return real;
  // YAML's own spellings of the special floats.
  if (text == ".inf" || text == ".Inf" || text == ".INF" || text == "+.inf" || text == "+.Inf" ||
      text == "+.INF")
    return std::numeric_limits<double>::infinity();
  if (text == "-.inf" || text == "-.Inf" || text == "-.INF")
    return -std::numeric_limits<double>::infinity();
  if (text == ".nan" || text == ".NaN" || text == ".NAN")
    return std::numeric_limits<double>::quiet_NaN();
  return text;
}

class Parser {
 public:
  Parser(std::string name, ConfigRequirements requirements)
      : m_name(std::move(name)), m_req(requirements) {}

  RunConfig parse(const std::string& yaml);

 private:
  std::string at(const YAML::Mark& mark) const {
    return mark.is_null() || !m_req.lines ? m_name : fmt::format("{}:{}", m_name, mark.line + 1);
  }
  std::string at(const YAML::Node& node) const {
    return node.IsDefined() ? at(node.Mark()) : m_name;
  }
  // yaml-cpp marks an empty value at the next token (often the next line), so messages about
  // empty values name the line of their key instead.
  std::string key_location(const YAML::Node& parent, const std::string& key) const {
    for (auto it = parent.begin(); it != parent.end(); ++it)
      if (it->first.IsScalar() && it->first.Scalar() == key) return at(it->first);
    return at(parent);
  }
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw ConfigError(where + ": " + what);
  }

  /// The section as a mapping (a missing or empty section reads as an empty mapping), with every
  /// key checked against `known`.
  YAML::Node section(const YAML::Node& root, const std::string& name,
                     const std::vector<std::string>& known, bool open = false);
  void check_keys(const YAML::Node& map, const std::string& where_name,
                  const std::vector<std::string>& known);

  /// Scalar accessors; `sec` is the section name for messages ("band.f_min_hz").
  std::optional<std::pair<ParameterValue::Storage, YAML::Node>> scalar(const YAML::Node& map,
                                                                       const std::string& sec,
                                                                       const std::string& key,
                                                                       bool required);
  std::optional<double> number(const YAML::Node& map, const std::string& sec,
                               const std::string& key, bool required);
  std::optional<long long> integer(const YAML::Node& map, const std::string& sec,
                                   const std::string& key, long long min);
  std::optional<std::string> text(const YAML::Node& map, const std::string& sec,
                                  const std::string& key, bool required);
  std::filesystem::path path_value(const YAML::Node& map, const std::string& sec,
                                   const std::string& key);
  /// A text value that must be one of the names in `options` (each with the value it stands
  /// for); the error lists the names and suggests the nearest.
  template <class T>
  std::optional<T> choice(const YAML::Node& map, const std::string& sec, const std::string& key,
                          const std::vector<std::pair<std::string, T>>& options) {
    const auto v = text(map, sec, key, false);
    if (!v) return std::nullopt;
    std::vector<std::string> names;
    for (const auto& [name, value] : options) {
      if (*v == name) return value;
      names.push_back(name);
    }
    const std::string near = nearest(*v, names);
    fail(at(map[key]),
         fmt::format("{}.{} = '{}': must be one of {}{}", sec, key, *v, fmt::join(names, ", "),
                     near.empty() ? std::string() : " (did you mean '" + near + "'?)"));
  }

  /// Every key but those in `skip` becomes a parameter of the reducer/strategy.
  void collect_parameters(const YAML::Node& map, const std::string& sec, ParameterMap& params,
                          const std::vector<std::string>& skip = {"name"});
  /// strategy: {name: portfolio, prune: ..., members: [{reducer: {...}, strategy: {...}}, ...]}.
  void parse_portfolio(const YAML::Node& strategy, RunConfig& config);
  /// strategy.members[k] (`where`): {reducer: {name: ..., ...}, strategy: {name: ..., ...}}.
  PortfolioMember parse_member(const YAML::Node& item, const std::string& where);

  /// Reads the YAML into m_root and checks the section names. \throws ConfigError.
  void load(const std::string& yaml);
  /// Whether strategy.name is portfolio (whose members name the reducers). Not const, nor is
  /// require_sections: a const YAML::Node's operator[] makes an invalid node of a missing key.
  bool names_portfolio();
  void require_sections(bool portfolio);
  /// One function per section: reads it into `config`.
  void parse_model(RunConfig& config);
  void parse_band(RunConfig& config);
  void parse_target(RunConfig& config);
  void parse_strategy(bool portfolio, RunConfig& config);
  void parse_check(RunConfig& config);
  void parse_output(RunConfig& config);
  /// A section of plain key/value options (error, solver, backend), read through its specs.
  void read_section(const std::string& name, const OptionSpecs<RunConfig>& specs,
                    RunConfig& config);
  void parse_plugins(RunConfig& config);
  void parse_compress(RunConfig& config);
  ParameterValue parameter(const YAML::Node& key, const YAML::Node& value,
                           const std::string& full_key);

  std::string m_name;
  ConfigRequirements m_req;
  YAML::Node m_root;
};

void Parser::check_keys(const YAML::Node& map, const std::string& where_name,
                        const std::vector<std::string>& known) {
  std::map<std::string, int> seen;
  std::vector<std::string> problems;
  for (auto it = map.begin(); it != map.end(); ++it) {
    const YAML::Node key = it->first;
    if (!key.IsScalar()) fail(at(key), "keys in " + where_name + " must be plain names");
    const std::string& k = key.Scalar();
    // yaml-cpp keeps duplicate keys and operator[] returns the first: the second would be ignored
    // without a word, so it is an error.
    if (auto [pos, inserted] = seen.emplace(k, key.Mark().line + 1); !inserted)
      fail(at(key), fmt::format("duplicate key '{}' in {} (first given at line {})", k, where_name,
                                pos->second));
    if (!known.empty() && std::find(known.begin(), known.end(), k) == known.end())
      problems.push_back(fmt::format("{}: unknown key '{}' in {}{}", at(key), k, where_name,
                                     suggestion(k, known)));
  }
  if (!problems.empty()) throw ConfigError(fmt::format("{}", fmt::join(problems, "; ")));
}

YAML::Node Parser::section(const YAML::Node& root, const std::string& name,
                           const std::vector<std::string>& known, bool open) {
  const YAML::Node node = root[name];
  if (!node.IsDefined()) return YAML::Node(YAML::NodeType::Map);
  if (node.IsNull()) return node;  // `band:` with nothing after it: keeps its line for messages
  if (!node.IsMap())
    fail(at(node), fmt::format("'{}' must be a mapping of keys ({}), found {}", name,
                               fmt::join(known, ", "), node_kind(node)));
  // Open sections (reducer, strategy) accept any key; only duplicates are checked here.
  check_keys(node, "'" + name + "'", open ? std::vector<std::string>{} : known);
  return node;
}

std::optional<std::pair<ParameterValue::Storage, YAML::Node>> Parser::scalar(const YAML::Node& map,
                                                                             const std::string& sec,
                                                                             const std::string& key,
                                                                             bool required) {
  const YAML::Node node = map[key];
  if (!node.IsDefined()) {
    if (required)
      fail(map.IsNull() ? key_location(m_root, sec) : at(map),
           fmt::format("missing required key '{}.{}'", sec, key));
    return std::nullopt;
  }
  if (node.IsNull()) fail(key_location(map, key), fmt::format("{}.{} has no value", sec, key));
  if (!node.IsScalar())
    fail(at(node),
         fmt::format("{}.{} must be a single value, found {}", sec, key, node_kind(node)));
  return std::make_pair(classify_scalar(node), node);
}

std::optional<double> Parser::number(const YAML::Node& map, const std::string& sec,
                                     const std::string& key, bool required) {
  auto v = scalar(map, sec, key, required);
  if (!v) return std::nullopt;
  double result = 0.0;
  if (const double* d = std::get_if<double>(&v->first)) {
    result = *d;
  } else if (const long long* i = std::get_if<long long>(&v->first)) {
    result = static_cast<double>(*i);
  } else {
    fail(at(v->second),
         fmt::format("{}.{} = '{}': must be a number", sec, key, v->second.Scalar()));
  }
  if (!std::isfinite(result))
    fail(at(v->second), fmt::format("{}.{} = {}: must be finite", sec, key, v->second.Scalar()));
  return result;
}

std::optional<long long> Parser::integer(const YAML::Node& map, const std::string& sec,
                                         const std::string& key, long long min) {
  auto v = scalar(map, sec, key, false);
  if (!v) return std::nullopt;
  long long result = 0;
  if (const long long* i = std::get_if<long long>(&v->first)) {
    result = *i;
  } else if (const double* d = std::get_if<double>(&v->first);
             d != nullptr && std::isfinite(*d) && *d == std::trunc(*d) && std::abs(*d) < 9e18) {
    result = static_cast<long long>(*d);  // 1e3 is an integer written as a float
  } else {
    fail(at(v->second),
         fmt::format("{}.{} = {}: must be an integer", sec, key, v->second.Scalar()));
  }
  if (result < min)
    fail(at(v->second), fmt::format("{}.{} = {}: must be >= {}", sec, key, result, min));
  return result;
}

std::optional<std::string> Parser::text(const YAML::Node& map, const std::string& sec,
                                        const std::string& key, bool required) {
  auto v = scalar(map, sec, key, required);
  if (!v) return std::nullopt;
  // Names and paths are text whatever they look like (a directory may be called "2024").
  const std::string& s = v->second.Scalar();
  if (s.empty()) fail(at(v->second), fmt::format("{}.{} must not be empty", sec, key));
  return s;
}

std::filesystem::path Parser::path_value(const YAML::Node& map, const std::string& sec,
                                         const std::string& key) {
  return std::filesystem::absolute(*text(map, sec, key, true)).lexically_normal();
}

ParameterValue Parser::parameter(const YAML::Node& key, const YAML::Node& value,
                                 const std::string& full_key) {
  ParameterValue out;
  out.location = at(key);
  if (value.IsNull()) fail(at(key), full_key + " has no value");
  if (value.IsMap())
    fail(at(value),
         full_key + ": nested mappings are not supported (a parameter is a value or a list)");
  if (value.IsScalar()) {
    out.value = classify_scalar(value);
    return out;
  }
  // A list: all numbers -> list of double, all strings -> list of string.
  std::vector<double> numbers;
  std::vector<std::string> strings;
  for (const YAML::Node& item : value) {
    if (!item.IsScalar())
      fail(at(item), fmt::format("{}: list items must be single values, found {}", full_key,
                                 node_kind(item)));
    auto v = classify_scalar(item);
    if (const double* d = std::get_if<double>(&v)) {
      numbers.push_back(*d);
    } else if (const long long* i = std::get_if<long long>(&v)) {
      numbers.push_back(static_cast<double>(*i));
    } else if (const std::string* s = std::get_if<std::string>(&v)) {
      strings.push_back(*s);
    } else {
      fail(at(item), fmt::format("{}: lists of true/false are not supported", full_key));
    }
    if (!numbers.empty() && !strings.empty())
      fail(at(item),
           fmt::format("{}: list mixes numbers and text ('{}')", full_key, item.Scalar()));
  }
  if (!strings.empty())
    out.value = std::move(strings);
  else
    out.value = std::move(numbers);
  return out;
}

void Parser::collect_parameters(const YAML::Node& map, const std::string& sec, ParameterMap& params,
                                const std::vector<std::string>& skip) {
  for (auto it = map.begin(); it != map.end(); ++it) {
    const std::string& key = it->first.Scalar();
    if (std::find(skip.begin(), skip.end(), key) != skip.end()) continue;
    // The driver's wall-clock budget in the strategy section is not a strategy parameter.
    if (sec == "strategy" && key == "time_limit_s") continue;
    params.set(key, parameter(it->first, it->second, sec + "." + key));
  }
}

void Parser::parse_portfolio(const YAML::Node& strategy, RunConfig& config) {
  std::vector<std::string> keys = kPortfolioStructure;
  for (const std::string& key : portfolio_specs().keys()) keys.push_back(key);
  check_keys(strategy, "'strategy' (portfolio)", keys);
  ParameterMap options("strategy 'portfolio'");
  collect_parameters(strategy, "strategy", options, kPortfolioStructure);
  portfolio_specs().read_into(options, config);
  const YAML::Node members = strategy["members"];
  const std::string shape =
      "a list of {reducer: {name: ..., <parameters>}, strategy: {name: ..., <parameters>}}";
  if (!members.IsDefined()) return;  // the driver fills in the default members
  if (!members.IsSequence() || members.size() == 0)
    fail(members.IsNull() ? key_location(strategy, "members") : at(members),
         fmt::format("strategy.members must be {}, found {}", shape,
                     members.IsSequence() ? "an empty list" : node_kind(members)));
  for (std::size_t k = 0; k < members.size(); ++k)
    config.portfolio.push_back(
        parse_member(members[k], fmt::format("strategy.members[{}]", k + 1)));
}

PortfolioMember Parser::parse_member(const YAML::Node& item, const std::string& where) {
  if (!item.IsMap())
    fail(at(item), fmt::format("{} must be a mapping with 'reducer' (and optionally "
                               "'strategy' and 'fallback'), found {}",
                               where, node_kind(item)));
  check_keys(item, where, {"reducer", "strategy", "fallback"});
  PortfolioMember member;
  if (const YAML::Node fallback = item["fallback"]; fallback.IsDefined()) {
    const bool is_bool =
        fallback.IsScalar() && std::holds_alternative<bool>(classify_scalar(fallback));
    if (!is_bool)
      fail(fallback.IsNull() ? key_location(item, "fallback") : at(fallback),
           fmt::format("{}.fallback must be true or false, found {}", where,
                       fallback.IsScalar() ? "'" + fallback.Scalar() + "'" : node_kind(fallback)));
    member.fallback = std::get<bool>(classify_scalar(fallback));
  }
  const YAML::Node reducer = item["reducer"];
  if (!reducer.IsDefined()) fail(at(item), fmt::format("missing required key '{}.reducer'", where));
  if (!reducer.IsMap())
    fail(reducer.IsNull() ? key_location(item, "reducer") : at(reducer),
         fmt::format("{}.reducer must be a mapping with 'name' and the reducer's parameters, "
                     "found {}",
                     where, node_kind(reducer)));
  check_keys(reducer, "'" + where + ".reducer'", {});
  member.reducer_name = *text(reducer, where + ".reducer", "name", true);
  member.reducer_params =
      ParameterMap(fmt::format("reducer '{}' ({})", member.reducer_name, where));
  collect_parameters(reducer, where + ".reducer", member.reducer_params);
  const YAML::Node inner = item["strategy"];
  if (inner.IsDefined() && !inner.IsMap())
    fail(inner.IsNull() ? key_location(item, "strategy") : at(inner),
         fmt::format("{}.strategy must be a mapping with 'name' and the strategy's parameters, "
                     "found {}",
                     where, node_kind(inner)));
  if (inner.IsDefined()) {
    check_keys(inner, "'" + where + ".strategy'", {});
    if (auto name = text(inner, where + ".strategy", "name", false)) member.strategy_name = *name;
    if (member.strategy_name == "portfolio")
      fail(at(inner["name"]), where + ".strategy: a portfolio member cannot be a portfolio");
    if (inner["time_limit_s"].IsDefined())
      fail(at(inner["time_limit_s"]),
           where +
               ".strategy.time_limit_s: the time limit is the whole portfolio's; give it as "
               "strategy.time_limit_s");
  }
  member.strategy_params =
      ParameterMap(fmt::format("strategy '{}' ({})", member.strategy_name, where));
  if (inner.IsDefined()) collect_parameters(inner, where + ".strategy", member.strategy_params);
  return member;
}

RunConfig Parser::parse(const std::string& yaml) {
  load(yaml);
  const bool portfolio = names_portfolio();
  require_sections(portfolio);
  RunConfig config;
  if (m_req.model) parse_model(config);
  parse_band(config);
  parse_target(config);
  parse_strategy(portfolio, config);
  config.error.norm = config.norm;
  for (const auto& [name, specs] : option_sections()) read_section(name, *specs, config);
  parse_check(config);
  parse_output(config);
  parse_plugins(config);
  parse_compress(config);
  return config;
}

void Parser::load(const std::string& yaml) {
  try {
    m_root = YAML::Load(yaml);
  } catch (const YAML::ParserException& e) {
    fail(at(e.mark), "YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    fail(at(e.mark), "cannot read YAML: " + e.msg);
  }
  if (!m_root.IsDefined() || m_root.IsNull())
    fail(m_name,
         fmt::format("the file is empty (expected the sections {})", fmt::join(kSections, ", ")));
  if (!m_root.IsMap())
    fail(at(m_root), fmt::format("expected a mapping of sections ({}), found {}",
                                 fmt::join(kSections, ", "), node_kind(m_root)));
  check_keys(m_root, "the configuration", kSections);
}

bool Parser::names_portfolio() {
  const YAML::Node strategy = m_root["strategy"];
  // (A missing key reads as an invalid node, whose IsScalar() throws: test IsDefined() first.)
  return strategy.IsMap() && strategy["name"].IsDefined() && strategy["name"].IsScalar() &&
         strategy["name"].Scalar() == "portfolio";
}

void Parser::require_sections(bool portfolio) {
  if (!m_req.model && m_root["model"].IsDefined())
    fail(key_location(m_root, "model"),
         "the model is given by the caller, so the configuration must not name one: remove the "
         "'model' section");
  for (const char* required : {"model", "band", "target", "reducer", "output"}) {
    if (portfolio && std::string(required) == "reducer") continue;
    if (!m_req.model && std::string(required) == "model") continue;
    if (!m_req.output && std::string(required) == "output") continue;
    if (!m_root[required].IsDefined())
      fail(at(m_root), fmt::format("missing required section '{}'", required));
  }
  if (portfolio && m_root["reducer"].IsDefined())
    fail(key_location(m_root, "reducer"),
         "with strategy 'portfolio' each member names its reducer (strategy.members[k].reducer); "
         "remove the top-level 'reducer' section");
}

// model: {dir: D} (Matrix Market files) or {file: F.mat, variables: {M: Mass, ...}}.
void Parser::parse_model(RunConfig& config) {
  const YAML::Node model = section(m_root, "model", {"dir", "file", "variables"});
  const bool by_dir = model["dir"].IsDefined();
  const bool by_file = model["file"].IsDefined();
  if (by_dir && by_file)
    fail(at(model["file"]),
         "give model.dir (a model directory) or model.file (a .mat file), not both");
  if (!by_dir && !by_file)
    fail(model.IsNull() ? key_location(m_root, "model") : at(model),
         "missing required key 'model.dir' (a model directory) or 'model.file' (a .mat file)");
  if (by_dir) {
    config.model.path = path_value(model, "model", "dir");
    if (model["variables"].IsDefined())
      fail(at(model["variables"]),
           "model.variables renames the variables of a .mat file (model.file); the files of a "
           "model directory have fixed names");
    return;
  }
  config.model.path = path_value(model, "model", "file");
  if (!is_mat_file_name(config.model.path))
    fail(at(model["file"]), fmt::format("model.file = '{}': must name a MATLAB file ending in "
                                        ".mat (a model directory is model.dir)",
                                        model["file"].Scalar()));
  if (const YAML::Node vars = model["variables"]; vars.IsDefined()) {
    if (!vars.IsMap())
      fail(vars.IsNull() ? key_location(model, "variables") : at(vars),
           fmt::format("model.variables must be a mapping from matrix to variable name, e.g. "
                       "{{M: Mass, K: Stiff}}, found {}",
                       node_kind(vars)));
    check_keys(vars, "'model.variables'", model_variable_roles());
    for (auto it = vars.begin(); it != vars.end(); ++it) {
      const std::string role = it->first.Scalar();
      config.model.variables[role] = *text(vars, "model.variables", role, true);
    }
  }
}

void Parser::parse_band(RunConfig& config) {
  const YAML::Node band = section(m_root, "band", {"f_min_hz", "f_max_hz"});
  config.band.f_min_hz = *number(band, "band", "f_min_hz", true);
  config.band.f_max_hz = *number(band, "band", "f_max_hz", true);
  // Band::validate is the lead's; these are the same rules with the line attached.
  if (!(config.band.f_min_hz > 0.0))
    fail(at(band["f_min_hz"]),
         fmt::format("band.f_min_hz = {}: must be > 0 (the band is sampled in log scale, and "
                     "f = 0 is a pole of H for a model with rigid-body modes, e.g. a "
                     "free-floating body)",
                     band["f_min_hz"].Scalar()));
  if (!(config.band.f_max_hz > config.band.f_min_hz))
    fail(at(band["f_max_hz"]), fmt::format("band.f_max_hz = {}: must be > band.f_min_hz = {}",
                                           band["f_max_hz"].Scalar(), band["f_min_hz"].Scalar()));
}

void Parser::parse_target(RunConfig& config) {
  const YAML::Node target = section(m_root, "target", {"tolerance", "norm"});
  config.tolerance = *number(target, "target", "tolerance", true);
  if (!(config.tolerance > 0.0 && config.tolerance <= 1e3))
    fail(at(target["tolerance"]),
         fmt::format("target.tolerance = {}: must be in (0, 1e3]", target["tolerance"].Scalar()));
  // Parsed here rather than with parse_error_norm so the message carries the line.
  if (auto norm = choice<ErrorNorm>(
          target, "target", "norm",
          {{"spectral", ErrorNorm::Spectral}, {"frobenius", ErrorNorm::Frobenius}}))
    config.norm = *norm;
}

// strategy (with reducer), or a portfolio's strategy section with its members.
void Parser::parse_strategy(bool portfolio, RunConfig& config) {
  const YAML::Node strategy = section(m_root, "strategy", {"name"}, true);
  if (portfolio) {
    config.reducer_name = "portfolio";
    config.strategy_name = "portfolio";
    parse_portfolio(strategy, config);
  } else {
    const YAML::Node reducer = section(m_root, "reducer", {"name"}, true);
    config.reducer_name = *text(reducer, "reducer", "name", true);
    config.reducer_params = ParameterMap("reducer '" + config.reducer_name + "'");
    collect_parameters(reducer, "reducer", config.reducer_params);
    if (auto name = text(strategy, "strategy", "name", false)) config.strategy_name = *name;
    config.strategy_params = ParameterMap("strategy '" + config.strategy_name + "'");
    collect_parameters(strategy, "strategy", config.strategy_params);
  }
  if (auto v = number(strategy, "strategy", "time_limit_s", false)) {
    if (!(*v > 0.0))
      fail(at(strategy["time_limit_s"]),
           fmt::format("strategy.time_limit_s = {}: must be > 0 (seconds of wall-clock time)",
                       strategy["time_limit_s"].Scalar()));
    config.time_limit_s = *v;
  }
}

void Parser::read_section(const std::string& name, const OptionSpecs<RunConfig>& specs,
                          RunConfig& config) {
  const YAML::Node node = section(m_root, name, specs.keys());
  ParameterMap options("section '" + name + "'");
  if (node.IsMap()) collect_parameters(node, name, options, {});
  specs.read_into(options, config);
}

// check: budgets of `ecmor check`. Not read through option specs: the defaults (0: no budget)
// lie outside the valid values, and a spec's range holds for its default too.
void Parser::parse_check(RunConfig& config) {
  const YAML::Node check = section(m_root, "check", {"max_order", "max_seconds"});
  if (auto v = integer(check, "check", "max_order", 1)) config.check_max_order = *v;
  if (auto v = number(check, "check", "max_seconds", false)) {
    if (!(*v > 0.0))
      fail(at(check["max_seconds"]),
           fmt::format("check.max_seconds = {}: must be > 0", check["max_seconds"].Scalar()));
    config.check_max_seconds = *v;
  }
}

void Parser::parse_output(RunConfig& config) {
  const YAML::Node output = section(m_root, "output", {"dir", "format"});
  if (m_req.output || output["dir"].IsDefined())
    config.output_dir = path_value(output, "output", "dir");
  if (auto format = choice<OutputFormat>(
          output, "output", "format",
          {{"mtx", OutputFormat::Mtx}, {"mat", OutputFormat::Mat}, {"both", OutputFormat::Both}}))
    config.output_format = *format;
}

// plugins: a list of paths, or a single path (a list of one).
void Parser::parse_plugins(RunConfig& config) {
  const YAML::Node plugins = m_root["plugins"];
  if (!plugins.IsDefined() || plugins.IsNull()) return;
  auto add = [&](const YAML::Node& item) {
    if (!item.IsScalar() || item.Scalar().empty())
      fail(at(item), fmt::format("plugins: each entry must be a path, found {}",
                                 item.IsScalar() ? "an empty string" : node_kind(item)));
    config.plugins.push_back(std::filesystem::absolute(item.Scalar()).lexically_normal());
  };
  if (plugins.IsSequence()) {
    for (const YAML::Node& item : plugins) add(item);
  } else if (plugins.IsScalar()) {
    add(plugins);
  } else {
    fail(at(plugins), "'plugins' must be a list of paths, found " + node_kind(plugins));
  }
}

// compress: true | false (the compression of the accepted model, driver.hpp).
void Parser::parse_compress(RunConfig& config) {
  const YAML::Node node = m_root["compress"];
  if (!node.IsDefined()) return;
  const std::string text = node.IsScalar() ? node.Scalar() : std::string();
  if (text != "true" && text != "false")
    fail(node.IsNull() ? key_location(m_root, "compress") : at(node),
         fmt::format("compress = '{}': must be true (search the accepted model for the smallest "
                     "model that still meets the target) or false",
                     node.IsScalar() ? text : node_kind(node)));
  config.compress = text == "true";
}

}  // namespace

std::vector<ParameterDoc> portfolio_options() { return portfolio_specs().docs(); }

std::vector<std::string> option_section_names() {
  std::vector<std::string> names;
  for (const auto& [name, specs] : option_sections()) names.push_back(name);
  return names;
}

std::vector<ParameterDoc> section_options(const std::string& section) {
  for (const auto& [name, specs] : option_sections())
    if (name == section) return specs->docs();
  throw std::invalid_argument("section_options: '" + section + "' is no section of options");
}

RunConfig parse_run_config(const std::string& yaml, const std::string& name,
                           const ConfigRequirements& requirements) {
  return Parser(name, requirements).parse(yaml);
}

RunConfig load_run_config(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw ConfigError(path.string() + ": configuration file not found");
  if (std::filesystem::is_directory(path, ec))
    throw ConfigError(path.string() + ": is a directory, not a configuration file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path.string() + ": cannot open the configuration file for reading");
  std::ostringstream contents;
  contents << in.rdbuf();
  if (in.bad()) throw ConfigError(path.string() + ": error while reading the configuration file");
  RunConfig config = parse_run_config(contents.str(), path.string());
  config.source = std::filesystem::absolute(path).lexically_normal();
  return config;
}

}  // namespace ecmor
