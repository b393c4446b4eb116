// Option specs (options.hpp): one list reads, validates and documents a struct's options. Each
// check is shown to fail with a message naming owner, location, key, value and rule; defaults
// come from the struct's member initialisers.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"

using namespace ecmor;

namespace {

enum class Mode { Fast, Careful };

struct Inner {
  long long budget = 7;
  long long start = 2;
};

struct Settings {
  long long count = 20;
  double ratio = 0.5;
  double step_hz = 1e-5;
  bool shrink = true;
  Mode mode = Mode::Careful;
  bool two_sided = false;
  std::vector<double> points_hz;
  std::vector<double> moments{1.0};
  double slack = 0.0;
  bool slack_given = false;
  Inner inner;
};

OptionSpecs<Inner> inner_specs() {
  return OptionSpecs<Inner>(
      {option("budget", &Inner::budget, "largest value").range(Range::at_least(1)),
       option("start", &Inner::start, "first value").range(Range::at_least(1))},
      {[](const Inner& o, const OptionCheck<Inner>& c) {
        if (o.budget < o.start) {
          c.fail(o.budget, "must be >= " + c.key(o.start) + " = " + std::to_string(o.start));
        }
      }});
}

OptionSpecs<Settings> specs() {
  OptionSpecs<Settings> s(
      {option("count", &Settings::count, "items per batch").range(Range::closed(1, 100000)),
       option("ratio", &Settings::ratio, "decrease factor").range(Range::open_closed(0, 1)),
       option("step_hz", &Settings::step_hz, "step").unit("Hz").range(Range::above(0).finite()),
       option("shrink", &Settings::shrink, "bisect afterwards"),
       choice("mode", &Settings::mode, {{"fast", Mode::Fast}, {"careful", Mode::Careful}},
              "speed or care"),
       choice("projection", &Settings::two_sided, {{"one_sided", false}, {"two_sided", true}},
              "bases"),
       option("points", &Settings::points_hz, "points").unit("Hz").range(Range::above(0).finite()),
       option("moments", &Settings::moments, "moments per point")
           .integers()
           .range(Range::closed(1, 1e6)),
       option("slack", &Settings::slack, "extra room")
           .range(Range::closed_open(0, 1))
           .given(&Settings::slack_given)
           .only_if([](const Settings& o) { return o.mode == Mode::Careful; },
                    "applies to mode: careful only")},
      {[](const Settings& o, const OptionCheck<Settings>& c) {
        if (o.moments.size() > 1 && o.moments.size() != o.points_hz.size()) {
          c.fail(o.moments, "give one per point or one for all");
        }
      }});
  s.include(&Settings::inner, inner_specs());
  return s;
}

ParameterMap with(const std::string& key, ParameterValue::Storage value) {
  ParameterMap map("reducer 'demo'");
  map.set(key, ParameterValue{std::move(value), "run.yaml:7"});
  return map;
}

std::string error_of(const ParameterMap& map) {
  return test::message_of<ConfigError>([&] { specs().read(map); });
}

void expect_error(const std::string& key, ParameterValue::Storage value, const std::string& what) {
  const std::string msg = error_of(with(key, std::move(value)));
  EXPECT_EQ(msg.rfind("run.yaml:7: reducer 'demo': ", 0), 0u) << msg;
  EXPECT_NE(msg.find(what), std::string::npos) << key << ": " << msg;
}

TEST(Options, DefaultsComeFromTheStruct) {
  const Settings read = specs().read(ParameterMap("reducer 'demo'"));
  const Settings defaults;
  EXPECT_EQ(read.count, defaults.count);
  EXPECT_EQ(read.ratio, defaults.ratio);
  EXPECT_EQ(read.mode, defaults.mode);
  EXPECT_EQ(read.moments, defaults.moments);
  EXPECT_FALSE(read.slack_given);
  EXPECT_EQ(read.inner.budget, 7);
  // The documented defaults are the member initialisers, as text.
  const std::vector<ParameterDoc> docs = specs().docs();
  ASSERT_EQ(docs.size(), 11u);
  auto doc = [&](const std::string& key) {
    for (const auto& d : docs)
      if (d.name == key) return d;
    ADD_FAILURE() << key;
    return ParameterDoc{};
  };
  EXPECT_EQ(doc("count").default_value, "20");
  EXPECT_EQ(doc("ratio").default_value, "0.5");
  EXPECT_EQ(doc("step_hz").default_value, "1e-05");
  EXPECT_EQ(doc("shrink").default_value, "true");
  EXPECT_EQ(doc("mode").default_value, "careful");
  EXPECT_EQ(doc("projection").default_value, "one_sided");
  EXPECT_EQ(doc("points").default_value, "[]");
  EXPECT_EQ(doc("moments").default_value, "[1]");
  EXPECT_EQ(doc("budget").default_value, "7");
  EXPECT_EQ(doc("moments").type, "list of int");
  // Range, unit and condition are part of the text.
  EXPECT_EQ(doc("count").description, "items per batch; valid: in [1, 100000]");
  EXPECT_EQ(doc("step_hz").description, "step; unit: Hz; valid: > 0 and finite");
  EXPECT_EQ(doc("mode").description, "speed or care; valid: one of fast, careful");
  EXPECT_EQ(doc("slack").description,
            "extra room; applies to mode: careful only; valid: in [0, 1)");
  EXPECT_EQ(doc("moments").description, "moments per point; valid: integers in [1, 1000000]");
  EXPECT_EQ(specs().keys(),
            (std::vector<std::string>{"count", "ratio", "step_hz", "shrink", "mode", "projection",
                                      "points", "moments", "slack", "budget", "start"}));
}

TEST(Options, ReadsGivenValues) {
  ParameterMap map("reducer 'demo'");
  map.set("count", 3);
  map.set("ratio", 1.0);  // the closed end of (0, 1]
  map.set("mode", "fast");
  map.set("projection", "two_sided");
  map.set("shrink", false);
  map.set("points", ParameterValue{std::vector<double>{10.0, 20.0}, {}});
  map.set("moments", ParameterValue{std::vector<double>{2.0, 3.0}, {}});
  map.set("budget", 9);
  const Settings o = specs().read(map);
  EXPECT_EQ(o.count, 3);
  EXPECT_EQ(o.ratio, 1.0);
  EXPECT_EQ(o.mode, Mode::Fast);
  EXPECT_TRUE(o.two_sided);
  EXPECT_FALSE(o.shrink);
  EXPECT_EQ(o.points_hz, (std::vector<double>{10.0, 20.0}));
  EXPECT_EQ(o.moments, (std::vector<double>{2.0, 3.0}));
  EXPECT_EQ(o.inner.budget, 9);
  EXPECT_NO_THROW(map.check_unused());  // every key was read
}

TEST(Options, RangesFail) {
  expect_error("count", 0LL, "count = 0: must be in [1, 100000]");
  expect_error("count", 100001LL, "count = 100001: must be in [1, 100000]");
  expect_error("ratio", 0.0, "ratio = 0: must be in (0, 1]");  // open end
  expect_error("ratio", 1.5, "ratio = 1.5: must be in (0, 1]");
  expect_error("step_hz", std::numeric_limits<double>::infinity(),
               "step_hz = inf: must be > 0 and finite");
  expect_error("step_hz", -1e-3, "step_hz = -0.001: must be > 0 and finite");
  expect_error("slack", 1.0, "slack = 1: must be in [0, 1)");
  expect_error("points", std::vector<double>{1.0, -2.0}, "points[1] = -2: must be > 0 and finite");
  expect_error("moments", std::vector<double>{1.0, 2.5}, "moments[1] = 2.5: must be an integer");
  expect_error("moments", std::vector<double>{0.0}, "moments[0] = 0: must be an integer in [1, ");
  expect_error("budget", 0LL, "budget = 0: must be >= 1");  // in a nested struct
}

TEST(Options, TypesFail) {
  expect_error("count", 2.5, "count = 2.5: must be an integer");
  expect_error("count", std::string("many"), "count = 'many': must be an integer, not a string");
  expect_error("ratio", std::string("half"), "ratio = 'half': must be a number");
  expect_error("ratio", std::nan(""), "must be a number, not NaN");
  expect_error("shrink", 1LL, "shrink = 1: must be true or false");
  expect_error("points", std::string("centre"), "points = 'centre': must be a list of numbers");
  expect_error("mode", 3LL, "mode = 3: must be a string");
}

TEST(Options, ChoicesFailWithASuggestion) {
  expect_error("mode", std::string("carefull"),
               "mode = 'carefull': must be one of fast, careful (did you mean 'careful'?)");
  expect_error("projection", std::string("both"), "must be one of one_sided, two_sided");
}

TEST(Options, UnknownKeysAreSuggested) {
  ParameterMap map = with("cuont", 3LL);
  specs().read(map);
  const std::string msg = test::message_of<ConfigError>([&] { map.check_unused(); });
  EXPECT_NE(msg.find("run.yaml:7: unknown key 'cuont' in reducer 'demo' (did you mean 'count'?)"),
            std::string::npos)
      << msg;
}

TEST(Options, ConditionsAndGivenFlags) {
  ParameterMap map = with("slack", 0.25);
  EXPECT_TRUE(specs().read(map).slack_given);
  map.set("mode", "fast");
  const std::string msg = error_of(map);
  EXPECT_NE(msg.find("run.yaml:7: reducer 'demo': slack = 0.25: applies to mode: careful only"),
            std::string::npos)
      << msg;
}

TEST(Options, RulesNameTheKeyOfAField) {
  ParameterMap map = with("start", 9LL);
  // budget was not given: the message shows its default, with start's location.
  EXPECT_NE(error_of(map).find("budget = 7: must be >= start = 9"), std::string::npos)
      << error_of(map);
  ParameterMap lists("reducer 'demo'");
  lists.set("points", ParameterValue{std::vector<double>{1.0, 2.0}, {}});
  lists.set("moments", ParameterValue{std::vector<double>{1.0, 2.0, 3.0}, "run.yaml:9"});
  EXPECT_NE(error_of(lists).find(
                "run.yaml:9: reducer 'demo': moments = [1, 2, 3]: give one per point or one"),
            std::string::npos)
      << error_of(lists);
}

// A struct filled in code (the C++ and Python APIs) is checked by the same ranges, choices and
// rules as one read from a file: each rule stated once.
TEST(Options, ValidateChecksAStructFilledInCode) {
  EXPECT_NO_THROW(specs().validate(Settings{}, "Settings"));
  auto validate_error = [](auto change) {
    Settings o;
    change(o);
    return test::message_of<ConfigError>([&] { specs().validate(o, "Settings"); });
  };
  EXPECT_EQ(validate_error([](Settings& o) { o.count = 0; }),
            "Settings: count = 0: must be in [1, 100000]");
  EXPECT_EQ(validate_error([](Settings& o) { o.ratio = std::nan(""); }),
            "Settings: ratio = nan: must be in (0, 1]");
  EXPECT_EQ(validate_error([](Settings& o) {
              o.points_hz = {1.0, -2.0};
            }),
            "Settings: points[1] = -2: must be > 0 and finite");
  EXPECT_EQ(validate_error([](Settings& o) { o.moments = {1.5}; }),
            "Settings: moments[0] = 1.5: must be an integer in [1, 1000000]");
  EXPECT_EQ(validate_error([](Settings& o) { o.mode = static_cast<Mode>(7); }),
            "Settings: mode = a value without a name: must be one of fast, careful");
  EXPECT_EQ(validate_error([](Settings& o) { o.inner.budget = 0; }),
            "Settings: budget = 0: must be >= 1");  // nested
  EXPECT_EQ(validate_error([](Settings& o) { o.inner.start = 9; }),
            "Settings: budget = 7: must be >= start = 9");  // a rule between fields
  EXPECT_EQ(validate_error([](Settings& o) {
              o.points_hz = {1.0, 2.0};
              o.moments = {1.0, 2.0, 3.0};
            }),
            "Settings: moments = [1, 2, 3]: give one per point or one for all");
}

TEST(Options, AKeyStatedTwiceIsAProgrammingError) {
  EXPECT_THROW(OptionSpecs<Inner>(
                   {option("budget", &Inner::budget, "a"), option("budget", &Inner::start, "b")}),
               std::logic_error);
  OptionSpecs<Settings> s({option("budget", &Settings::count, "clashes with inner's budget")});
  EXPECT_THROW(s.include(&Settings::inner, inner_specs()), std::logic_error);
}

// An inner struct's option offered under a prefixed key (the balanced plugin's adi_* keys from
// AdiOptions::specs()): reading, conditions, messages and documentation use the prefixed key, the
// range and documentation are the inner spec's.
TEST(Options, APrefixedOptionKeepsItsRuleUnderTheNewKey) {
  const OptionSpecs<Inner> inner = inner_specs();
  const Option<Inner>& budget = inner.options().front();
  auto careful = [](const Settings& o) { return o.mode == Mode::Careful; };
  const OptionSpecs<Settings> s({
      choice("mode", &Settings::mode, {{"fast", Mode::Fast}, {"careful", Mode::Careful}}, "mode"),
      budget.prefixed("inner_")
          .nested(&Settings::inner)
          .only_if(careful, "applies to mode: careful only"),
  });
  EXPECT_EQ(s.keys(), (std::vector<std::string>{"mode", "inner_budget"}));
  EXPECT_EQ(s.docs().back().description,
            "largest value; applies to mode: careful only; valid: >= 1");
  ParameterMap map = with("inner_budget", 9LL);
  EXPECT_EQ(s.read(map).inner.budget, 9);
  EXPECT_NE(test::message_of<ConfigError>([&] {
              s.read(with("inner_budget", 0LL));
            }).find("run.yaml:7: reducer 'demo': inner_budget = 0: must be >= 1"),
            std::string::npos);
  map.set("mode", "fast");
  EXPECT_NE(test::message_of<ConfigError>([&] {
              s.read(map);
            }).find("inner_budget = 9: applies to mode: careful only"),
            std::string::npos);
  Settings o;
  o.inner.budget = -1;
  EXPECT_EQ(test::message_of<ConfigError>([&] { s.validate(o, "Settings"); }),
            "Settings: inner_budget = -1: must be >= 1");
  EXPECT_EQ(budget.key(), "budget");  // the inner spec is unchanged
}

TEST(Options, NumbersPrintAsFmtDoes) {
  EXPECT_EQ(option_number(100000), "100000");
  EXPECT_EQ(option_number(0.01), "0.01");
  EXPECT_EQ(option_number(1e-10), "1e-10");
  EXPECT_EQ(option_number(0.999999), "0.999999");
  EXPECT_EQ(option_number(-2.5), "-2.5");
  EXPECT_EQ(option_number(1e300), "1e+300");
  EXPECT_EQ(Range::any().text(), "");
  EXPECT_EQ(Range::at_least(0).text(), ">= 0");
  EXPECT_EQ(Range::any().finite().text(), "finite");
}

TEST(Options, MarkdownTableEscapesBars) {
  const std::string t = markdown_table({{"norm", "string", "fro", "a | b"}});
  EXPECT_EQ(t,
            "| key | type | default | meaning |\n|---|---|---|---|\n"
            "| `norm` | string | `fro` | a \\| b |\n");
}

}  // namespace
