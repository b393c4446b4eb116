// The option tables of the plugin READMEs and docs/strategies.md are the tables the option specs
// generate (options.hpp), so the documentation cannot drift from the code; and every documented
// key, given its documented default, is accepted by create() / make_strategy(), so the keys the
// specs document are the keys the code reads.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/plugin_registry.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/strategies/strategy.hpp"
#include "greedy_points.hpp"
#include "grow_order.hpp"
#include "minimax_points.hpp"
#include "mixed_basis.hpp"
#include "optimize_points.hpp"
#include "point_objective.hpp"

namespace ecmor {
namespace {

std::string read_text(const std::string& relative) {
  std::ifstream in(std::string(ECMOR_TEST_SOURCE_DIR) + "/" + relative);
  EXPECT_TRUE(in.good()) << relative;
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The text between "<!-- options: <name> -->\n" and "<!-- options: end -->" in `file`.
std::string documented_table(const std::string& file, const std::string& name) {
  const std::string text = read_text(file);
  const std::string begin = "<!-- options: " + name + " -->\n";
  const std::size_t a = text.find(begin);
  if (a == std::string::npos) {
    ADD_FAILURE() << file << " has no '" << begin << "' marker";
    return {};
  }
  const std::size_t b = text.find("<!-- options: end -->", a);
  if (b == std::string::npos) {
    ADD_FAILURE() << file << ": the table '" << name << "' has no end marker";
    return {};
  }
  return text.substr(a + begin.size(), b - a - begin.size());
}

void expect_table(const std::string& file, const std::string& name,
                  const std::vector<ParameterDoc>& docs) {
  const std::string expected = markdown_table(docs);
  EXPECT_EQ(documented_table(file, name), expected)
      << file << ": the option table '" << name << "' differs from the specs; replace it with:\n"
      << expected;
}

const ParameterDoc* find_doc(const std::vector<ParameterDoc>& docs, const std::string& name) {
  for (const auto& d : docs)
    if (d.name == name) return &d;
  return nullptr;
}

/// The documented default as the value a YAML file would give.
ParameterValue::Storage default_value(const ParameterDoc& doc) {
  const std::string& text = doc.default_value;
  if (doc.type == "bool") return text == "true";
  if (doc.type == "int") return std::stoll(text);
  if (doc.type == "double") return std::stod(text);
  if (doc.type.rfind("list", 0) == 0) {
    std::vector<double> items;
    std::stringstream s(text.substr(1, text.size() - 2));
    std::string item;
    while (std::getline(s, item, ',')) items.push_back(std::stod(item));
    return items;
  }
  return text;
}

/// Each documented key alone, with its documented default, is read and accepted: no "unknown
/// key", no failed type or range rule. A key valid only in some mode may be refused as not
/// applying ("applies to ..."), which names the key too.
template <class Create>
void expect_documented_keys_read(const std::string& owner, const std::vector<ParameterDoc>& docs,
                                 Create create) {
  ASSERT_FALSE(docs.empty()) << owner;
  for (const auto& doc : docs) {
    ParameterMap p(owner);
    p.set(doc.name, ParameterValue{default_value(doc), "run.yaml:3"});
    try {
      create(p);
    } catch (const ConfigError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.find("unknown key"), std::string::npos) << doc.name << ": " << msg;
      EXPECT_EQ(msg.find("must be"), std::string::npos) << doc.name << ": " << msg;
      EXPECT_NE(msg.find(doc.name), std::string::npos) << doc.name << ": " << msg;
    }
  }
}

struct Plugin {
  const char* library;
  const char* reducer;
};
const Plugin kPlugins[] = {{"libecmor_modal.so", "modal"},
                           {"libecmor_krylov.so", "krylov"},
                           {"libecmor_balanced.so", "balanced"},
                           {"libecmor_irka.so", "irka"}};

std::vector<ParameterDoc> reducer_docs(const Plugin& plugin) {
  for (const auto& e : test::plugin_registry(plugin.library).entries())
    if (e.info.name == plugin.reducer) return e.info.parameters;
  throw std::runtime_error(std::string("no reducer ") + plugin.reducer);
}

TEST(OptionDocs, PluginReadmesPrintTheSpecs) {
  for (const Plugin& plugin : kPlugins) {
    expect_table(std::string("plugins/") + plugin.reducer + "/README.md", plugin.reducer,
                 reducer_docs(plugin));
  }
}

TEST(OptionDocs, StrategyGuidePrintsTheSpecs) {
  const std::string file = "docs/strategies.md";
  expect_table(file, "grow_order", GrowOrderOptions::specs().docs());
  expect_table(file, "greedy_points", GreedyPointsOptions::specs().docs());
  expect_table(file, "mixed_basis", MixedBasisOptions::specs().docs());
  const auto shared = point_search::PointSearchOptions::specs().docs();
  expect_table(file, "point_search", shared);
  // The point searches' own options; the shared ones have their table above.
  for (const auto& [name, docs] :
       {std::pair{"optimize_points", OptimizePointsOptions::specs().docs()},
        std::pair{"minimax_points", MinimaxPointsOptions::specs().docs()}}) {
    std::vector<ParameterDoc> own;
    for (const auto& d : docs)
      if (find_doc(shared, d.name) == nullptr) own.push_back(d);
    EXPECT_EQ(own.size() + shared.size(), docs.size()) << name;
    expect_table(file, name, own);
  }
  expect_table(file, "portfolio", run_strategy_options("portfolio"));
}

std::string replace_first(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  if (at == std::string::npos) throw std::logic_error("replace_first: '" + from + "' not found");
  return text.replace(at, from.size(), to);
}

// Every section of the configuration is read through option specs: its table in the user guide
// is the specs' documentation, and every key has a meaning.
TEST(OptionDocs, UserGuidePrintsEverySectionsSpecs) {
  ASSERT_EQ(option_section_names(),
            (std::vector<std::string>{"model", "band", "target", "reducer", "strategy", "error",
                                      "solver", "backend", "output", "check"}));
  for (const std::string& section : option_section_names()) {
    const auto docs = section_options(section);
    ASSERT_FALSE(docs.empty()) << section;
    expect_table("docs/user-guide.md", section, docs);
    for (const auto& doc : docs)
      EXPECT_FALSE(doc.description.empty()) << section << "." << doc.name;
  }
  expect_table("docs/user-guide.md", "top-level", top_level_options());
  EXPECT_THROW(section_options("compress"), std::invalid_argument);
}

// The reader knows no key without a spec: in every section whose keys are all its own (all but
// reducer and strategy, whose other keys are the plugin's options) and at the top level, a key
// outside the specs is refused; and each documented key of the optional sections, given its
// documented default, is read.
TEST(OptionDocs, TheReaderKnowsExactlyTheDocumentedKeys) {
  const std::string head =
      "model: {dir: m}\nband: {f_min_hz: 1, f_max_hz: 10}\ntarget: {tolerance: 1.0e-3}\n"
      "reducer: {name: modal}\noutput: {dir: o}\n";
  const std::vector<std::string> in_head = {"model", "band", "target", "reducer", "output"};
  for (const std::string& section : option_section_names()) {
    if (section == "reducer" || section == "strategy") continue;
    const bool given = std::find(in_head.begin(), in_head.end(), section) != in_head.end();
    const std::string yaml = given ? replace_first(head, section + ": {", section + ": {extra: 1, ")
                                   : head + section + ": {extra: 1}\n";
    try {
      parse_run_config(yaml, "run.yaml");
      ADD_FAILURE() << section << " accepts a key without a spec";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("unknown key 'extra' in '" + section + "'"),
                std::string::npos)
          << e.what();
    }
    if (given) continue;
    for (const auto& doc : section_options(section)) {
      EXPECT_NO_THROW(parse_run_config(
          head + section + ":\n  " + doc.name + ": " + doc.default_value + "\n", "run.yaml"))
          << section << "." << doc.name;
    }
  }
  EXPECT_THROW(parse_run_config(head + "extra: 1\n", "run.yaml"), ConfigError);
  for (const auto& doc : top_level_options())
    EXPECT_NO_THROW(parse_run_config(head + doc.name + ": " + doc.default_value + "\n", "run.yaml"))
        << doc.name;
}

TEST(OptionDocs, EveryDocumentedReducerKeyIsRead) {
  for (const Plugin& plugin : kPlugins) {
    Registry& registry = test::plugin_registry(plugin.library);
    expect_documented_keys_read(std::string("reducer '") + plugin.reducer + "'",
                                reducer_docs(plugin),
                                [&](const ParameterMap& p) { registry.create(plugin.reducer, p); });
  }
}

TEST(OptionDocs, EveryDocumentedStrategyKeyIsRead) {
  for (const auto& name : strategy_names()) {
    expect_documented_keys_read("strategy '" + name + "'", strategy_parameters(name),
                                [&](const ParameterMap& p) { make_strategy(name, p); });
  }
}

TEST(OptionDocs, EveryDocumentedPortfolioKeyIsRead) {
  const std::string head =
      "model: {dir: m}\nband: {f_min_hz: 1, f_max_hz: 10}\ntarget: {tolerance: 1.0e-3}\n"
      "output: {dir: o}\nstrategy:\n  name: portfolio\n";
  const auto docs = run_strategy_options("portfolio");
  ASSERT_FALSE(docs.empty());
  for (const auto& doc : docs) {
    // `members` (a list of mappings) has no value to write for its default, the absence of the
    // key; test_config reads members in every shape.
    if (doc.type == "list of mapping") continue;
    EXPECT_NO_THROW(
        parse_run_config(head + "  " + doc.name + ": " + doc.default_value + "\n", "run.yaml"))
        << doc.name;
  }
}

TEST(OptionDocs, UndocumentedKeysAreRefused) {
  // The check above is not vacuous: a key no spec documents is refused by name.
  ParameterMap p("reducer 'modal'");
  p.set("batch_sise", 10);
  const std::string msg = test::message_of<ConfigError>(
      [&] { test::plugin_registry("libecmor_modal.so").create("modal", p); });
  EXPECT_NE(msg.find("unknown key 'batch_sise'"), std::string::npos) << msg;
  ParameterMap q("strategy 'grow_order'");
  q.set("max_ordr", 10);
  EXPECT_NE(test::message_of<ConfigError>([&] {
              make_strategy("grow_order", q);
            }).find("did you mean 'max_order'"),
            std::string::npos);
}

}  // namespace
}  // namespace ecmor
