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

// The portfolio strategy's own options (the defaults are RunConfig's).
const OptionSpecs<RunConfig>& portfolio_specs() {
  static const OptionSpecs<RunConfig> specs({
      structured<RunConfig>(
          "members", "list of mapping", "the bundled reducers suited to the model",
          "the members, tried in order: each `{reducer: {name: ..., <parameters>}, strategy: "
          "{name: ..., <parameters>}, fallback: true|false}` (strategy default `grow_order`; "
          "`fallback: true` runs only when no member before it met the target)"),
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
    std::vector<Option<C>> options;
    for (const auto& o : E::specs().options()) options.push_back(o.nested(&C::error));
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

// model: a model directory or a .mat file. Both keys fill ModelSource::path; which of them was
// given, and whether variables fits it, the parser checks (parse_model).
const OptionSpecs<RunConfig>& model_specs() {
  using M = ModelSource;
  static const OptionSpecs<RunConfig> specs = [] {
    OptionSpecs<RunConfig> out({});
    return out.include(
        &RunConfig::model,
        OptionSpecs<M>({
            option("dir", &M::path,
                   "directory with the model's `.mtx` (or `.mtx.gz`) files "
                   "([conventions](user-guide.md#model-directories)); exactly one of `dir` and "
                   "`file` is given"),
            option("file", &M::path,
                   "a MATLAB file, its name ending in `.mat`, holding the model's matrices as "
                   "variables ([conventions](user-guide.md#matlab-mat-files))"),
            structured<M>("variables", "mapping", "{}",
                          "with `file` only: the variable holding each matrix, by role (`M D K B "
                          "C Cv E A`), e.g. `{M: Mass, K: Stiff}`; matrices not listed are read "
                          "from the variable of their own name"),
        }));
  }();
  return specs;
}

const OptionSpecs<RunConfig>& band_specs() {
  static const OptionSpecs<RunConfig> specs =
      OptionSpecs<RunConfig>({}).include(&RunConfig::band, Band::specs());
  return specs;
}

const OptionSpecs<RunConfig>& target_specs() {
  using C = RunConfig;
  static const OptionSpecs<C> specs({
      option("tolerance", &C::tolerance,
             "the target: the largest relative error over the band the reduced model may have")
          .range(Range::open_closed(0, 1e3))
          .required(),
      choice("norm", &C::norm, error_norm_names(),
             "the norm of the relative error: `spectral` = ‖H - Hr‖₂ / ‖H‖₂ (the seed's Eq. 22), "
             "`frobenius` = the same in the Frobenius norm (Eq. 23)"),
  });
  return specs;
}

// The reducer section's own key; the others are the reducer's options (its README).
const OptionSpecs<RunConfig>& reducer_specs() {
  static const OptionSpecs<RunConfig> specs({
      option("name", &RunConfig::reducer_name,
             "the reducer (`ecmor plugins` lists them); the section's other keys are its options")
          .required(),
  });
  return specs;
}

// The strategy section's own keys; the others are the strategy's options (strategies.md).
const OptionSpecs<RunConfig>& strategy_specs() {
  static const OptionSpecs<RunConfig> specs({
      option("name", &RunConfig::strategy_name,
             "the strategy ([strategies.md](strategies.md)), or `portfolio`; the section's other "
             "keys are its options"),
      option("time_limit_s", &RunConfig::time_limit_s,
             "wall-clock budget of the whole run: when it is used up the run stops and reports "
             "the best model so far, saying so; 0 = no limit")
          .range(Range::at_least(0).finite())
          .unit("s"),
  });
  return specs;
}

const OptionSpecs<RunConfig>& output_specs() {
  static const OptionSpecs<RunConfig> specs({
      option("dir", &RunConfig::output_dir,
             "output directory, created if needed (`-o` overrides it): the reduced model, its "
             "bases, the history, summary.json and the error plots")
          .required(),
      choice("format", &RunConfig::output_format, output_format_names(),
             "the reduced model and bases as Matrix Market files (`mtx`), one MATLAB file "
             "(`mat`, reduced_model.mat), or `both`"),
  });
  return specs;
}

// check: budgets of `ecmor check`, each 0 = no budget.
const OptionSpecs<RunConfig>& check_specs() {
  static const OptionSpecs<RunConfig> specs({
      option("max_order", &RunConfig::check_max_order,
             "`ecmor check` fails when the reduced order exceeds this; 0 = no budget")
          .range(Range::at_least(0)),
      option("max_seconds", &RunConfig::check_max_seconds,
             "`ecmor check` fails when the run takes longer; 0 = no budget")
          .range(Range::at_least(0).finite())
          .unit("s"),
  });
  return specs;
}

// The keys at the top level that are not sections.
const OptionSpecs<RunConfig>& top_level_specs() {
  static const OptionSpecs<RunConfig> specs({
      option("plugins", &RunConfig::plugins,
             "extra plugin libraries, or directories of them, loaded besides the bundled ones "
             "([user-guide.md](user-guide.md#plugins)); one path is a list of one"),
      option("compress", &RunConfig::compress,
             "search the accepted model for the smallest model inside it that still meets the "
             "target ([strategies.md](strategies.md#compression-after-acceptance-compress-true-"
             "the-default)); false: the model as accepted"),
  });
  return specs;
}

// Every section and its specs, in the order of the file and of docs/user-guide.md. The sections
// reducer and strategy are open: their other keys are the reducer's or strategy's options.
const std::vector<std::pair<std::string, const OptionSpecs<RunConfig>*>>& option_sections() {
  static const std::vector<std::pair<std::string, const OptionSpecs<RunConfig>*>> sections = {
      {"model", &model_specs()},     {"band", &band_specs()},         {"target", &target_specs()},
      {"reducer", &reducer_specs()}, {"strategy", &strategy_specs()}, {"error", &error_specs()},
      {"solver", &solver_specs()},   {"backend", &backend_specs()},   {"output", &output_specs()},
      {"check", &check_specs()}};
  return sections;
}

// The keys of the configuration's top level: the sections and the keys of top_level_specs().
std::vector<std::string> top_level_keys() {
  std::vector<std::string> keys;
  for (const auto& [name, specs] : option_sections()) keys.push_back(name);
  for (const std::string& key : top_level_specs().keys()) keys.push_back(key);
  return keys;
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
  std::optional<std::string> text(const YAML::Node& map, const std::string& sec,
                                  const std::string& key, bool required);
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
  /// The sections whose keys are not all options: model (dir or file), the reducer and strategy
  /// (whose other keys are the plugin's options).
  void parse_model(RunConfig& config);
  void parse_strategy(bool portfolio, RunConfig& config);
  /// A section read through its specs: keys checked (an `open` section passes its other keys to
  /// a plugin), required keys present (unless `required` is false), values read into `config`.
  /// Returns the section's node.
  YAML::Node read_section(const std::string& name, const OptionSpecs<RunConfig>& specs,
                          RunConfig& config, bool open = false, bool required = true);
  /// The values of the specs' keys in `map` (structured keys left to their parser); text-typed
  /// options (names, paths, choices) take the value as written: a directory may be called 2024.
  ParameterMap options_of(const YAML::Node& map, const std::string& sec,
                          const OptionSpecs<RunConfig>& specs);
  /// The top level's keys that are not sections (plugins, compress).
  void parse_top_level(RunConfig& config);
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

std::optional<std::string> Parser::text(const YAML::Node& map, const std::string& sec,
                                        const std::string& key, bool required) {
  auto v = scalar(map, sec, key, required);
  if (!v) return std::nullopt;
  // Names and paths are text whatever they look like (a directory may be called "2024").
  const std::string& s = v->second.Scalar();
  if (s.empty()) fail(at(v->second), fmt::format("{}.{} must not be empty", sec, key));
  return s;
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
    params.set(key, parameter(it->first, it->second, sec + "." + key));
  }
}

ParameterMap Parser::options_of(const YAML::Node& map, const std::string& sec,
                                const OptionSpecs<RunConfig>& specs) {
  ParameterMap params = ParameterMap::section(sec);
  if (!map.IsMap()) return params;
  for (auto it = map.begin(); it != map.end(); ++it) {
    // Copies: `it->` returns a proxy that ends with the full expression, and a range-for over
    // its member would outlive it.
    const YAML::Node key_node = it->first;
    const YAML::Node node = it->second;
    const std::string key = key_node.Scalar();
    const std::string full_key = sec.empty() ? key : sec + "." + key;
    for (const auto& opt : specs.options()) {
      if (opt.key() != key || opt.is_structured()) continue;
      ParameterValue value = parameter(key_node, node, full_key);
      const bool text = opt.type() == "string" || opt.type() == "path";
      if (text && node.IsScalar()) value.value = node.Scalar();
      if (opt.type() == "list of path" && node.IsSequence()) {
        std::vector<std::string> items;
        for (const YAML::Node& item : node) items.push_back(item.Scalar());
        if (!items.empty()) value.value = items;
      }
      params.set(key, std::move(value));
    }
  }
  return params;
}

void Parser::parse_portfolio(const YAML::Node& strategy, RunConfig& config) {
  std::vector<std::string> keys = strategy_specs().keys();
  for (const std::string& key : portfolio_specs().keys()) keys.push_back(key);
  check_keys(strategy, "'strategy' (portfolio)", keys);
  portfolio_specs().read_into(options_of(strategy, "strategy", portfolio_specs()), config);
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
  for (const auto& [name, specs] : option_sections()) {
    if (name == "model") {
      if (m_req.model) parse_model(config);
    } else if (name == "reducer") {
      parse_strategy(portfolio, config);
    } else if (name != "strategy") {
      read_section(name, *specs, config, false, name != "output" || m_req.output);
    }
  }
  config.error.norm = config.norm;
  parse_top_level(config);
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
  const std::vector<std::string> keys = top_level_keys();
  if (!m_root.IsDefined() || m_root.IsNull())
    fail(m_name,
         fmt::format("the file is empty (expected the sections {})", fmt::join(keys, ", ")));
  if (!m_root.IsMap())
    fail(at(m_root), fmt::format("expected a mapping of sections ({}), found {}",
                                 fmt::join(keys, ", "), node_kind(m_root)));
  check_keys(m_root, "the configuration", keys);
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
  const YAML::Node model = section(m_root, "model", model_specs().keys());
  const bool by_dir = model["dir"].IsDefined();
  const bool by_file = model["file"].IsDefined();
  if (by_dir && by_file)
    fail(at(model["file"]),
         "give model.dir (a model directory) or model.file (a .mat file), not both");
  if (!by_dir && !by_file)
    fail(model.IsNull() ? key_location(m_root, "model") : at(model),
         "missing required key 'model.dir' (a model directory) or 'model.file' (a .mat file)");
  model_specs().read_into(options_of(model, "model", model_specs()), config);
  if (by_dir) {
    if (model["variables"].IsDefined())
      fail(at(model["variables"]),
           "model.variables renames the variables of a .mat file (model.file); the files of a "
           "model directory have fixed names");
    return;
  }
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

// strategy (with reducer), or a portfolio's strategy section with its members.
void Parser::parse_strategy(bool portfolio, RunConfig& config) {
  if (portfolio) {
    const YAML::Node strategy = section(m_root, "strategy", {}, true);
    strategy_specs().read_into(options_of(strategy, "strategy", strategy_specs()), config);
    config.reducer_name = "portfolio";
    parse_portfolio(strategy, config);
    return;
  }
  const YAML::Node reducer = read_section("reducer", reducer_specs(), config, true);
  config.reducer_params = ParameterMap("reducer '" + config.reducer_name + "'");
  collect_parameters(reducer, "reducer", config.reducer_params, reducer_specs().keys());
  const YAML::Node strategy = read_section("strategy", strategy_specs(), config, true);
  config.strategy_params = ParameterMap("strategy '" + config.strategy_name + "'");
  collect_parameters(strategy, "strategy", config.strategy_params, strategy_specs().keys());
}

YAML::Node Parser::read_section(const std::string& name, const OptionSpecs<RunConfig>& specs,
                                RunConfig& config, bool open, bool required) {
  const YAML::Node node = section(m_root, name, specs.keys(), open);
  const ParameterMap options = options_of(node, name, specs);
  if (const auto* missing = required ? specs.missing_required(options) : nullptr)
    fail(node.IsMap() ? at(node) : key_location(m_root, name),
         fmt::format("missing required key '{}.{}'", name, missing->key()));
  specs.read_into(options, config, required);
  return node;
}

// The top level's plain keys (plugins, compress), read through their specs like a section's.
void Parser::parse_top_level(RunConfig& config) {
  top_level_specs().read_into(options_of(m_root, "", top_level_specs()), config);
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

std::vector<ParameterDoc> top_level_options() { return top_level_specs().docs(); }

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
