// ParameterMap, edit distance and suggestions: conversions, ranges, and messages that name owner,
// key, location, value and rule.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/parameters.hpp"

using namespace ecmor;

namespace {

template <class F>
std::string config_error(F&& f) {
  return test::message_of<ConfigError>(std::forward<F>(f));
}

ParameterMap with(const std::string& key, ParameterValue::Storage value,
                  const std::string& location = "run.yaml:7") {
  ParameterMap map("reducer 'modal'");
  map.set(key, ParameterValue{std::move(value), location});
  return map;
}

// Textbook dynamic programme written independently of the implementation (full matrix, recursion
// on prefixes), to cross-check edit_distance on many pairs.
std::size_t reference_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i)
    for (std::size_t j = 1; j <= b.size(); ++j)
      d[i][j] = std::min(
          {d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] != b[j - 1] ? 1u : 0u)});
  return d[a.size()][b.size()];
}

}  // namespace

TEST(EditDistance, KnownValues) {
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(edit_distance("flaw", "lawn"), 2u);
  EXPECT_EQ(edit_distance("", "abc"), 3u);
  EXPECT_EQ(edit_distance("abc", ""), 3u);
  EXPECT_EQ(edit_distance("", ""), 0u);
  EXPECT_EQ(edit_distance("tolerance", "tolerance"), 0u);
  EXPECT_EQ(edit_distance("tolerence", "tolerance"), 1u);  // substitution
  EXPECT_EQ(edit_distance("max_ordr", "max_order"), 1u);   // insertion
  EXPECT_EQ(edit_distance("ab", "ba"), 2u);                // no transposition in Levenshtein
}

TEST(EditDistance, MatchesReferenceAndIsAMetric) {
  const std::vector<std::string> words = {
      "",       "a",         "ab",   "grid_points", "grid_pts", "pole_samples", "refine_peaks",
      "refine", "tolerance", "norm", "nrom"};
  for (const auto& a : words)
    for (const auto& b : words) {
      EXPECT_EQ(edit_distance(a, b), reference_distance(a, b)) << a << " / " << b;
      EXPECT_EQ(edit_distance(a, b), edit_distance(b, a));
      EXPECT_EQ(edit_distance(a, b) == 0, a == b);
      for (const auto& c : words)
        EXPECT_LE(edit_distance(a, c), edit_distance(a, b) + edit_distance(b, c));
    }
}

TEST(Nearest, PlausibleTyposOnly) {
  const std::vector<std::string> keys = {"tolerance", "norm", "max_order", "grid_points"};
  EXPECT_EQ(nearest("tolerence", keys), "tolerance");
  EXPECT_EQ(nearest("max_ordr", keys), "max_order");
  EXPECT_EQ(nearest("nrom", keys), "norm");  // short word: up to 2 edits
  EXPECT_EQ(nearest("colour", keys), "");
  EXPECT_EQ(nearest("anything", {}), "");
  // "ab" and "xy" are 2 edits apart but share nothing: not a typo.
  EXPECT_EQ(nearest("ab", {"xy"}), "");
  // Limit max(2, len/3): a 12-letter word tolerates 4 edits, not 5.
  EXPECT_EQ(nearest("abcdefghijkl", {"abcdefghWXYZ"}), "abcdefghWXYZ");
  EXPECT_EQ(nearest("abcdefghijkl", {"abcdefgVWXYZ"}), "");
  // The closest candidate wins, whatever the order.
  EXPECT_EQ(nearest("refine_peak", {"refine_evaluations", "refine_peaks"}), "refine_peaks");
}

TEST(Suggestion, DidYouMeanOrValidList) {
  EXPECT_EQ(suggestion("tolerence", {"tolerance", "norm"}), " (did you mean 'tolerance'?)");
  EXPECT_EQ(suggestion("colour", {"tolerance", "norm"}), " (valid: tolerance, norm)");
  EXPECT_EQ(suggestion("colour", {}), " (valid: none)");
}

TEST(ParameterMap, FallbacksWhenAbsent) {
  ParameterMap map("strategy 'grow_order'");
  EXPECT_FALSE(map.has("x"));
  EXPECT_EQ(map.location("x"), "");
  EXPECT_EQ(map.get_int("x", 7), 7);
  EXPECT_EQ(map.get_double("y", 2.5), 2.5);
  EXPECT_TRUE(map.get_bool("z", true));
  EXPECT_EQ(map.get_string("w", "hi"), "hi");
  EXPECT_EQ(map.get_doubles("v", {1.0, 2.0}), (std::vector<double>{1.0, 2.0}));
  EXPECT_NO_THROW(map.check_unused());
}

TEST(ParameterMap, SetAndReadBack) {
  ParameterMap map("reducer 'modal'");
  map.set("flag", true);
  map.set("count", 12);
  map.set("big", 1234567890123LL);
  map.set("shift", 0.25);
  map.set("method", "lanczos");
  map.set("name", std::string("x"));
  map.set("shifts", ParameterValue{std::vector<double>{1.0, 2.0}, "a.yaml:3"});
  EXPECT_EQ(map.keys(), (std::vector<std::string>{"big", "count", "flag", "method", "name", "shift",
                                                  "shifts"}));
  EXPECT_EQ(map.owner(), "reducer 'modal'");
  EXPECT_EQ(map.location("shifts"), "a.yaml:3");
  EXPECT_TRUE(map.get_bool("flag", false));
  EXPECT_EQ(map.get_int("count", 0), 12);
  EXPECT_EQ(map.get_int("big", 0), 1234567890123LL);
  EXPECT_EQ(map.get_double("shift", 0.0), 0.25);
  EXPECT_EQ(map.get_string("method", ""), "lanczos");
  EXPECT_EQ(map.get_string("name", ""), "x");
  EXPECT_EQ(map.get_doubles("shifts", {}), (std::vector<double>{1.0, 2.0}));
  EXPECT_NO_THROW(map.check_unused());
}

TEST(ParameterMap, NumericConversions) {
  // An integer where a double is expected is exact for |n| < 2^53.
  EXPECT_EQ(with("tol", 3LL).get_double("tol", 0.0), 3.0);
  // A double with an integral value is an integer (YAML users write 1e3 or 20.0).
  EXPECT_EQ(with("n", 1e3).get_int("n", 0), 1000);
  EXPECT_EQ(with("n", -20.0).get_int("n", 0), -20);
  // A single number reads as a list of one.
  EXPECT_EQ(with("s", 4LL).get_doubles("s", {}), std::vector<double>{4.0});
  EXPECT_EQ(with("s", 0.5).get_doubles("s", {}), std::vector<double>{0.5});
}

TEST(ParameterMap, RangeErrorsNameEverything) {
  EXPECT_EQ(config_error([] { with("batch_size", -3LL).get_int("batch_size", 1, 1); }),
            "run.yaml:7: reducer 'modal': batch_size = -3: must be >= 1");
  EXPECT_EQ(config_error([] { with("batch_size", 500LL).get_int("batch_size", 1, 1, 100); }),
            "run.yaml:7: reducer 'modal': batch_size = 500: must be <= 100");
  EXPECT_EQ(config_error([] { with("tol", 0.0).get_double("tol", 1.0, 1e-16, 1.0); }),
            "run.yaml:7: reducer 'modal': tol = 0: must be >= 1e-16");
  EXPECT_EQ(config_error([] { with("tol", 2.5).get_double("tol", 1.0, 0.0, 1.0); }),
            "run.yaml:7: reducer 'modal': tol = 2.5: must be <= 1");
  // Bounds inclusive.
  EXPECT_EQ(with("n", 1LL).get_int("n", 0, 1, 1), 1);
  EXPECT_EQ(with("x", 1.0).get_double("x", 0.0, 1.0, 1.0), 1.0);
  // Without a location (set programmatically) the message starts with the owner.
  ParameterMap map("reducer 'krylov'");
  map.set("order", -1);
  EXPECT_EQ(config_error([&] { map.get_int("order", 1, 0); }),
            "reducer 'krylov': order = -1: must be >= 0");
}

TEST(ParameterMap, TypeErrorsNameTheType) {
  EXPECT_EQ(config_error([] { with("n", 2.5).get_int("n", 0); }),
            "run.yaml:7: reducer 'modal': n = 2.5: must be an integer");
  EXPECT_EQ(config_error([] { with("n", std::string("ten")).get_int("n", 0); }),
            "run.yaml:7: reducer 'modal': n = 'ten': must be an integer, not a string");
  EXPECT_EQ(config_error([] { with("x", true).get_double("x", 0.0); }),
            "run.yaml:7: reducer 'modal': x = true: must be a number, not a boolean");
  EXPECT_EQ(config_error([] { with("b", 1LL).get_bool("b", false); }),
            "run.yaml:7: reducer 'modal': b = 1: must be true or false, not an integer");
  EXPECT_EQ(config_error([] { with("s", 3.5).get_string("s", ""); }),
            "run.yaml:7: reducer 'modal': s = 3.5: must be a string, not a number");
  EXPECT_EQ(config_error([] {
              with("v", std::vector<std::string>{"a", "b"}).get_doubles("v", {});
            }),
            "run.yaml:7: reducer 'modal': v = ['a', 'b']: must be a list of numbers, not a list "
            "of strings");
  EXPECT_EQ(config_error([] {
              with("n", std::vector<double>{1, 2}).get_int("n", 0);
            }),
            "run.yaml:7: reducer 'modal': n = [1, 2]: must be an integer, not a list of numbers");
  // An integral double beyond the range of long long cannot be converted.
  EXPECT_NE(config_error([] { with("n", 1e30).get_int("n", 0); }).find("must be an integer"),
            std::string::npos);
}

TEST(ParameterMap, NaNIsRejected) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(config_error([&] { with("x", nan).get_double("x", 0.0); }),
            "run.yaml:7: reducer 'modal': x = nan: must be a number, not NaN");
  EXPECT_NE(config_error([&] {
              with("v", std::vector<double>{1.0, nan}).get_doubles("v", {});
            }).find("must not contain NaN"),
            std::string::npos);
  EXPECT_NE(config_error([&] { with("n", nan).get_int("n", 0); }).find("must be an integer"),
            std::string::npos);
}

TEST(ParameterMap, ChoicesSuggestTheNearest) {
  const std::vector<std::string> choices = {"lanczos", "arnoldi", "block"};
  EXPECT_EQ(with("method", std::string("arnoldi")).get_string("method", "", choices), "arnoldi");
  EXPECT_EQ(config_error(
                [&] { with("method", std::string("arnoldy")).get_string("method", "", choices); }),
            "run.yaml:7: reducer 'modal': method = 'arnoldy': must be one of lanczos, arnoldi, "
            "block (did you mean 'arnoldi'?)");
  EXPECT_EQ(
      config_error([&] { with("method", std::string("qr")).get_string("method", "", choices); }),
      "run.yaml:7: reducer 'modal': method = 'qr': must be one of lanczos, arnoldi, block");
}

TEST(ParameterMap, CheckUnusedReportsEveryUnknownKeyWithSuggestion) {
  ParameterMap map("reducer 'modal'");
  map.set("max_ordr", ParameterValue{10LL, "run.yaml:9"});
  map.set("static_correction", ParameterValue{true, "run.yaml:8"});
  map.set("zzz", ParameterValue{1LL, "run.yaml:10"});
  map.get_int("max_order", 5);  // absent, but asked for: a known key to suggest
  map.get_bool("static_correction", false);
  EXPECT_EQ(config_error([&] { map.check_unused(); }),
            "run.yaml:9: unknown key 'max_ordr' in reducer 'modal' (did you mean 'max_order'?); "
            "run.yaml:10: unknown key 'zzz' in reducer 'modal' (valid: max_order, "
            "static_correction)");
}

TEST(ParameterMap, DeclareMarksKeysKnown) {
  ParameterMap map("strategy 'greedy'");
  map.set("handled_elsewhere", 1);
  EXPECT_THROW(map.check_unused(), ConfigError);
  map.declare({"handled_elsewhere"});
  EXPECT_NO_THROW(map.check_unused());
}

TEST(ParameterMap, UnknownKeyWithoutAnyKnownKeys) {
  ParameterMap map("reducer 'trivial'");
  map.set("order", 3);
  EXPECT_EQ(config_error([&] { map.check_unused(); }),
            "unknown key 'order' in reducer 'trivial' (valid: none)");
}
