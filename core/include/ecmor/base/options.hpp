#pragma once
/// \file options.hpp
/// Options stated once. A reducer or strategy keeps its settings in a plain struct whose default
/// member initialisers are the defaults; one Option per field then gives the YAML key, the field
/// (a pointer to member), the valid range or choices, the unit and the documentation. From that
/// one list, OptionSpecs
///   * reads and validates a ParameterMap into the struct (read()), every rule failing with a
///     ConfigError "<file:line>: <owner>: <key> = <value>: <rule>";
///   * documents the options for `ecmor plugins` and the READMEs (docs(): default from the
///     struct, range and unit in the text);
///   * lists the keys (keys()), for tests;
///   * validates a struct filled in code, not from a file (validate(): the C++ and Python APIs),
///     by the same ranges, choices and rules, failing with "<owner>: <key> = <value>: <rule>".
///
///   struct Options { Index batch_size = 20; bool shrink = true; Mode mode = Mode::Band; };
///   const OptionSpecs<Options> kSpecs({
///       option("batch_size", &Options::batch_size, "eigenpairs per run").range(Range::closed(1,
///       1e5)), option("shrink", &Options::shrink, "bisect after the first pass"), choice("mode",
///       &Options::mode, {{"band", Mode::Band}, {"dominance", Mode::Dominance}},
///              "order of the modes"),
///   });
///   Options o = kSpecs.read(params);            // in create()
///   info.parameters = kSpecs.docs();            // in the ReducerInfo
///
/// Rules between fields (a budget at least as large as a start value) go into the OptionSpecs'
/// rule functions; they name fields, not keys (OptionCheck::fail(o.max_order, ...)), so that every
/// key is written once, in its Option.
///
/// Header-only templates on purpose: they are instantiated in the plugin or strategy that owns the
/// struct, so no option type crosses the plugin boundary; only ParameterMap (core) does.

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/parameters.hpp"
#include "ecmor/export.hpp"

namespace ecmor {

/// A number as messages and documentation print it: integral values up to 1e15 without exponent
/// ("100000"), others in shortest round-trip form, fixed between 1e-4 and 1e16 ("0.01"),
/// scientific outside ("1e-10"), as fmt's "{}" does; "inf", "-inf", "nan".
inline std::string option_number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (v == std::trunc(v) && std::abs(v) < 1e15) return std::to_string(static_cast<long long>(v));
  char buffer[64];
  const double a = std::abs(v);
  const auto format =
      a >= 1e-4 && a < 1e16 ? std::chars_format::fixed : std::chars_format::scientific;
  const auto end = std::to_chars(buffer, buffer + sizeof buffer, v, format).ptr;
  return std::string(buffer, end);
}

/// The valid values of a number (or of every item of a list): an interval whose ends may be open
/// or closed. An open infinite end means "finite": Range::above(0).finite() is (0, inf).
/// NaN is never contained.
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;

  static Range any() { return {}; }
  static Range at_least(double lo) { return {lo, kInf, false, false}; }             ///< [lo, inf]
  static Range above(double lo) { return {lo, kInf, true, false}; }                 ///< (lo, inf]
  static Range closed(double lo, double hi) { return {lo, hi, false, false}; }      ///< [lo, hi]
  static Range open(double lo, double hi) { return {lo, hi, true, true}; }          ///< (lo, hi)
  static Range open_closed(double lo, double hi) { return {lo, hi, true, false}; }  ///< (lo, hi]
  static Range closed_open(double lo, double hi) { return {lo, hi, false, true}; }  ///< [lo, hi)
  /// The same range without infinite values.
  Range finite() const {
    Range r = *this;
    if (r.hi == kInf) r.hi_open = true;
    if (r.lo == -kInf) r.lo_open = true;
    return r;
  }

  bool unbounded() const { return lo == -kInf && hi == kInf && !lo_open && !hi_open; }
  bool contains(double v) const {
    return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  }
  /// "in [1, 100000]", ">= 1", "> 0 and finite", "< 1", "" for any.
  std::string text() const {
    const bool has_lo = lo > -kInf, has_hi = hi < kInf;
    std::string t;
    if (has_lo && has_hi) {
      return std::string("in ") + (lo_open ? "(" : "[") + option_number(lo) + ", " +
             option_number(hi) + (hi_open ? ")" : "]");
    }
    if (has_lo) t = (lo_open ? "> " : ">= ") + option_number(lo);
    if (has_hi) t = (hi_open ? "< " : "<= ") + option_number(hi);
    if ((!has_lo && lo_open) || (!has_hi && hi_open)) t += t.empty() ? "finite" : " and finite";
    return t;
  }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();
};

template <class O>
class OptionSpecs;

/// One option of the struct O: key, field, documentation and rule. Built by option() or choice()
/// below and refined by the chained setters (range, unit, only_if, given, integers).
template <class O>
class Option {
 public:
  using Read = std::function<void(const Option&, const ParameterMap&, O&)>;
  using Show = std::function<std::string(const O&)>;
  using Address = std::function<const void*(const O&)>;
  /// Checks the field's value in a struct filled in code against the option's rule.
  using Check = std::function<void(const Option&, const ParameterMap&, const O&)>;

  Option(std::string key, std::string type, std::string doc, Read read, Show show, Address address)
      : m_key(std::move(key)),
        m_type(std::move(type)),
        m_doc(std::move(doc)),
        m_read(std::move(read)),
        m_show(std::move(show)),
        m_address(std::move(address)) {}

  /// Valid values (of every item, for a list). Not for bool or choice options.
  Option& range(Range r) {
    m_range = r;
    return *this;
  }
  /// Why the range is what it is, appended to the message of a value outside it:
  /// "f_min_hz = 0: must be > 0 and finite (the band is sampled in log scale, ...)".
  Option& because(std::string reason) {
    m_reason = std::move(reason);
    return *this;
  }
  /// "must be > 0 and finite (<reason>)": the rule a value outside the range breaks.
  std::string range_rule() const {
    return "must be " + m_range.text() + (m_reason.empty() ? "" : " (" + m_reason + ")");
  }
  /// Unit of the value ("Hz", "decades"), printed in the documentation.
  Option& unit(std::string u) {
    m_unit = std::move(u);
    return *this;
  }
  /// The key may be given only when `applies(o)` holds for the options read; otherwise reading
  /// fails with `rule` ("applies to structure: second_order only").
  Option& only_if(std::function<bool(const O&)> applies, std::string rule) {
    m_applies = std::move(applies);
    m_condition = std::move(rule);
    return *this;
  }
  /// Sets `*flag` to whether the key was given (for defaults that depend on the model).
  Option& given(bool O::*flag) {
    m_given = flag;
    return *this;
  }
  /// For a list of numbers: every item must be an integer.
  Option& integers() {
    m_integers = true;
    if (m_type == "list of double") m_type = "list of int";
    return *this;
  }
  /// The key must be given: the documentation says "required" where the default would stand,
  /// and missing_required() names it.
  Option& required() {
    m_required = true;
    return *this;
  }

  const std::string& key() const { return m_key; }
  const std::string& type() const { return m_type; }
  const Range& valid_range() const { return m_range; }
  const std::vector<std::string>& choices() const { return m_choices; }
  bool integer_items() const { return m_integers; }
  bool is_required() const { return m_required; }
  /// A structured() key: its value is no parameter (a mapping), and its owner's parser reads it.
  bool is_structured() const { return m_structured; }

  /// The field's value in `o` as text ("20", "band", "[1, 2]").
  std::string value_text(const O& o) const { return m_show(o); }
  /// The default: the field of a value-initialised O, i.e. its default member initialiser.
  std::string default_text() const { return m_show(O{}); }
  /// "in [1, 100000]", "one of band, dominance", or "".
  std::string valid_text() const {
    if (!m_choices.empty()) {
      std::string t = "one of ";
      for (std::size_t i = 0; i < m_choices.size(); ++i) t += (i ? ", " : "") + m_choices[i];
      return t;
    }
    const std::string r = m_range.text();
    if (r.empty()) return r;
    return (m_type.rfind("list", 0) == 0 ? (m_integers ? "integers " : "items ") : "") + r;
  }
  /// Documentation for `ecmor plugins` and the READMEs: the doc, then unit, condition and range.
  ParameterDoc document() const {
    std::string text = m_doc;
    if (!m_unit.empty()) text += "; unit: " + m_unit;
    if (!m_condition.empty()) text += "; " + m_condition;
    const std::string valid = valid_text();
    if (!valid.empty()) text += "; valid: " + valid;
    return {m_key, m_type, m_required ? "required" : default_text(), text};
  }

  /// Reads the key into o (o's field is the fallback). \throws ConfigError.
  void read(const ParameterMap& params, O& o) const {
    m_read(*this, params, o);
    if (m_given != nullptr) o.*m_given = params.has(m_key);
  }
  /// \throws ConfigError "<key> = <value>: <rule>" when o's field breaks the option's range or
  ///         names no choice (validate()).
  void check_value(const ParameterMap& params, const O& o) const {
    if (m_check) m_check(*this, params, o);
  }
  /// Used by the factories: how check_value() checks the field.
  void set_check(Check check) { m_check = std::move(check); }
  /// \throws ConfigError when the key is given but its condition does not hold for o.
  void check_condition(const ParameterMap& params, const O& o) const {
    if (m_applies && params.has(m_key) && !m_applies(o)) reject(params, o, m_condition);
  }
  /// \throws ConfigError "<key> = <value of o>: <rule>".
  [[noreturn]] void reject(const ParameterMap& params, const O& o, const std::string& rule) const {
    params.fail(m_key, m_key + " = " + value_text(o) + ": " + rule);
  }
  /// True if this option's field in o is the object at `field`.
  bool holds(const O& o, const void* field) const { return m_address(o) == field; }

  /// This option as an option of Outer, whose member `member` is an O.
  template <class Outer>
  Option<Outer> nested(O Outer::*member) const {
    const Option inner = *this;
    Option<Outer> outer(
        m_key, m_type, m_doc,
        [inner, member](const Option<Outer>&, const ParameterMap& p, Outer& o) {
          inner.read(p, o.*member);
        },
        [inner, member](const Outer& o) { return inner.value_text(o.*member); },
        [inner, member](const Outer& o) { return inner.m_address(o.*member); });
    outer.m_range = m_range;
    outer.m_unit = m_unit;
    outer.m_reason = m_reason;
    outer.m_choices = m_choices;
    outer.m_integers = m_integers;
    outer.m_condition = m_condition;
    outer.m_required = m_required;
    outer.m_structured = m_structured;
    if (m_check) {
      outer.m_check = [inner, member](const Option<Outer>&, const ParameterMap& p, const Outer& o) {
        inner.check_value(p, o.*member);
      };
    }
    if (m_applies) {
      outer.m_applies = [inner, member](const Outer& o) { return inner.m_applies(o.*member); };
    }
    return outer;
  }
  /// This option under the key `prefix` + key ("adi_" + "tolerance"): a struct's specs offered
  /// among another struct's keys (chain nested() after it; reading, checks and messages all use
  /// the prefixed key).
  Option prefixed(const std::string& prefix) const {
    Option copy = *this;
    copy.m_key = prefix + m_key;
    return copy;
  }
  /// This option under another key, documented as what it is in its new place
  /// (AdaptiveQuadratureOptions' relative_tolerance offered as a reducer's
  /// band_quadrature_tolerance); range, choices and rule stay the option's own.
  Option renamed(std::string key, std::string doc) const {
    Option copy = *this;
    copy.m_key = std::move(key);
    copy.m_doc = std::move(doc);
    return copy;
  }

  /// Used by choice(): the names, in order.
  void set_choices(std::vector<std::string> names) { m_choices = std::move(names); }
  /// Used by structured().
  void set_structured() { m_structured = true; }

 private:
  template <class>
  friend class Option;

  std::string m_key, m_type, m_doc, m_unit, m_condition, m_reason;
  Range m_range;
  std::vector<std::string> m_choices;
  bool m_integers = false;
  bool m_required = false;
  bool m_structured = false;
  Read m_read;
  Show m_show;
  Address m_address;
  Check m_check;
  std::function<bool(const O&)> m_applies;
  bool O::*m_given = nullptr;
};

namespace options_detail {

template <class O, class T>
typename Option<O>::Address address_of(T O::*field) {
  return [field](const O& o) -> const void* { return &(o.*field); };
}

inline std::string list_text(const std::vector<double>& v) {
  std::string t = "[";
  for (std::size_t i = 0; i < v.size(); ++i) t += (i ? ", " : "") + option_number(v[i]);
  return t + "]";
}

// "key = value: must be in [1, 10]" unless the range holds.
template <class O>
void check_range(const Option<O>& self, const ParameterMap& p, double v) {
  if (!self.valid_range().contains(v)) {
    p.fail(self.key(), self.key() + " = " + option_number(v) + ": " + self.range_rule());
  }
}

// "key[i] = value: must be [an integer] in [1, 10]" for the first item outside the rule.
template <class O>
void check_items(const Option<O>& self, const ParameterMap& p, const std::vector<double>& v) {
  for (std::size_t i = 0; i < v.size(); ++i) {
    const bool integral = std::isfinite(v[i]) && v[i] == std::trunc(v[i]);
    if (!self.valid_range().contains(v[i]) || (self.integer_items() && !integral)) {
      p.fail(self.key(), self.key() + "[" + std::to_string(i) + "] = " + option_number(v[i]) +
                             ": must be " + (self.integer_items() ? "an integer " : "") +
                             self.valid_range().text());
    }
  }
}

}  // namespace options_detail

/// A boolean option (YAML true/false).
template <class O>
Option<O> option(std::string key, bool O::*field, std::string doc) {
  return Option<O>(
      std::move(key), "bool", std::move(doc),
      [field](const Option<O>& self, const ParameterMap& p, O& o) {
        o.*field = p.get_bool(self.key(), o.*field);
      },
      [field](const O& o) -> std::string { return o.*field ? "true" : "false"; },
      options_detail::address_of(field));
}

/// An integer option (any integral field type other than bool).
template <class O, class T,
          std::enable_if_t<std::is_integral_v<T> && !std::is_same_v<T, bool>, int> = 0>
Option<O> option(std::string key, T O::*field, std::string doc) {
  Option<O> opt(
      std::move(key), "int", std::move(doc),
      [field](const Option<O>& self, const ParameterMap& p, O& o) {
        const long long v = p.get_int(self.key(), static_cast<long long>(o.*field));
        options_detail::check_range(self, p, static_cast<double>(v));
        o.*field = static_cast<T>(v);
      },
      [field](const O& o) { return std::to_string(o.*field); }, options_detail::address_of(field));
  opt.set_check([field](const Option<O>& self, const ParameterMap& p, const O& o) {
    if (!self.valid_range().contains(static_cast<double>(o.*field)))
      self.reject(p, o, self.range_rule());
  });
  return opt;
}

/// A real option (NaN is always refused).
template <class O>
Option<O> option(std::string key, double O::*field, std::string doc) {
  Option<O> opt(
      std::move(key), "double", std::move(doc),
      [field](const Option<O>& self, const ParameterMap& p, O& o) {
        const double v = p.get_double(self.key(), o.*field);
        options_detail::check_range(self, p, v);
        o.*field = v;
      },
      [field](const O& o) { return option_number(o.*field); }, options_detail::address_of(field));
  opt.set_check([field](const Option<O>& self, const ParameterMap& p, const O& o) {
    if (!self.valid_range().contains(o.*field)) self.reject(p, o, self.range_rule());
  });
  return opt;
}

/// A list of numbers (a single number is a list of one); range() and integers() apply to every
/// item, and a failing item is named by its 0-based index: "points[1] = -2: must be > 0".
template <class O>
Option<O> option(std::string key, std::vector<double> O::*field, std::string doc) {
  Option<O> opt(
      std::move(key), "list of double", std::move(doc),
      [field](const Option<O>& self, const ParameterMap& p, O& o) {
        std::vector<double> v = p.get_doubles(self.key(), o.*field);
        options_detail::check_items(self, p, v);
        o.*field = std::move(v);
      },
      [field](const O& o) { return options_detail::list_text(o.*field); },
      options_detail::address_of(field));
  opt.set_check([field](const Option<O>& self, const ParameterMap& p, const O& o) {
    options_detail::check_items(self, p, o.*field);
  });
  return opt;
}

/// The names of an enum's values, stated once: a choice() option, to_string and the parsers of
/// the APIs all read the same list.
template <class T>
using NameList = std::vector<std::pair<std::string, T>>;

/// The name of `value` in `names`. \throws std::logic_error for a value without a name.
template <class T>
const std::string& name_of(const NameList<T>& names, T value) {
  for (const auto& n : names)
    if (n.second == value) return n.first;
  throw std::logic_error("a value without a name");
}

/// The value named `name`. \throws ConfigError "<what> = '<name>': must be one of a, b (did you
/// mean 'a'?)".
template <class T>
T value_of(const NameList<T>& names, const std::string& name, const std::string& what) {
  std::vector<std::string> list;
  for (const auto& n : names) {
    if (n.first == name) return n.second;
    list.push_back(n.first);
  }
  std::string rule = "must be one of ";
  for (std::size_t i = 0; i < list.size(); ++i) rule += (i ? ", " : "") + list[i];
  const std::string near = nearest(name, list);
  if (!near.empty()) rule += " (did you mean '" + near + "'?)";
  std::string quoted(1, '\'');
  quoted.append(name);
  quoted.push_back('\'');
  throw ConfigError(what + " = " + quoted + ": " + rule);
}

/// A string option with a fixed set of names, each standing for one value of the field (an enum,
/// a bool, ...). The default is the name of the struct's default value.
template <class O, class T>
Option<O> choice(std::string key, T O::*field, std::vector<std::pair<std::string, T>> names,
                 std::string doc) {
  std::vector<std::string> list;
  for (const auto& n : names) list.push_back(n.first);
  auto show = [field, names](const O& o) -> std::string {
    for (const auto& n : names)
      if (n.second == o.*field) return n.first;
    throw std::logic_error("option value without a name");
  };
  Option<O> opt(
      std::move(key), "string", std::move(doc),
      [field, names, show](const Option<O>& self, const ParameterMap& p, O& o) {
        const std::string name = p.get_string(self.key(), show(o), self.choices());
        for (const auto& n : names)
          if (n.first == name) o.*field = n.second;
      },
      show, options_detail::address_of(field));
  opt.set_check([field, names](const Option<O>& self, const ParameterMap& p, const O& o) {
    for (const auto& n : names)
      if (n.second == o.*field) return;
    std::string value = "a value without a name";
    if constexpr (std::is_convertible_v<T, std::string>) {
      // Appended, not "'" + s + "'": GCC 12 warns falsely (-Wrestrict) on that form.
      value.assign(1, '\'');
      value.append(o.*field);
      value.push_back('\'');
    }
    p.fail(self.key(), self.key() + " = " + value + ": must be " + self.valid_text());
  });
  opt.set_choices(std::move(list));
  return opt;
}

/// A text option (a name; never empty).
template <class O>
Option<O> option(std::string key, std::string O::*field, std::string doc) {
  return Option<O>(
      std::move(key), "string", std::move(doc),
      [field](const Option<O>& self, const ParameterMap& p, O& o) {
        const std::string v = p.get_string(self.key(), o.*field);
        if (v.empty()) p.fail(self.key(), self.key() + " = '': must not be empty");
        o.*field = v;
      },
      [field](const O& o) { return o.*field; }, options_detail::address_of(field));
}

/// A file or directory. A relative path is taken from the working directory, as a shell would;
/// the field holds it absolute and normalised.
template <class O>
Option<O> option(std::string key, std::filesystem::path O::*field, std::string doc) {
  return Option<O>(
      std::move(key), "path", std::move(doc),
      [field](const Option<O>& self, const ParameterMap& p, O& o) {
        if (!p.has(self.key())) return;
        const std::string v = p.get_string(self.key(), "");
        if (v.empty()) p.fail(self.key(), self.key() + " = '': must not be empty");
        o.*field = std::filesystem::absolute(v).lexically_normal();
      },
      [field](const O& o) { return (o.*field).empty() ? "none" : (o.*field).string(); },
      options_detail::address_of(field));
}

/// A list of files or directories (a single path is a list of one), each as option(path) reads
/// it.
template <class O>
Option<O> option(std::string key, std::vector<std::filesystem::path> O::*field, std::string doc) {
  return Option<O>(
      std::move(key), "list of path", std::move(doc),
      [field](const Option<O>& self, const ParameterMap& p, O& o) {
        if (!p.has(self.key())) return;
        std::vector<std::filesystem::path> paths;
        for (const std::string& v : p.get_strings(self.key(), {}))
          paths.push_back(std::filesystem::absolute(v).lexically_normal());
        o.*field = std::move(paths);
      },
      [field](const O& o) {
        std::string t = "[";
        for (std::size_t i = 0; i < (o.*field).size(); ++i)
          t += (i ? ", " : "") + (o.*field)[i].string();
        return t + "]";
      },
      options_detail::address_of(field));
}

/// A key whose value is structured (a mapping, a list of mappings), read by the parser of its
/// section rather than by the specs; listed so that the key is known and documented with the
/// others. `default_text` documents what its absence means.
template <class O>
Option<O> structured(std::string key, std::string type, std::string default_text, std::string doc) {
  Option<O> opt(
      std::move(key), std::move(type), std::move(doc),
      [](const Option<O>& self, const ParameterMap& p, O&) { p.declare({self.key()}); },
      [default_text](const O&) { return default_text; },
      [](const O&) -> const void* { return nullptr; });
  opt.set_structured();
  return opt;
}

/// What a rule between fields sees: the options read, and how to name a field's key.
template <class O>
class OptionCheck {
 public:
  OptionCheck(const std::vector<Option<O>>& options, const ParameterMap& params, const O& o)
      : m_options(options), m_params(params), m_o(o) {}
  /// \throws ConfigError "<location>: <owner>: <key> = <value>: <rule>" for the option whose
  ///         field is `field` (a member of the options being checked).
  template <class T>
  [[noreturn]] void fail(const T& field, const std::string& rule) const {
    option_of(&field).reject(m_params, m_o, rule);
  }
  /// The key of the option whose field is `field`.
  template <class T>
  const std::string& key(const T& field) const {
    return option_of(&field).key();
  }
  const ParameterMap& params() const { return m_params; }
  /// Whether the key of `field` was given.
  template <class T>
  bool given(const T& field) const {
    return m_params.has(key(field));
  }

 private:
  const Option<O>& option_of(const void* field) const {
    for (const auto& opt : m_options)
      if (opt.holds(m_o, field)) return opt;
    throw std::logic_error("OptionCheck: a field without an option");
  }
  const std::vector<Option<O>>& m_options;
  const ParameterMap& m_params;
  const O& m_o;
};

/// The options of a struct O: read, validate, document, list.
template <class O>
class OptionSpecs {
 public:
  /// A rule between fields, run after every option is read; throws through check.fail().
  using Rule = std::function<void(const O& o, const OptionCheck<O>& check)>;

  explicit OptionSpecs(std::vector<Option<O>> options, std::vector<Rule> rules = {})
      : m_options(std::move(options)), m_rules(std::move(rules)) {
    for (std::size_t i = 0; i < m_options.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (m_options[i].key() == m_options[j].key())
          throw std::logic_error("option key '" + m_options[i].key() + "' given twice");
  }

  /// Adds the options and rules of `inner`, the specs of O's member `member`.
  template <class Inner>
  OptionSpecs& include(Inner O::*member, const OptionSpecs<Inner>& inner) {
    std::vector<Option<O>> added;
    for (const auto& opt : inner.options()) added.push_back(opt.template nested<O>(member));
    for (const auto& rule : inner.rules()) {
      const std::vector<Option<Inner>> inner_options = inner.options();
      m_rules.push_back([rule, inner_options, member](const O& o, const OptionCheck<O>& c) {
        rule(o.*member, OptionCheck<Inner>(inner_options, c.params(), o.*member));
      });
    }
    return *this = OptionSpecs(concat(m_options, added), m_rules);
  }

  /// Reads every option into `o` (its fields are the fallbacks), then checks the conditions and
  /// rules. Marks each key as known to the map (its check_unused() then flags the others).
  /// \throws ConfigError naming owner, key, location, value and rule.
  /// `check_required` false: a required key may be missing (a caller that knows better).
  void read_into(const ParameterMap& params, O& o, bool check_required = true) const {
    const Option<O>* missing = check_required ? missing_required(params) : nullptr;
    if (missing != nullptr)
      params.fail(missing->key(), missing->key() + ": required, but not given");
    for (const auto& opt : m_options) opt.read(params, o);
    for (const auto& opt : m_options) opt.check_condition(params, o);
    const OptionCheck<O> check(m_options, params, o);
    for (const auto& rule : m_rules) rule(o, check);
  }
  /// The first required key not in `params`, or nullptr.
  const Option<O>* missing_required(const ParameterMap& params) const {
    for (const auto& opt : m_options)
      if (opt.is_required() && !params.has(opt.key())) return &opt;
    return nullptr;
  }
  /// A value-initialised O (the struct's defaults) with the given keys read into it.
  O read(const ParameterMap& params) const {
    O o{};
    read_into(params, o);
    return o;
  }
  /// Checks a struct filled in code (not read from a file) by the same ranges, choices and rules.
  /// \throws ConfigError "<owner>: <key> = <value>: <rule>" for the first option that fails.
  void validate(const O& o, const std::string& owner) const { validate(o, ParameterMap(owner)); }
  /// validate() naming the keys as `none` does (ParameterMap::section("band"): "band.f_max_hz").
  void validate(const O& o, const ParameterMap& none) const {
    for (const auto& opt : m_options) opt.check_value(none, o);
    const OptionCheck<O> check(m_options, none, o);
    for (const auto& rule : m_rules) rule(o, check);
  }
  /// One ParameterDoc per option, in order, for ReducerInfo::parameters and the READMEs.
  std::vector<ParameterDoc> docs() const {
    std::vector<ParameterDoc> out;
    for (const auto& opt : m_options) out.push_back(opt.document());
    return out;
  }
  /// The keys, in order.
  std::vector<std::string> keys() const {
    std::vector<std::string> out;
    for (const auto& opt : m_options) out.push_back(opt.key());
    return out;
  }
  const std::vector<Option<O>>& options() const { return m_options; }
  const std::vector<Rule>& rules() const { return m_rules; }
  /// The option of `key`. \throws std::logic_error when there is none.
  const Option<O>& at(const std::string& key) const {
    for (const auto& opt : m_options)
      if (opt.key() == key) return opt;
    throw std::logic_error("no option '" + key + "'");
  }

 private:
  static std::vector<Option<O>> concat(std::vector<Option<O>> a, const std::vector<Option<O>>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
  }
  std::vector<Option<O>> m_options;
  std::vector<Rule> m_rules;
};

/// A Markdown table of documented options, | key | type | default | meaning |, one row per
/// option, for the READMEs (tests compare the READMEs' tables with it).
inline std::string markdown_table(const std::vector<ParameterDoc>& docs) {
  std::string t = "| key | type | default | meaning |\n|---|---|---|---|\n";
  for (const auto& d : docs) {
    std::string meaning = d.description;
    // A '|' inside a cell would end it.
    for (std::size_t at = meaning.find('|'); at != std::string::npos;
         at = meaning.find('|', at + 2))
      meaning.replace(at, 1, "\\|");
    t += "| `" + d.name + "` | " + d.type + " | `" + d.default_value + "` | " + meaning + " |\n";
  }
  return t;
}

}  // namespace ecmor
