// parameters.cpp: the core-owned parameter map that carries YAML settings across the plugin
// boundary.
#include "ecmor/base/parameters.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <type_traits>

#include "ecmor/base/error.hpp"

namespace ecmor {

namespace {

// A value as the user wrote it, for messages: strings quoted so that "abc" and abc differ from
// numbers, doubles in shortest round-trip form so the user recognises their own digits.
std::string describe(const ParameterValue::Storage& value) {
  return std::visit(
      [](const auto& v) -> std::string {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, bool>) {
          return v ? "true" : "false";
        } else if constexpr (std::is_same_v<T, long long> || std::is_same_v<T, double>) {
          return fmt::format("{}", v);
        } else if constexpr (std::is_same_v<T, std::string>) {
          return "'" + v + "'";
        } else if constexpr (std::is_same_v<T, std::vector<double>>) {
          return fmt::format("[{}]", fmt::join(v, ", "));
        } else {
          std::vector<std::string> quoted;
          for (const auto& s : v) quoted.push_back("'" + s + "'");
          return fmt::format("[{}]", fmt::join(quoted, ", "));
        }
      },
      value);
}

std::string type_name(const ParameterValue::Storage& value) {
  switch (value.index()) {
    case 0:
      return "a boolean";
    case 1:
      return "an integer";
    case 2:
      return "a number";
    case 3:
      return "a string";
    case 4:
      return "a list of numbers";
    default:
      return "a list of strings";
  }
}

std::string join(const std::vector<std::string>& words) {
  return fmt::format("{}", fmt::join(words, ", "));
}

}  // namespace

ParameterMap::ParameterMap(std::string owner) : m_owner(std::move(owner)) {}

ParameterMap ParameterMap::section(const std::string& name) {
  ParameterMap map(name);
  map.m_section = true;
  return map;
}

void ParameterMap::set(const std::string& key, ParameterValue value) {
  m_values[key] = std::move(value);
}

bool ParameterMap::has(const std::string& key) const { return m_values.count(key) != 0; }

std::vector<std::string> ParameterMap::keys() const {
  std::vector<std::string> out;
  out.reserve(m_values.size());
  for (const auto& [key, value] : m_values) out.push_back(key);
  return out;
}

std::string ParameterMap::location(const std::string& key) const {
  auto it = m_values.find(key);
  return it == m_values.end() ? std::string() : it->second.location;
}

const ParameterValue* ParameterMap::find(const std::string& key) const {
  m_known.insert(key);
  auto it = m_values.find(key);
  return it == m_values.end() ? nullptr : &it->second;
}

namespace {

// "run.yaml:7: reducer 'modal': batch_size = -3: must be >= 1"
[[noreturn]] void reject(const ParameterMap& map, const std::string& key, const ParameterValue& v,
                         const std::string& rule) {
  map.fail_at(v.location, fmt::format("{} = {}: {}", key, describe(v.value), rule));
}

}  // namespace

bool ParameterMap::get_bool(const std::string& key, bool fallback) const {
  const ParameterValue* v = find(key);
  if (v == nullptr) return fallback;
  if (const bool* b = std::get_if<bool>(&v->value)) return *b;
  reject(*this, key, *v, "must be true or false, not " + type_name(v->value));
}

long long ParameterMap::get_int(const std::string& key, long long fallback, long long min,
                                long long max) const {
  const ParameterValue* v = find(key);
  if (v == nullptr) return fallback;
  long long result = 0;
  if (const long long* i = std::get_if<long long>(&v->value)) {
    result = *i;
  } else if (const double* d = std::get_if<double>(&v->value)) {
    // 1e3 or 20.0 are integers written as floats; 2.5 is not. The bounds keep the cast defined.
    if (!std::isfinite(*d) || *d != std::trunc(*d) || *d < -9.2e18 || *d > 9.2e18)
      reject(*this, key, *v, "must be an integer");
    result = static_cast<long long>(*d);
  } else {
    reject(*this, key, *v, "must be an integer, not " + type_name(v->value));
  }
  if (result < min) reject(*this, key, *v, fmt::format("must be >= {}", min));
  if (result > max) reject(*this, key, *v, fmt::format("must be <= {}", max));
  return result;
}

double ParameterMap::get_double(const std::string& key, double fallback, double min,
                                double max) const {
  const ParameterValue* v = find(key);
  if (v == nullptr) return fallback;
  double result = 0.0;
  if (const double* d = std::get_if<double>(&v->value)) {
    result = *d;
  } else if (const long long* i = std::get_if<long long>(&v->value)) {
    result = static_cast<double>(*i);
  } else {
    reject(*this, key, *v, "must be a number, not " + type_name(v->value));
  }
  // NaN would pass every range comparison below, so it is rejected explicitly.
  if (std::isnan(result)) reject(*this, key, *v, "must be a number, not NaN");
  if (result < min) reject(*this, key, *v, fmt::format("must be >= {}", min));
  if (result > max) reject(*this, key, *v, fmt::format("must be <= {}", max));
  return result;
}

std::string ParameterMap::get_string(const std::string& key, const std::string& fallback,
                                     const std::vector<std::string>& choices) const {
  const ParameterValue* v = find(key);
  if (v == nullptr) return fallback;
  const std::string* s = std::get_if<std::string>(&v->value);
  if (s == nullptr) reject(*this, key, *v, "must be a string, not " + type_name(v->value));
  if (!choices.empty() && std::find(choices.begin(), choices.end(), *s) == choices.end()) {
    std::string rule = "must be one of " + join(choices);
    std::string near = nearest(*s, choices);
    if (!near.empty()) rule += " (did you mean '" + near + "'?)";
    reject(*this, key, *v, rule);
  }
  return *s;
}

std::vector<double> ParameterMap::get_doubles(const std::string& key,
                                              const std::vector<double>& fallback) const {
  const ParameterValue* v = find(key);
  if (v == nullptr) return fallback;
  std::vector<double> result;
  if (const auto* list = std::get_if<std::vector<double>>(&v->value)) {
    result = *list;
  } else if (const double* d = std::get_if<double>(&v->value)) {
    result = {*d};  // a single number is a list of one: `shifts: 10` reads like `shifts: [10]`
  } else if (const long long* i = std::get_if<long long>(&v->value)) {
    result = {static_cast<double>(*i)};
  } else {
    reject(*this, key, *v, "must be a list of numbers, not " + type_name(v->value));
  }
  for (double x : result)
    if (std::isnan(x)) reject(*this, key, *v, "must not contain NaN");
  return result;
}

void ParameterMap::fail(const std::string& key, const std::string& what) const {
  fail_at(location(key), what);
}

void ParameterMap::fail_at(const std::string& location, const std::string& what) const {
  std::string owner = m_owner + ": ";
  if (m_section) owner = m_owner.empty() ? std::string() : m_owner + ".";
  throw ConfigError(fmt::format("{}{}{}", location.empty() ? "" : location + ": ", owner, what));
}

std::vector<std::string> ParameterMap::get_strings(const std::string& key,
                                                   const std::vector<std::string>& fallback) const {
  const ParameterValue* v = find(key);
  if (v == nullptr) return fallback;
  std::vector<std::string> result;
  if (const auto* list = std::get_if<std::vector<std::string>>(&v->value)) {
    result = *list;
  } else if (const std::string* s = std::get_if<std::string>(&v->value)) {
    result = {*s};  // a single string is a list of one
  } else if (const auto* numbers = std::get_if<std::vector<double>>(&v->value);
             numbers != nullptr && numbers->empty()) {
    // `[]`: an empty list has no item type, so it is an empty list of strings too
  } else {
    reject(*this, key, *v, "must be a list of strings, not " + type_name(v->value));
  }
  for (const std::string& s : result)
    if (s.empty()) reject(*this, key, *v, "must not contain an empty string");
  return result;
}

void ParameterMap::declare(const std::vector<std::string>& keys) const {
  m_known.insert(keys.begin(), keys.end());
}

void ParameterMap::check_unused() const {
  const std::vector<std::string> known(m_known.begin(), m_known.end());
  std::string where = m_owner;
  if (m_section) where = m_owner.empty() ? "the configuration" : "'" + m_owner + "'";
  std::vector<std::string> problems;
  for (const auto& [key, value] : m_values) {
    if (m_known.count(key) != 0) continue;
    std::string prefix = value.location.empty() ? std::string() : value.location + ": ";
    problems.push_back(
        fmt::format("{}unknown key '{}' in {}{}", prefix, key, where, suggestion(key, known)));
  }
  if (problems.empty()) return;
  throw ConfigError(fmt::format("{}", fmt::join(problems, "; ")));
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  // Two-row dynamic programme: row[j] = distance between a[0..i) and b[0..j).
  std::vector<std::size_t> previous(b.size() + 1), current(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) previous[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    current[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitute = previous[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      current[j] = std::min({previous[j] + 1, current[j - 1] + 1, substitute});
    }
    std::swap(previous, current);
  }
  return previous[b.size()];
}

std::string nearest(const std::string& word, const std::vector<std::string>& candidates) {
  // A plausible typo changes at most max(2, len/3) characters. A candidate that shares nothing
  // with the word (distance = length of the longer one, e.g. "ab" vs "xy") is never suggested.
  const std::size_t limit = std::max<std::size_t>(2, word.size() / 3);
  std::string best;
  std::size_t best_distance = limit + 1;
  for (const auto& candidate : candidates) {
    const std::size_t d = edit_distance(word, candidate);
    if (d < best_distance && d < std::max(word.size(), candidate.size())) {
      best = candidate;
      best_distance = d;
    }
  }
  return best;
}

std::string suggestion(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string near = nearest(word, candidates);
  if (!near.empty()) return " (did you mean '" + near + "'?)";
  if (candidates.empty()) return " (valid: none)";
  return " (valid: " + join(candidates) + ")";
}

}  // namespace ecmor
