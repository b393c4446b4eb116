// nodes.csv and dofs.csv of a model directory (fe_geometry.hpp): the round trip, and one case
// per rule whose message must name the file, the line and the rule.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "common/reject_case.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/interop/fe_geometry.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;
using test::message_of;
using test::RejectCase;
using test::TempDir;
using test::write_raw;

FeGeometry two_nodes() {
  FeGeometry g;
  g.nodes = {{10, 0.0, 0.0, 0.0}, {20, 1.0, 0.5, -0.25}};
  g.dofs = {{1, 10, 1}, {2, 10, 3}, {3, 20, 2}};
  return g;
}

TEST(FeGeometry, RoundTripsAndIsOptional) {
  TempDir dir;
  EXPECT_FALSE(read_fe_geometry(dir.path(), 3).has_value());
  FeGeometry g = two_nodes();
  g.nodes[1].x = 0.1;  // not exact in binary: it must still come back bitwise
  write_fe_geometry(dir.path(), g);
  const auto back = read_fe_geometry(dir.path(), 3);
  ASSERT_TRUE(back.has_value());
  ASSERT_EQ(back->nodes.size(), 2u);
  EXPECT_EQ(back->nodes[1].x, 0.1);
  g.nodes[1].y = 1.0 / 3.0;  // 17 significant digits are needed here
  write_fe_geometry(dir.path(), g);
  EXPECT_EQ(read_fe_geometry(dir.path(), 3)->nodes[1].y, 1.0 / 3.0);
  EXPECT_EQ(back->nodes[1].z, -0.25);
  ASSERT_EQ(back->dofs.size(), 3u);
  EXPECT_EQ(back->dofs[2].node, 20);
  EXPECT_EQ(back->dofs[2].direction, 2);
}

TEST(FeGeometry, ReadSortsRowsGivenInAnyOrder) {
  TempDir dir;
  write_raw(dir / "nodes.csv", "node,x,y,z\n10,0,0,0\n20,1,0,0\n");
  write_raw(dir / "dofs.csv", "row,node,direction\n2,20,1\n1,10,1\n");
  const auto g = read_fe_geometry(dir.path(), 2);
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->dofs[0].node, 10);
  EXPECT_EQ(g->dofs[1].node, 20);
}

class FeGeometryRejects : public ::testing::TestWithParam<RejectCase> {};

TEST_P(FeGeometryRejects, NamingFileLineAndRule) {
  const RejectCase& c = GetParam();  // first: nodes.csv, second: dofs.csv
  TempDir dir;
  if (c.first != nullptr) write_raw(dir / "nodes.csv", c.first);
  if (c.second != nullptr) write_raw(dir / "dofs.csv", c.second);
  const std::string msg = message_of<InputError>([&] { read_fe_geometry(dir.path(), 2); });
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, c.expected, msg) << c.name;
}

constexpr const char* kNodes = "node,x,y,z\n1,0,0,0\n2,1,0,0\n";
constexpr const char* kDofs = "row,node,direction\n1,1,1\n2,2,1\n";

INSTANTIATE_TEST_SUITE_P(
    Rules, FeGeometryRejects,
    ::testing::Values(RejectCase{"nodes only", kNodes, nullptr, "nodes.csv without dofs.csv"},
                      RejectCase{"dofs only", nullptr, kDofs, "dofs.csv without nodes.csv"},
                      RejectCase{"header", "id,x,y,z\n1,0,0,0\n", kDofs,
                                 "nodes.csv: line 1: the header must be 'node,x,y,z'"},
                      RejectCase{"fields", "node,x,y,z\n1,0,0\n", kDofs,
                                 "nodes.csv: line 2: 3 fields, expected 4"},
                      RejectCase{"coordinate", "node,x,y,z\n1,0,nan,0\n2,0,0,0\n", kDofs,
                                 "nodes.csv: line 2: y 'nan' is not a finite number"},
                      RejectCase{"node id", "node,x,y,z\n1.5,0,0,0\n", kDofs,
                                 "nodes.csv: line 2: node '1.5' is not an integer"},
                      RejectCase{"node twice", "node,x,y,z\n1,0,0,0\n1,1,0,0\n", kDofs,
                                 "nodes.csv: line 3: node 1 given twice (first at line 2)"},
                      RejectCase{"node id zero", "node,x,y,z\n0,0,0,0\n", kDofs,
                                 "nodes.csv: line 2: node id 0: must be in 1..2^60"},
                      RejectCase{"blank line", "node,x,y,z\n1,0,0,0\n\n2,0,0,0\n", kDofs,
                                 "nodes.csv: line 3: blank line"},
                      RejectCase{"too few rows", kNodes, "row,node,direction\n1,1,1\n",
                                 "1 rows, but the model has N = 2"},
                      RejectCase{"row range", kNodes, "row,node,direction\n1,1,1\n3,2,1\n",
                                 "dofs.csv: line 3: row 3: must be in 1..N = 2"},
                      RejectCase{"row twice", kNodes, "row,node,direction\n1,1,1\n1,2,1\n",
                                 "dofs.csv: line 3: row 1 given twice (first at line 2)"},
                      RejectCase{"direction 0", kNodes, "row,node,direction\n1,1,0\n2,2,1\n",
                                 "dofs.csv: line 2: row 1: direction 0: must be 1..6"},
                      RejectCase{"direction 7", kNodes, "row,node,direction\n1,1,1\n2,2,7\n",
                                 "dofs.csv: line 3: row 2: direction 7: must be 1..6"},
                      RejectCase{"unknown node", kNodes, "row,node,direction\n1,1,1\n2,5,1\n",
                                 "dofs.csv: line 3: row 2: node 5 is not in"},
                      RejectCase{"pair twice", kNodes, "row,node,direction\n1,1,2\n2,1,2\n",
                                 "dofs.csv: line 3: row 2: node 1 direction 2 already has row 1"}));

TEST(FeGeometry, ValidateInMemoryNamesTheEntry) {
  FeGeometry g = two_nodes();
  g.dofs[1].row = 1;
  EXPECT_PRED_FORMAT2(::testing::IsSubstring,
                      "geom: dofs: entry 2: row 1 given twice (first at entry 1)",
                      message_of<InputError>([&] { validate(g, 3, "geom"); }));
  TempDir dir;
  EXPECT_PRED_FORMAT2(::testing::IsSubstring, "row 1 given twice",
                      message_of<InputError>([&] { write_fe_geometry(dir.path(), g); }));
  EXPECT_FALSE(fs::exists(dir / "nodes.csv")) << "nothing is written for invalid geometry";
}

}  // namespace
}  // namespace ecmor
