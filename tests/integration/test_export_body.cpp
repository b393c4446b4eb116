// End to end: a clamped steel bar (bench/solid.hpp) with nodes.csv/dofs.csv -> `ecmor reduce`
// (modal) -> `ecmor export-body RUN --mass-model FREE` -> read_sid. The body read back has the
// bar's mass rho lx ly lz, centre l / 2 and inertia about the origin (derived in the test as in
// tests/interop/test_flexible_body.cpp; exact for the consistent mass of affine hexahedra up to
// rounding), the ROM's Mr and Kr as Me and Ke, and the input/output nodes as its frame. Without
// the mass model the clamped face's mass is missing and the command says so; a changed model
// and a model without nodes are refused by name, and so is a run of a model read from a .mat file.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../../bench/solid.hpp"
#include "../../bench/solid_geometry.hpp"
#include "common/mat_test_file.hpp"
#include "common/run_ecmor.hpp"
#include "ecmor/interop/fe_geometry.hpp"
#include "ecmor/interop/sid.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model_io.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

void write_solid(const fs::path& dir, const bench::SolidOptions& o) {
  const SecondOrderModel m = bench::solid(o);
  fs::create_directories(dir);
  write_matrix_market(dir / "M.mtx", m.M);
  write_matrix_market(dir / "D.mtx", m.D);
  write_matrix_market(dir / "K.mtx", m.K);
  write_matrix_market(dir / "B.mtx", Matrix(m.B));
  write_matrix_market(dir / "C.mtx", Matrix(m.C));
  write_fe_geometry(dir, bench::solid_geometry(o));
}

class ExportBody : public ::testing::Test {
 protected:
  void SetUp() override {
    m_dir = fs::temp_directory_path() / ("ecmor_export_body_" + std::to_string(::getpid()));
    fs::remove_all(m_dir);
    m_options.nx = 6;
    m_options.ny = 2;
    m_options.nz = 2;
    write_solid(m_dir / "clamped", m_options);
    bench::SolidOptions free = m_options;
    free.clamped = false;
    write_solid(m_dir / "free", free);
    std::ofstream(m_dir / "run.yaml") << "model:    {dir: " << (m_dir / "clamped").string() << "}\n"
                                      << "band:     {f_min_hz: 1.0, f_max_hz: 300.0}\n"
                                      << "target:   {tolerance: 1.0e-2}\n"
                                      << "reducer:  {name: modal}\n"
                                      << "strategy: {name: grow_order}\n"
                                      << "output:   {dir: " << (m_dir / "run").string() << "}\n";
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(m_dir);
  }

  test::CliResult run(const std::vector<std::string>& args) { return test::run_ecmor(args, m_dir); }

  fs::path m_dir;
  bench::SolidOptions m_options;
};

TEST_F(ExportBody, ReducedBarHasTheBarsMassInvariants) {
  const test::CliResult reduced = run({"reduce", (m_dir / "run.yaml").string(), "--no-plot", "-q"});
  ASSERT_EQ(reduced.exit_code, 0) << reduced.out << reduced.err;
  const fs::path run_dir = m_dir / "run";
  const test::CliResult r =
      run({"export-body", run_dir.string(), "--mass-model", (m_dir / "free").string()});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_EQ(r.err, "");  // no warning: the mass model is complete and W = V (modal)

  const SidBody body = read_sid(run_dir / "body.SID_FEM");
  const bench::SolidOptions& o = m_options;
  const double m = o.rho * o.lx * o.ly * o.lz;
  constexpr double kRounding = 1e-12;
  EXPECT_NEAR(body.mass, m, kRounding * m);
  const Eigen::Vector3d c(o.lx / 2, o.ly / 2, o.lz / 2);
  for (Index a = 0; a < 3; ++a) EXPECT_NEAR(body.mdCM.m0(a, 0), m * c(a), kRounding * m * o.lx);
  // J about the origin (xx, yy, zz, xy, xz, yz): m (l_b^2 + l_c^2) / 3 and -m l_a l_b / 4.
  const double J[6] = {m * (o.ly * o.ly + o.lz * o.lz) / 3,
                       m * (o.lx * o.lx + o.lz * o.lz) / 3,
                       m * (o.lx * o.lx + o.ly * o.ly) / 3,
                       -m * o.lx * o.ly / 4,
                       -m * o.lx * o.lz / 4,
                       -m * o.ly * o.lz / 4};
  for (Index k = 0; k < 6; ++k) EXPECT_NEAR(body.J.m0(k, 0), J[k], kRounding * J[2]) << k;

  nlohmann::json summary;
  std::ifstream(run_dir / "summary.json") >> summary;
  const Index n = summary.at("final_order").get<Index>();
  EXPECT_EQ(body.nq(), n);
  const ReducedModel rom = read_reduced_model(run_dir);
  const auto& rs = std::get<ReducedSecondOrderModel>(rom);
  EXPECT_LE((body.Me.m0 - rs.M).cwiseAbs().maxCoeff(), 1e-12 * rs.M.cwiseAbs().maxCoeff());
  EXPECT_LE((body.Ke.m0 - rs.K).cwiseAbs().maxCoeff(), 1e-12 * rs.K.cwiseAbs().maxCoeff());
  // Modal: Me, Ke diagonal, so each coordinate is named with its frequency.
  EXPECT_NE(body.ielastq[0].find(" Hz"), std::string::npos) << body.ielastq[0];
  // The frame: the nodes of the solid's inputs and outputs, at their positions.
  EXPECT_FALSE(body.frame.empty());
  const FeGeometry g = bench::solid_geometry(o);
  for (const SidNode& p : body.frame) {
    const auto it =
        std::find_if(g.nodes.begin(), g.nodes.end(), [&](const FeNode& q) { return q.id == p.id; });
    ASSERT_NE(it, g.nodes.end());
    EXPECT_EQ(p.origin.m0(0, 0), it->x);
    EXPECT_EQ(p.origin.m0(1, 0), it->y);
    EXPECT_EQ(p.origin.m0(2, 0), it->z);
  }
  // The JSON next to it holds both couplings.
  nlohmann::json j;
  std::ifstream(run_dir / "body.json") >> j;
  EXPECT_NEAR(j.at("mass").get<double>(), m, kRounding * m);
  EXPECT_EQ(j.at("Ct_v").size(), static_cast<std::size_t>(n));
  EXPECT_EQ(j.at("Ct_w"), j.at("Ct_v"));

  // Without the mass model the clamped face's mass is missing, and the command says so.
  const test::CliResult partial =
      run({"export-body", run_dir.string(), "-o", (m_dir / "p.SID_FEM").string()});
  ASSERT_EQ(partial.exit_code, 0) << partial.err;
  const Index face = 3 * (o.ny + 1) * (o.nz + 1);
  EXPECT_NE(partial.err.find("lacks " + std::to_string(face) + " translational DOFs"),
            std::string::npos)
      << partial.err;
  EXPECT_LT(read_sid(m_dir / "p.SID_FEM").mass, m * (1 - 1e-3));

  // A run whose Mr no longer matches its model directory is refused.
  write_matrix_market(run_dir / "Mr.mtx", Matrix(2.0 * rs.M));
  const test::CliResult changed = run({"export-body", run_dir.string()});
  EXPECT_EQ(changed.exit_code, 1);
  EXPECT_NE(changed.err.find("differ from the run's Mr, Dr, Kr"), std::string::npos) << changed.err;

  // A model directory without nodes.csv/dofs.csv cannot give mass invariants.
  fs::remove(m_dir / "clamped" / "nodes.csv");
  fs::remove(m_dir / "clamped" / "dofs.csv");
  const test::CliResult bare = run({"export-body", run_dir.string()});
  EXPECT_EQ(bare.exit_code, 1);
  EXPECT_NE(bare.err.find("no nodes.csv and dofs.csv"), std::string::npos) << bare.err;
}

// A free-floating bar reduced with modal (which keeps its six rigid-body modes) and written as
// .mat only: the body exported from it has the rigid-body motion in its frame, not in its
// coordinates (n = order - 6), its elastic coordinates are mean axes (C_t = 0), and the .mat copy
// holds the same numbers as the SID file and the JSON.
TEST_F(ExportBody, AFreeBodyHasOnlyElasticCoordinates) {
  std::ofstream(m_dir / "free.yaml")
      << "model:    {dir: " << (m_dir / "free").string() << "}\n"
      << "band:     {f_min_hz: 1.0, f_max_hz: 300.0}\n"
      << "target:   {tolerance: 1.0e-2}\n"
      << "reducer:  {name: modal}\n"
      << "strategy: {name: grow_order}\n"
      << "output:   {dir: " << (m_dir / "free_run").string() << ", format: mat}\n";
  const test::CliResult reduced =
      run({"reduce", (m_dir / "free.yaml").string(), "--no-plot", "-q"});
  ASSERT_EQ(reduced.exit_code, 0) << reduced.out << reduced.err;
  const fs::path run_dir = m_dir / "free_run";
  ASSERT_FALSE(fs::exists(run_dir / "V.mtx"));  // the bases come from reduced_model.mat
  const test::CliResult r = run({"export-body", run_dir.string()});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("6 rigid-body motions move the body frame"), std::string::npos) << r.out;

  nlohmann::json summary;
  std::ifstream(run_dir / "summary.json") >> summary;
  const Index order = summary.at("final_order").get<Index>();
  ASSERT_GT(order, 6);
  const SidBody body = read_sid(run_dir / "body.SID_FEM");
  EXPECT_EQ(body.nq(), order - 6);
  nlohmann::json j;
  std::ifstream(run_dir / "body.json") >> j;
  EXPECT_EQ(j.at("free_rigid_motions").get<Index>(), 6);
  EXPECT_EQ(j.at("removed_coordinates").get<Index>(), 6);

  const bench::SolidOptions& o = m_options;
  const double m = o.rho * o.lx * o.ly * o.lz;
  EXPECT_NEAR(body.mass, m, 1e-12 * m);
  // Mass-normalised elastic modes: Me = I; mean axes: C_t = 0 to rounding of sqrt(m).
  EXPECT_LT((body.Me.m0 - Matrix::Identity(order - 6, order - 6)).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(body.Ct.m0.cwiseAbs().maxCoeff(), 1e-9 * std::sqrt(m));
  // The elastic frequencies are the run's nonzero ones: Ke's diagonal is Kr's spectrum without
  // the six zeros (modal: Mr, Kr diagonal in its eigenvector coordinates).
  const ReducedModel rom = read_reduced_model(run_dir);
  const auto& rs = std::get<ReducedSecondOrderModel>(rom);
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> run_modes(rs.K, rs.M);
  for (Index k = 0; k < order - 6; ++k)
    EXPECT_NEAR(body.Ke.m0(k, k), run_modes.eigenvalues()(6 + k),
                1e-9 * run_modes.eigenvalues()(order - 1))
        << k;

  // The .mat copy: the numbers of the JSON (full precision) and the SID file.
  const fs::path mat = run_dir / "body.mat";
  ASSERT_TRUE(fs::exists(mat));
  EXPECT_EQ(test::mat_read_dense(mat, "mass")(0, 0), j.at("mass").get<double>());
  const Matrix Ke = test::mat_read_dense(mat, "Ke");
  ASSERT_EQ(Ke.rows(), order - 6);
  for (Index a = 0; a < Ke.rows(); ++a)
    for (Index b = 0; b < Ke.cols(); ++b)
      EXPECT_EQ(Ke(a, b),
                j.at("Ke")[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)].get<double>());
  const Matrix J1 = test::mat_read_dense(mat, "J1");  // 3 x 3n: reshape(J1, 3, 3, n) in MATLAB
  ASSERT_EQ(J1.cols(), 3 * (order - 6));
  for (Index k = 0; k < order - 6; ++k)
    for (Index a = 0; a < 3; ++a)
      for (Index b = 0; b < 3; ++b)
        EXPECT_EQ(J1(a, 3 * k + b),
                  j.at("J")
                      .at("a1")[static_cast<std::size_t>(k)][static_cast<std::size_t>(a)]
                               [static_cast<std::size_t>(b)]
                      .get<double>());
  EXPECT_EQ(test::mat_read_dense(mat, "T").rows(), order);
  EXPECT_EQ(test::mat_read_dense(mat, "frame_ids").rows(), static_cast<Index>(body.frame.size()));

  // A run directory without its bases (neither V.mtx nor reduced_model.mat) is refused by name.
  fs::remove(run_dir / "reduced_model.mat");
  const test::CliResult bare = run({"export-body", run_dir.string()});
  EXPECT_EQ(bare.exit_code, 1);
  EXPECT_NE(bare.err.find("no projection bases: neither V.mtx nor reduced_model.mat"),
            std::string::npos)
      << bare.err;
}

// A run whose model came from a .mat file has no node positions or DOF map: export-body refuses
// it by name (the run directory, the file, and what it needs), not with a JSON library message.
TEST_F(ExportBody, ARunOfAMatModelIsRefusedByName) {
  const fs::path mat = m_dir / "clamped.mat";
  {
    test::MatTestFile f(mat, MAT_FT_MAT5);
    f.model(load_model(m_dir / "clamped"));
  }
  std::ofstream(m_dir / "mat.yaml") << "model:    {file: " << mat.string() << "}\n"
                                    << "band:     {f_min_hz: 1.0, f_max_hz: 300.0}\n"
                                    << "target:   {tolerance: 1.0e-2}\n"
                                    << "reducer:  {name: modal}\n"
                                    << "strategy: {name: grow_order}\n"
                                    << "output:   {dir: " << (m_dir / "mat_run").string() << "}\n";
  const test::CliResult reduced = run({"reduce", (m_dir / "mat.yaml").string(), "--no-plot", "-q"});
  ASSERT_EQ(reduced.exit_code, 0) << reduced.out << reduced.err;
  const fs::path run_dir = m_dir / "mat_run";
  const test::CliResult r = run({"export-body", run_dir.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("run " + run_dir.string() + ": its model was read from the file " +
                       mat.string() + ", not from a model directory"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("export-body needs a model directory"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("nodes.csv and dofs.csv"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("json.exception"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace ecmor
