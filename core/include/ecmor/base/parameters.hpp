#pragma once
/// \file parameters.hpp
/// A small, core-owned parameter map: how YAML settings reach reducers and strategies (yaml-cpp
/// does not cross the plugin boundary). Values remember where they came from ("run.yaml:7") so
/// errors can name the line. Every get_* marks the key as known; check_unused() then reports the
/// keys nobody asked for, suggesting the nearest known key ("unknown key 'max_ordr' ... did you
/// mean 'max_order'?").

#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include "ecmor/export.hpp"

namespace ecmor {

/// One parameter value as parsed from the configuration.
struct ParameterValue {
  using Storage = std::variant<bool, long long, double, std::string, std::vector<double>,
                               std::vector<std::string>>;
  Storage value;
  std::string location;  ///< "file.yaml:12", or empty when set programmatically
};

/// Documentation of one parameter, for `ecmor plugins` and the plugin READMEs.
struct ParameterDoc {
  std::string name;
  std::string type;           ///< "int", "double", "bool", "string", "list of double"
  std::string default_value;  ///< as text
  std::string description;    ///< meaning, unit, valid range
};

class ECMOR_API ParameterMap {
 public:
  /// `owner` names the section in messages, e.g. "reducer 'modal'":
  /// "run.yaml:7: reducer 'modal': batch_size = -3: must be >= 1".
  explicit ParameterMap(std::string owner = "parameters");
  /// A map of one section of the run configuration, whose messages name each key by its path in
  /// the file: "run.yaml:4: band.f_min_hz = -1: must be > 0" (an empty `name`: the top level,
  /// "run.yaml:9: compress = 'maybe': ...").
  static ParameterMap section(const std::string& name);

  void set(const std::string& key, ParameterValue value);
  void set(const std::string& key, bool v) { set(key, ParameterValue{v, {}}); }
  void set(const std::string& key, int v) {
    set(key, ParameterValue{static_cast<long long>(v), {}});
  }
  void set(const std::string& key, long long v) { set(key, ParameterValue{v, {}}); }
  void set(const std::string& key, double v) { set(key, ParameterValue{v, {}}); }
  void set(const std::string& key, const char* v) { set(key, ParameterValue{std::string(v), {}}); }
  void set(const std::string& key, std::string v) { set(key, ParameterValue{std::move(v), {}}); }

  bool has(const std::string& key) const;
  const std::string& owner() const { return m_owner; }
  std::vector<std::string> keys() const;
  /// Location of a key's value, or "" if absent.
  std::string location(const std::string& key) const;

  /// Typed access with a default. Each marks `key` as known. Wrong types and values outside
  /// [min, max] throw ConfigError naming owner, key, location, value and rule.
  bool get_bool(const std::string& key, bool fallback) const;
  long long get_int(const std::string& key, long long fallback,
                    long long min = std::numeric_limits<long long>::min(),
                    long long max = std::numeric_limits<long long>::max()) const;
  double get_double(const std::string& key, double fallback,
                    double min = -std::numeric_limits<double>::infinity(),
                    double max = std::numeric_limits<double>::infinity()) const;
  /// With non-empty `choices`, the value must be one of them (suggests the nearest otherwise).
  std::string get_string(const std::string& key, const std::string& fallback,
                         const std::vector<std::string>& choices = {}) const;
  std::vector<double> get_doubles(const std::string& key,
                                  const std::vector<double>& fallback) const;
  /// A list of strings; a single string is a list of one. No item may be empty.
  std::vector<std::string> get_strings(const std::string& key,
                                       const std::vector<std::string>& fallback) const;

  /// Rejects the value of `key`: throws ConfigError "<location>: <owner>: <what>", the location
  /// being that of `key` (omitted when unknown). `what` names the key, the value and the rule
  /// ("max_order = 1: must be >= initial_order = 2"); options.hpp composes it. A section()'s map
  /// puts its name before the key instead: "<location>: band.f_max_hz = 1: ...".
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;
  /// fail() at a known location (a value's, or "" for none).
  [[noreturn]] void fail_at(const std::string& location, const std::string& what) const;

  /// Marks keys as known without reading them (e.g. documented but handled elsewhere).
  void declare(const std::vector<std::string>& keys) const;
  /// \throws ConfigError for the first key never read nor declared, with a suggestion.
  void check_unused() const;

 private:
  const ParameterValue* find(const std::string& key) const;
  std::string m_owner;
  bool m_section = false;  // section(): keys are named "<owner>.<key>"
  std::map<std::string, ParameterValue> m_values;
  mutable std::set<std::string> m_known;
};

/// Levenshtein edit distance (for suggestions).
ECMOR_API std::size_t edit_distance(const std::string& a, const std::string& b);
/// The candidate nearest to `word` if it is close enough to be a plausible typo, else "".
ECMOR_API std::string nearest(const std::string& word, const std::vector<std::string>& candidates);
/// " (did you mean 'x'?)" or " (valid: a, b, c)" for error messages.
ECMOR_API std::string suggestion(const std::string& word,
                                 const std::vector<std::string>& candidates);

}  // namespace ecmor
