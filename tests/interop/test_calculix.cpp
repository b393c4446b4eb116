// The CalculiX import without ccx: the deck reader, the reader of ccx's stored matrices, the
// import YAML, nodes.csv/dofs.csv, and an import from hand-written matrix files (calculix.run:
// false). Every rule has a case whose message must name the file, the line and the rule.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "common/reject_case.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/interop/calculix.hpp"
#include "ecmor/interop/fe_geometry.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model_io.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;
using test::message_of;
using test::RejectCase;
using test::TempDir;
using test::write_raw;

// ---- the deck reader ---------------------------------------------------------------------------

TEST(CalculixDeck, ReadsNodesSetsIncludesAndSteps) {
  TempDir dir;
  fs::create_directories(dir / "mesh");
  write_raw(dir / "mesh" / "nodes.inp",
            "** nodes of the block\n*Node, nset=ALLN\n1, 0., 0., 0.\n2, 1.0, 0, 0\n3, 1, 2.5e-1\n"
            "4,0,1,+2\n5, 0.5\n");
  write_raw(dir / "deck.inp",
            "*HEADING\n test\n*INCLUDE, INPUT=mesh/nodes.inp\n"
            "*NSET, NSET=left\n1, 4,\n\n*nset,nset=LEFT\n4, 5\n"
            "*NSET, NSET=GEN, GENERATE\n1, 5, 2\n*NSET, NSET=BOTH\nLEFT, 2\n"
            "*ELEMENT, TYPE=C3D4, ELSET=E\n1, 1, 2, 3, 4\n"
            "*STEP\n*BOUNDARY\nLEFT, 1, 3\n*FREQUENCY, SOLVER=MatrixStorage\n1\n*END STEP\n");
  const CalculixDeck d = read_calculix_deck(dir / "deck.inp");
  ASSERT_EQ(d.nodes.size(), 5u);
  EXPECT_EQ(d.nodes[2].y, 0.25);
  EXPECT_EQ(d.nodes[2].z, 0.0) << "an omitted coordinate is 0";
  EXPECT_EQ(d.nodes[3].z, 2.0);
  EXPECT_EQ(d.nodes[4].x, 0.5);
  EXPECT_EQ(d.nsets.at("ALLN"), (std::vector<long long>{1, 2, 3, 4, 5}));
  EXPECT_EQ(d.nsets.at("LEFT"), (std::vector<long long>{1, 4, 5}))
      << "blocks append, each node once";
  EXPECT_EQ(d.nsets.at("GEN"), (std::vector<long long>{1, 3, 5}));
  EXPECT_EQ(d.nsets.at("BOTH"), (std::vector<long long>{1, 4, 5, 2}));
  ASSERT_EQ(d.steps.size(), 1u);
  EXPECT_EQ(d.steps[0].procedure, "*FREQUENCY");
  EXPECT_TRUE(d.steps[0].matrix_storage);
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "deck.inp: line 15", d.steps[0].location);
  // The flattened deck holds the included lines instead of the *INCLUDE card.
  std::string flat;
  for (const std::string& l : d.flattened) flat += l + "\n";
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "*Node, nset=ALLN\n1, 0., 0., 0.\n", flat);
  EXPECT_EQ(flat.find("*INCLUDE"), std::string::npos);
}

class CalculixDeckRejects : public ::testing::TestWithParam<RejectCase> {};

TEST_P(CalculixDeckRejects, NamingFileLineAndRule) {
  const RejectCase& c = GetParam();
  TempDir dir;
  write_raw(dir / "d.inp", c.first);
  const std::string msg = message_of<InputError>([&] { read_calculix_deck(dir / "d.inp"); });
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, c.expected, msg) << c.name;
}

INSTANTIATE_TEST_SUITE_P(
    Rules, CalculixDeckRejects,
    ::testing::Values(
        RejectCase{"data first", "1, 0, 0, 0\n", nullptr,
                   "d.inp: line 1: data line outside any keyword block"},
        RejectCase{"node id", "*NODE\nA, 0, 0, 0\n", nullptr,
                   "d.inp: line 2: *NODE: node id 'A' is not an integer"},
        RejectCase{"node negative", "*NODE\n-3, 0, 0, 0\n", nullptr,
                   "d.inp: line 2: *NODE: node id -3: must be > 0"},
        RejectCase{"coordinate", "*NODE\n1, 0, x, 0\n", nullptr,
                   "d.inp: line 2: *NODE 1: coordinate 'x' is not a finite number"},
        RejectCase{"fields", "*NODE\n1, 0, 0, 0, 0\n", nullptr,
                   "d.inp: line 2: *NODE: 5 fields: expected id, x[, y[, z]]"},
        RejectCase{"node twice", "*NODE\n1, 0, 0, 0\n*NODE\n1, 1, 0, 0\n", nullptr,
                   "d.inp: line 4: node 1 defined twice (first at "},
        RejectCase{"system", "*NODE, SYSTEM=C\n1, 0, 0, 0\n", nullptr,
                   "d.inp: line 1: *NODE: parameter SYSTEM is not supported"},
        RejectCase{"nset name", "*NSET\n1\n", nullptr, "d.inp: line 1: *NSET without NSET=name"},
        RejectCase{"undefined node", "*NODE\n1, 0, 0, 0\n*NSET, NSET=S\n1, 7\n", nullptr,
                   "d.inp: line 4: *NSET S: node 7 is not defined by any *NODE"},
        RejectCase{"unknown set", "*NODE\n1, 0, 0, 0\n*NSET, NSET=S\nT\n", nullptr,
                   "d.inp: line 4: *NSET S: 'T' is neither a node id nor a node set defined above"},
        RejectCase{"generate increment", "*NSET, NSET=S, GENERATE\n1, 5, 0\n", nullptr,
                   "d.inp: line 2: *NSET, GENERATE: increment '0': must be an integer > 0"},
        RejectCase{"generate order", "*NSET, NSET=S, GENERATE\n5, 1\n", nullptr,
                   "d.inp: line 2: *NSET, GENERATE: first 5 > last 1"},
        RejectCase{"generate fields", "*NSET, NSET=S, GENERATE\n1\n", nullptr,
                   "d.inp: line 2: *NSET, GENERATE: 1 fields"},
        RejectCase{"include input", "*INCLUDE\n", nullptr,
                   "d.inp: line 1: *INCLUDE without INPUT=file"},
        RejectCase{"include missing", "*INCLUDE, INPUT=nothere.inp\n", nullptr,
                   "d.inp: line 1: *INCLUDE, INPUT=nothere.inp: no such file"},
        RejectCase{"input on a card", "*BOUNDARY, INPUT=fix.bou\n", nullptr,
                   "d.inp: line 1: *BOUNDARY, INPUT=fix.bou: data from other files only through "
                   "*INCLUDE"},
        RejectCase{"include cycle", "*INCLUDE, INPUT=d.inp\n", nullptr, "nested more than 16 deep"},
        RejectCase{"open step", "*STEP\n*STATIC\n", nullptr,
                   "d.inp: line 1: *STEP without *END STEP"},
        RejectCase{"end step", "*END STEP\n", nullptr, "d.inp: line 1: *END STEP without *STEP"},
        RejectCase{"long line",
                   "*NODE\n1, 0.000000000000000000000000000000000000000000000000000000000000000000,"
                   " 0.0000000000000000000000000000000000000000000000000000000000000000000000\n",
                   nullptr, "d.inp: line 2: 145 columns: ccx reads at most 132 per line"}));

TEST(CalculixDeck, MissingFileIsAnInputError) {
  TempDir dir;
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "none.inp: CalculiX deck not found",
                      message_of<InputError>([&] { read_calculix_deck(dir / "none.inp"); }));
}

// ---- the matrices ccx stores ---------------------------------------------------------------

// A 3-dof system: node 1 directions 1 and 2, node 2 direction 1. K and M as ccx writes them.
constexpr const char* kSti =
    "1 1  4.0e+00\n1 2 -1.0e+00\n2 2  5.0e+00\n1 3  0.0e+00\n3 3  2.0e+00\n";
constexpr const char* kMas = "1 1  2.0e+00\n2 2  2.0e+00\n2 3  5.0e-01\n3 3  1.0e+00\n";
constexpr const char* kDof = "1.1\n1.2\n2.1\n";

void write_matrices(const fs::path& dir, const std::string& job, const char* sti = kSti,
                    const char* mas = kMas, const char* dof = kDof) {
  write_raw(dir / (job + ".sti"), sti);
  write_raw(dir / (job + ".mas"), mas);
  write_raw(dir / (job + ".dof"), dof);
}

TEST(CalculixMatrices, UpperTriangleExpandsToTheSymmetricMatrix) {
  TempDir dir;
  write_matrices(dir.path(), "j");
  const CalculixMatrices m = read_calculix_matrices(dir / "j.sti", dir / "j.mas", dir / "j.dof");
  Matrix K(3, 3), M(3, 3);
  K << 4, -1, 0, -1, 5, 0, 0, 0, 2;
  M << 2, 0, 0, 0, 2, 0.5, 0, 0.5, 1;
  EXPECT_EQ(Matrix(m.K), K);
  EXPECT_EQ(Matrix(m.M), M);
  EXPECT_EQ(m.K.nonZeros(), 5) << "the stored zero is dropped";
  ASSERT_EQ(m.dofs.size(), 3u);
  EXPECT_EQ(m.dofs[1].row, 2);
  EXPECT_EQ(m.dofs[1].node, 1);
  EXPECT_EQ(m.dofs[1].direction, 2);
  EXPECT_EQ(m.dofs[2].node, 2);
}

class CalculixMatricesReject : public ::testing::TestWithParam<RejectCase> {};

TEST_P(CalculixMatricesReject, NamingFileLineAndRule) {
  const RejectCase& c = GetParam();  // first: the .sti file, second: the .dof file
  TempDir dir;
  write_matrices(dir.path(), "j", c.first, kMas, c.second);
  const std::string msg = message_of<InputError>(
      [&] { read_calculix_matrices(dir / "j.sti", dir / "j.mas", dir / "j.dof"); });
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, c.expected, msg) << c.name;
}

INSTANTIATE_TEST_SUITE_P(
    Rules, CalculixMatricesReject,
    ::testing::Values(
        RejectCase{"lower", "1 1 1.0\n2 1 1.0\n", kDof,
                   "j.sti: line 2: entry (2, 1) below the diagonal"},
        RejectCase{"order", "1 2 1.0\n1 1 1.0\n", kDof, "j.sti: line 2: entry (1, 1) after (1, 2)"},
        RejectCase{"repeat", "1 1 1.0\n1 1 1.0\n", kDof,
                   "j.sti: line 2: entry (1, 1) after (1, 1)"},
        RejectCase{"range", "1 4 1.0\n", kDof, "j.sti: line 1: entry (1, 4) outside 1..N = 3"},
        RejectCase{"value", "1 1 nan\n", kDof, "j.sti: line 1: expected 'row column value'"},
        RejectCase{"fields", "1 1\n", kDof, "j.sti: line 1: expected 'row column value'"},
        RejectCase{"blank", "1 1 1.0\n\n2 2 1.0\n", kDof, "j.sti: line 2: blank line"},
        RejectCase{"thermal", kSti, "1.1\n1.0\n2.1\n",
                   "j.dof: line 2: '1.0': a thermal degree of freedom"},
        RejectCase{"direction", kSti, "1.1\n1.7\n2.1\n",
                   "j.dof: line 2: '1.7': direction 7: must be 1..6"},
        RejectCase{"dof syntax", kSti, "1.1\n12\n2.1\n",
                   "j.dof: line 2: '12': expected node.direction"},
        RejectCase{"empty", kSti, "", "j.dof: no degrees of freedom"}));

// ---- the import YAML -------------------------------------------------------------------------

constexpr const char* kYaml =
    "calculix: {deck: d.inp, run: false}\n"
    "inputs:\n  - {nset: LEFT, directions: [1, 2]}\n"
    "outputs:\n  - {nset: right, direction: 1}\n"
    "damping: {alpha: 0.5, beta: 1.0e-3}\n"
    "output: {dir: out}\n";

TEST(CalculixConfig, ParsesTheDocumentedShape) {
  const CalculixImportConfig c = parse_calculix_import_config(kYaml, "imp.yaml");
  EXPECT_FALSE(c.run);
  EXPECT_EQ(c.executable, "ccx");
  EXPECT_TRUE(c.deck.is_absolute());
  EXPECT_EQ(c.deck.filename(), "d.inp");
  ASSERT_EQ(c.inputs.size(), 1u);
  EXPECT_EQ(c.inputs[0].nset, "LEFT");
  EXPECT_EQ(c.inputs[0].directions, (std::vector<int>{1, 2}));
  EXPECT_EQ(c.outputs[0].directions, (std::vector<int>{1}));
  EXPECT_EQ(c.alpha, 0.5);
  EXPECT_EQ(c.beta, 1.0e-3);
  EXPECT_EQ(c.output_dir.filename(), "out");
}

std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  return s.replace(pos, from.size(), to);
}

TEST(CalculixConfig, RejectsNamingLineAndKey) {
  struct Edit {
    std::string from, to;  // kYaml with `from` replaced by `to` ...
    const char* expected;  // ... must fail with this in its message
  };
  const std::vector<Edit> edits = {
      {"deck:", "dek:", "imp.yaml:1: unknown key 'dek' in 'calculix' (did you mean 'deck'?)"},
      {"deck: d.inp, ", "", "imp.yaml:1: missing required key 'calculix.deck'"},
      {"[1, 2]", "[1, 7]", "imp.yaml:3: inputs[0].directions[1] = 7: must be an integer 1..6"},
      {"[1, 2]", "[2, 2]", "imp.yaml:3: inputs[0].directions: 2 given twice"},
      {"direction: 1}", "direction: 1, directions: [2]}",
       "imp.yaml:5: outputs[0]: give either 'direction' or 'directions'"},
      {"alpha: 0.5", "alpha: -0.5", "imp.yaml:6: damping.alpha = -0.5: must be >= 0"},
      {"beta: 1.0e-3", "beta: fast", "imp.yaml:6: damping.beta = 'fast': must be a finite number"},
      {", beta: 1.0e-3", "", "missing required key 'damping.beta'"},
      {"inputs:\n  - {nset: LEFT, directions: [1, 2]}", "inputs: []",
       "imp.yaml:2: 'inputs' must be a non-empty list"},
      {"run: false", "run: maybe", "imp.yaml:1: calculix.run = maybe: must be true or false"},
      {"output: {dir: out}\n", "output: {dir: out}\nextra: 1\n",
       "imp.yaml:8: unknown key 'extra' in the import configuration"}};
  for (const Edit& e : edits) {
    const std::string yaml = replaced(kYaml, e.from, e.to);
    EXPECT_PRED_FORMAT2(::testing::IsSubstring, e.expected, message_of<ConfigError>([&] {
                          parse_calculix_import_config(yaml, "imp.yaml");
                        }));
  }
}

// ---- an import from matrices ccx wrote (run: false) -------------------------------------------

// Nodes 1, 2 with the matrices above; node 3 exists in the deck but has no rows (as a node fixed
// by *BOUNDARY would).
constexpr const char* kDeck =
    "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 2, 0, 0\n"
    "*NSET, NSET=LEFT\n1\n*NSET, NSET=PAIR\n1, 2\n*NSET, NSET=FIXED\n2, 3\n";

CalculixImportConfig config_in(const TempDir& dir, const std::string& inputs,
                               const std::string& outputs) {
  const std::string yaml =
      "calculix: {deck: " + (dir / "d.inp").string() + ", run: false}\ninputs: " + inputs +
      "\noutputs: " + outputs +
      "\ndamping: {alpha: 0.5, beta: 0.25}\noutput: {dir: " + (dir / "model").string() + "}\n";
  return parse_calculix_import_config(yaml, "imp.yaml");
}

TEST(CalculixImport, WritesALoadableModelWithSpreadInputsAndMeanOutputs) {
  TempDir dir;
  write_raw(dir / "d.inp", kDeck);
  write_matrices(dir.path(), "d");
  const CalculixImportConfig c =
      config_in(dir, "[{nset: PAIR, directions: [1]}, {nset: left, direction: 2}]",
                "[{nset: PAIR, direction: 1}]");
  const CalculixImportSummary s = import_calculix(c);
  EXPECT_EQ(s.size, 3);
  EXPECT_EQ(s.inputs, 2);
  EXPECT_EQ(s.outputs, 1);
  EXPECT_EQ(s.input_labels[0], "PAIR direction 1 (2 nodes)");

  const Model model = load_model(dir / "model");  // ignores nodes.csv, dofs.csv
  const auto& m = std::get<SecondOrderModel>(model);
  // Rows: 1 = node 1 x, 2 = node 1 y, 3 = node 2 x.
  Matrix B(3, 2), C(1, 3);
  B << 0.5, 0.0, 0.0, 1.0, 0.5, 0.0;
  C << 0.5, 0.0, 0.5;
  EXPECT_EQ(m.B, B);
  EXPECT_EQ(m.C, C);
  EXPECT_EQ(Matrix(m.D), Matrix(0.5 * Matrix(m.M) + 0.25 * Matrix(m.K)));
  const auto g = read_fe_geometry(dir / "model", 3);
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->nodes.size(), 3u);
  EXPECT_EQ(g->dofs[2].node, 2);
  EXPECT_EQ(g->dofs[2].direction, 1);
}

TEST(CalculixImport, RejectsSetsAndDecksItCannotMap) {
  TempDir dir;
  write_raw(dir / "d.inp", kDeck);
  write_matrices(dir.path(), "d");
  EXPECT_PRED_FORMAT2(::testing::IsSubstring,
                      "imp.yaml:2: inputs[0]: nset 'LEFTT' is not a node set of",
                      message_of<ConfigError>([&] {
                        import_calculix(config_in(dir, "[{nset: LEFTT, direction: 1}]",
                                                  "[{nset: LEFT, direction: 1}]"));
                      }));
  EXPECT_PRED_FORMAT2(
      ::testing::IsSubstring, "(did you mean 'LEFT'?)", message_of<ConfigError>([&] {
        import_calculix(
            config_in(dir, "[{nset: LEFTT, direction: 1}]", "[{nset: LEFT, direction: 1}]"));
      }));
  // Node 3 has no rows, node 2 no direction 2.
  EXPECT_PRED_FORMAT2(::testing::IsSubstring,
                      "inputs[0]: node set FIXED direction 1: 1 of 2 nodes have no degree of "
                      "freedom 1 in the matrices (first: 3)",
                      message_of<InputError>([&] {
                        import_calculix(config_in(dir, "[{nset: FIXED, direction: 1}]",
                                                  "[{nset: LEFT, direction: 1}]"));
                      }));
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "outputs[0]: node set PAIR direction 2: 1 of 2 nodes",
                      message_of<InputError>([&] {
                        import_calculix(config_in(dir, "[{nset: LEFT, direction: 1}]",
                                                  "[{nset: PAIR, direction: 2}]"));
                      }));
}

TEST(CalculixImport, RejectsStepsOtherThanMatrixStorage) {
  TempDir dir;
  write_raw(dir / "d.inp", std::string(kDeck) + "*STEP\n*STATIC\n*END STEP\n");
  write_matrices(dir.path(), "d");
  EXPECT_PRED_FORMAT2(::testing::IsSubstring,
                      "d.inp: line 11: a *STEP with *STATIC: ecmor appends its own",
                      message_of<InputError>([&] {
                        import_calculix(config_in(dir, "[{nset: LEFT, direction: 1}]",
                                                  "[{nset: LEFT, direction: 1}]"));
                      }));
  write_raw(dir / "d.inp", std::string(kDeck) +
                               "*STEP\n*FREQUENCY,SOLVER=MATRIXSTORAGE\n1\n*END STEP\n"
                               "*STEP\n*FREQUENCY,SOLVER=MATRIXSTORAGE\n1\n*END STEP\n");
  write_matrices(dir.path(), "d");
  EXPECT_PRED_FORMAT2(
      ::testing::IsSubstring, "d.inp: line 15: a second *STEP", message_of<InputError>([&] {
        import_calculix(
            config_in(dir, "[{nset: LEFT, direction: 1}]", "[{nset: LEFT, direction: 1}]"));
      }));
}

TEST(CalculixImport, RejectsMatricesOlderThanTheDeckOrMissing) {
  TempDir dir;
  write_matrices(dir.path(), "d");
  write_raw(dir / "d.inp", kDeck);
  const auto old = fs::last_write_time(dir / "d.inp") - std::chrono::hours(1);
  fs::last_write_time(dir / "d.sti", old);
  const auto cfg = config_in(dir, "[{nset: LEFT, direction: 1}]", "[{nset: LEFT, direction: 1}]");
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "d.sti: older than the deck",
                      message_of<InputError>([&] { import_calculix(cfg); }));
  fs::remove(dir / "d.sti");
  EXPECT_PRED_FORMAT2(::testing::IsSubstring,
                      "d.sti: not found (calculix.run: false reads the matrices ccx wrote",
                      message_of<InputError>([&] { import_calculix(cfg); }));
}

}  // namespace
}  // namespace ecmor
