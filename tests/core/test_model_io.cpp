// Tests of model loading, validation, definiteness checks, summaries and reduced-model files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/bitwise_equal.hpp"
#include "common/builders.hpp"
#include "common/gzip_text.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/model/model_io.hpp"

namespace fs = std::filesystem;
using namespace ecmor;

namespace {

using ecmor::test::sparse;

const fs::path kModels = fs::path(ECMOR_TEST_SOURCE_DIR) / "models";

using test::bitwise_equal;
using test::TempDir;
using test::write_raw;

/// Symmetric positive definite tridiagonal n x n (1D Dirichlet Laplacian).
SparseMatrix laplacian(Index n, bool neumann = false) {
  std::vector<Eigen::Triplet<double, int>> t;
  for (int i = 0; i < n; ++i) {
    double d = 2.0;
    if (neumann && (i == 0 || i == n - 1)) d = 1.0;
    t.emplace_back(i, i, d);
    if (i + 1 < n) {
      t.emplace_back(i, i + 1, -1.0);
      t.emplace_back(i + 1, i, -1.0);
    }
  }
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

SecondOrderModel small_second_order(Index n = 4, Index m = 1, Index p = 1) {
  SecondOrderModel s;
  s.M = sparse(Matrix::Identity(n, n));
  s.D = 0.1 * laplacian(n);
  s.K = laplacian(n);
  s.B = Matrix::Ones(n, m);
  s.C = Matrix::Ones(p, n);
  return s;
}

DescriptorModel small_descriptor(Index n = 4, Index m = 1, Index p = 1) {
  DescriptorModel d;
  d.E = sparse(Matrix::Identity(n, n));
  d.A = -laplacian(n);
  d.B = Matrix::Ones(n, m);
  d.C = Matrix::Ones(p, n);
  return d;
}

/// Writes the files of a second-order model (M K B C, D unless skipped) to dir.
void write_model_files(const fs::path& dir, const SecondOrderModel& s, bool with_d = true) {
  write_matrix_market(dir / "M.mtx", s.M);
  if (with_d) write_matrix_market(dir / "D.mtx", s.D);
  write_matrix_market(dir / "K.mtx", s.K);
  write_matrix_market(dir / "B.mtx", sparse(s.B));  // coordinate, as in the benchmark models
  write_matrix_market(dir / "C.mtx", sparse(s.C));
  if (s.has_velocity_output()) write_matrix_market(dir / "Cv.mtx", s.Cv);
}

void write_model_files(const fs::path& dir, const DescriptorModel& d, bool with_e = true) {
  if (with_e) write_matrix_market(dir / "E.mtx", d.E);
  write_matrix_market(dir / "A.mtx", d.A);
  write_matrix_market(dir / "B.mtx", d.B);  // array format works as well
  write_matrix_market(dir / "C.mtx", sparse(d.C));
}

/// Expects `f` to throw InputError whose message contains every one of `parts`.
template <class F>
void expect_input_error(F&& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    for (const std::string& part : parts)
      EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
  }
}

const MatrixSummary* find_summary(const ModelSummary& s, const std::string& name) {
  for (const MatrixSummary& m : s.matrices)
    if (m.name == name) return &m;
  return nullptr;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The benchmark models
// ---------------------------------------------------------------------------------------------

TEST(SharedModels, EveryModelLoadsAndMatchesItsInfoJson) {
  ASSERT_TRUE(fs::is_directory(kModels)) << kModels << " is missing";
  std::vector<fs::path> dirs;
  for (const auto& e : fs::directory_iterator(kModels))
    if (e.is_directory()) dirs.push_back(e.path());
  std::sort(dirs.begin(), dirs.end());
  ASSERT_EQ(dirs.size(), 22u) << "the benchmark models of models/README.md";
  for (const fs::path& dir : dirs) {
    SCOPED_TRACE(dir.string());
    Model model;
    ASSERT_NO_THROW(model = load_model(dir));
    EXPECT_NO_THROW(validate(model, dir.string()));
    const fs::path info_path = dir / "info.json";
    ASSERT_TRUE(fs::exists(info_path)) << "each model carries its info.json";
    std::ifstream in(info_path);
    const nlohmann::json info = nlohmann::json::parse(in);
    if (info.contains("N")) {
      EXPECT_EQ(size_of(model), info["N"].get<Index>());
    }
    if (info.contains("m")) {
      EXPECT_EQ(inputs_of(model), info["m"].get<Index>());
    }
    if (info.contains("p")) {
      EXPECT_EQ(outputs_of(model), info["p"].get<Index>());
    }
    if (info.contains("kind")) {
      EXPECT_EQ(kind_of(model),
                info["kind"] == "second" ? ModelKind::SecondOrder : ModelKind::Descriptor);
    }

    // Definiteness of the exactly symmetric matrices agrees with the independent analysis in
    // info.json ("SPD: Cholesky of X succeeded", "SND: Cholesky of -A succeeded", "neither ...").
    const ModelSummary summary = summarize(model);
    EXPECT_EQ(summary.size, size_of(model));
    if (!info.contains("matrices")) continue;
    for (const auto& [name, m] : info["matrices"].items()) {
      const MatrixSummary* ms = find_summary(summary, name);
      ASSERT_NE(ms, nullptr) << name;
      if (m.contains("shape")) {
        EXPECT_EQ(ms->rows, m["shape"][0].get<Index>()) << name;
        EXPECT_EQ(ms->cols, m["shape"][1].get<Index>()) << name;
      }
      if (m.contains("nnz") && (name == "B" || name == "C" || name == "Cv")) {
        EXPECT_LE(ms->nnz, m["nnz"].get<Index>()) << name;  // dense count omits stored zeros
      } else if (m.contains("nnz")) {
        EXPECT_EQ(ms->nnz, m["nnz"].get<Index>()) << name;
      }
      if (!m.contains("cholesky") || !m.contains("rel_asymmetry") ||
          m["rel_asymmetry"].get<double>() != 0.0)
        continue;
      EXPECT_EQ(ms->relative_asymmetry, 0.0) << name;
      const std::string chol = m["cholesky"].get<std::string>();
      std::string expected;
      if (chol.rfind("SPD", 0) == 0)
        expected = "positive definite";
      else if (chol.rfind("SND", 0) == 0)
        expected = "negative definite";
      else
        expected = name == "A" ? "not negative definite" : "not positive definite";
      EXPECT_EQ(ms->definiteness, expected) << name << ": " << chol;
    }
  }
}

TEST(SharedModels, SpecificModels) {
  // lf10: M is positive definite although badly scaled (eigenvalues 3e-11 .. 7e-5).
  const Model lf10 = load_model(kModels / "lf10");
  ASSERT_EQ(kind_of(lf10), ModelKind::SecondOrder);
  const auto& so = std::get<SecondOrderModel>(lf10);
  EXPECT_LT(so.M.norm(), 1e-3);
  EXPECT_TRUE(is_positive_definite(so.M));
  EXPECT_NO_THROW(require_spd_mass(lf10));
  EXPECT_FALSE(so.has_velocity_output());

  // build_so: D and K slightly unsymmetric, C = 0 with a velocity output.
  const Model build_so = load_model(kModels / "build_so");
  const auto& b = std::get<SecondOrderModel>(build_so);
  EXPECT_TRUE(b.has_velocity_output());
  EXPECT_EQ(b.C, Matrix::Zero(1, 24));
  EXPECT_GT(relative_asymmetry(b.K), 1e-3);
  EXPECT_EQ(find_summary(summarize(build_so), "K")->definiteness, "not checked");

  // peec: weird, but a valid model; mna5: E singular (a DAE), so E is not positive definite.
  const Model peec = load_model(kModels / "peec");
  EXPECT_EQ(size_of(peec), 480);
  const Model mna5 = load_model(kModels / "mna5");
  EXPECT_EQ(size_of(mna5), 10913);
  EXPECT_FALSE(is_positive_definite(std::get<DescriptorModel>(mna5).E));
  expect_input_error([&] { require_spd_mass(mna5, "model mna5"); },
                     {"model mna5: E is not positive definite"});
}

// ---------------------------------------------------------------------------------------------
// Definiteness and symmetry
// ---------------------------------------------------------------------------------------------

TEST(Definiteness, PositiveIndefiniteSingularUnsymmetric) {
  EXPECT_TRUE(is_positive_definite(laplacian(100)));
  // Badly but harmlessly scaled: SPD.
  SparseMatrix scaled = sparse(Eigen::Vector3d(1e-30, 1.0, 1e30).asDiagonal().toDenseMatrix());
  EXPECT_TRUE(is_positive_definite(scaled));

  Matrix indef(3, 3);
  indef << 1, 2, 0, 2, 1, 0, 0, 0, 1;  // eigenvalues 3, -1, 1; positive diagonal
  EXPECT_FALSE(is_positive_definite(sparse(indef)));
  EXPECT_FALSE(is_positive_definite(-laplacian(10)));
  // Singular positive semidefinite (Neumann Laplacian: constant null vector) and all-zero.
  EXPECT_FALSE(is_positive_definite(laplacian(50, /*neumann=*/true)));
  EXPECT_FALSE(is_positive_definite(SparseMatrix(5, 5)));
  Matrix rank1 = Eigen::Vector3d(1, 2, 3) * Eigen::RowVector3d(1, 2, 3);
  EXPECT_FALSE(is_positive_definite(sparse(rank1)));
  // Unsymmetric (though its symmetric part is SPD) and non-square.
  SparseMatrix unsym = laplacian(5);
  unsym.coeffRef(0, 1) = -0.5;
  EXPECT_FALSE(is_positive_definite(unsym));
  EXPECT_TRUE(is_positive_definite(unsym, /*symmetry_tol=*/1.0));
  EXPECT_FALSE(is_positive_definite(SparseMatrix(3, 4)));
}

TEST(Definiteness, RequireSpdMassMessages) {
  SecondOrderModel s = small_second_order(3);
  Matrix indef(3, 3);
  indef << 1, 2, 0, 2, 1, 0, 0, 0, 1;
  s.M = sparse(indef);
  expect_input_error([&] { require_spd_mass(Model(s), "model here"); },
                     {"model here: M is not positive definite (Cholesky failed at column 2)"});
  s.M = sparse(Matrix::Identity(3, 3));
  s.M.coeffRef(0, 2) = 0.1;
  expect_input_error([&] { require_spd_mass(Model(s), "model here"); },
                     {"model here: M is not symmetric (relative asymmetry", "> 1e-10)"});
  EXPECT_NO_THROW(require_spd_mass(Model(s), "model", 0.5));

  DescriptorModel d = small_descriptor(3);
  EXPECT_NO_THROW(require_spd_mass(Model(d)));
  d.E.coeffRef(1, 1) = 0.0;  // a DAE
  expect_input_error([&] { require_spd_mass(Model(d)); },
                     {"E is not positive definite", "column 2"});
}

TEST(Symmetry, RelativeAsymmetry) {
  EXPECT_EQ(relative_asymmetry(laplacian(10)), 0.0);
  EXPECT_EQ(relative_asymmetry(SparseMatrix(4, 4)), 0.0);
  EXPECT_EQ(relative_asymmetry(Matrix(Matrix::Zero(4, 4))), 0.0);
  Matrix a(2, 2);
  a << 0, 1, 0, 0;
  EXPECT_DOUBLE_EQ(relative_asymmetry(a), std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(relative_asymmetry(sparse(a)), std::sqrt(2.0));
  EXPECT_TRUE(std::isinf(relative_asymmetry(SparseMatrix(2, 3))));
}

// ---------------------------------------------------------------------------------------------
// Accessors and validation
// ---------------------------------------------------------------------------------------------

TEST(ModelAccessors, BothKinds) {
  const Model so = small_second_order(5, 2, 3);
  const Model de = small_descriptor(6, 1, 4);
  EXPECT_EQ(kind_of(so), ModelKind::SecondOrder);
  EXPECT_EQ(kind_of(de), ModelKind::Descriptor);
  EXPECT_EQ(size_of(so), 5);
  EXPECT_EQ(inputs_of(so), 2);
  EXPECT_EQ(outputs_of(so), 3);
  EXPECT_EQ(size_of(de), 6);
  EXPECT_EQ(inputs_of(de), 1);
  EXPECT_EQ(outputs_of(de), 4);
  EXPECT_EQ(to_string(ModelKind::SecondOrder), "second order");
  EXPECT_EQ(to_string(ModelKind::Descriptor), "descriptor");

  ReducedSecondOrderModel rs{Matrix::Identity(3, 3), Matrix::Zero(3, 3), Matrix::Identity(3, 3),
                             Matrix::Ones(3, 2),     Matrix::Ones(4, 3), Matrix()};
  ReducedDescriptorModel rd{Matrix::Identity(2, 2), -Matrix::Identity(2, 2), Matrix::Ones(2, 1),
                            Matrix::Ones(1, 2)};
  EXPECT_EQ(kind_of(ReducedModel(rs)), ModelKind::SecondOrder);
  EXPECT_EQ(kind_of(ReducedModel(rd)), ModelKind::Descriptor);
  EXPECT_EQ(size_of(ReducedModel(rs)), 3);
  EXPECT_EQ(inputs_of(ReducedModel(rs)), 2);
  EXPECT_EQ(outputs_of(ReducedModel(rs)), 4);
  EXPECT_EQ(size_of(ReducedModel(rd)), 2);
  EXPECT_EQ(inputs_of(ReducedModel(rd)), 1);
  EXPECT_EQ(outputs_of(ReducedModel(rd)), 1);
  EXPECT_NO_THROW(validate(ReducedModel(rs)));
  EXPECT_NO_THROW(validate(ReducedModel(rd)));
}

TEST(ModelValidate, SecondOrderMessages) {
  const std::string origin = "model models/x";
  EXPECT_NO_THROW(validate(Model(small_second_order()), origin));
  {
    SecondOrderModel s = small_second_order(450);
    s.D = SparseMatrix(450, 451);
    expect_input_error([&] { validate(Model(s), origin); },
                       {"model models/x: D is 450 x 451: must be square"});
  }
  {
    SecondOrderModel s = small_second_order(301);
    s.B = Matrix::Ones(300, 1);
    expect_input_error([&] { validate(Model(s), origin); },
                       {origin + ": B has 300 rows: must equal N = 301 (the size of K)"});
  }
  {
    SecondOrderModel s = small_second_order(4);
    s.M = sparse(Matrix::Identity(3, 3));
    expect_input_error([&] { validate(Model(s), origin); },
                       {"M is 3 x 3: must be N x N = 4 x 4 (the size of K)"});
  }
  {
    SecondOrderModel s = small_second_order(4);
    s.K = SparseMatrix(4, 5);
    expect_input_error([&] { validate(Model(s), origin); }, {"K is 4 x 5: must be square"});
  }
  {
    SecondOrderModel s = small_second_order(4);
    s.C = Matrix::Ones(1, 5);
    expect_input_error([&] { validate(Model(s), origin); },
                       {"C has 5 columns: must equal N = 4 (the size of K)"});
  }
  {
    SecondOrderModel s = small_second_order(4, 1, 2);
    s.Cv = Matrix::Ones(3, 4);
    expect_input_error([&] { validate(Model(s), origin); },
                       {"Cv is 3 x 4 but C is 2 x 4: C and Cv must have the same number of rows"});
    s.Cv = Matrix::Ones(2, 3);
    expect_input_error([&] { validate(Model(s), origin); }, {"Cv has 3 columns"});
  }
  {
    SecondOrderModel s = small_second_order(4);
    s.B = Matrix(4, 0);
    expect_input_error([&] { validate(Model(s), origin); }, {"at least one input"});
  }
  {
    SecondOrderModel s = small_second_order(4);
    s.B(1, 0) = std::numeric_limits<double>::quiet_NaN();
    expect_input_error([&] { validate(Model(s), origin); },
                       {"B has a non-finite value (NaN) at (2, 1)"});
  }
  {
    SecondOrderModel s = small_second_order(4);
    s.K.coeffRef(2, 3) = -std::numeric_limits<double>::infinity();
    expect_input_error([&] { validate(Model(s), origin); },
                       {"K has a non-finite value (Inf) at (3, 4)"});
  }
}

TEST(ModelValidate, DescriptorAndReducedMessages) {
  {
    DescriptorModel d = small_descriptor(4);
    d.E = sparse(Matrix::Identity(3, 3));
    expect_input_error([&] { validate(Model(d), "m"); },
                       {"m: E is 3 x 3: must be N x N = 4 x 4 (the size of A)"});
  }
  {
    DescriptorModel d = small_descriptor(4);
    d.C = Matrix(0, 4);
    expect_input_error([&] { validate(Model(d), "m"); }, {"at least one output"});
  }
  {
    ReducedDescriptorModel r{Matrix::Identity(2, 2), Matrix::Identity(2, 3), Matrix::Ones(2, 1),
                             Matrix::Ones(1, 2)};
    expect_input_error([&] { validate(ReducedModel(r)); },
                       {"reduced model: A is 2 x 3: must be square"});
  }
  {
    ReducedSecondOrderModel r{Matrix::Identity(2, 2), Matrix::Zero(2, 2), Matrix::Identity(2, 2),
                              Matrix::Ones(2, 1),     Matrix::Ones(1, 2), Matrix()};
    r.D(0, 1) = std::numeric_limits<double>::infinity();
    expect_input_error([&] { validate(ReducedModel(r), "rom"); },
                       {"rom: D has a non-finite value (Inf) at (1, 2)"});
  }
}

// ---------------------------------------------------------------------------------------------
// Loading model directories
// ---------------------------------------------------------------------------------------------

TEST(ModelLoad, SecondOrderWithAndWithoutOptionalFiles) {
  TempDir dir{"ecmor_test_model"};
  SecondOrderModel s = small_second_order(5, 2, 3);
  s.Cv = Matrix::Constant(3, 5, 0.5);
  write_model_files(dir.path(), s);
  const Model m = load_model(dir.path());
  ASSERT_EQ(kind_of(m), ModelKind::SecondOrder);
  const auto& l = std::get<SecondOrderModel>(m);
  EXPECT_EQ(Matrix(l.K), Matrix(s.K));
  EXPECT_EQ(Matrix(l.D), Matrix(s.D));
  EXPECT_EQ(l.B, s.B);
  EXPECT_EQ(l.C, s.C);
  EXPECT_EQ(l.Cv, s.Cv);

  TempDir dir2;
  s.Cv = Matrix();
  write_model_files(dir2.path(), s, /*with_d=*/false);
  const auto l2 = std::get<SecondOrderModel>(load_model(dir2.path()));
  EXPECT_EQ(l2.D.rows(), 5);
  EXPECT_EQ(l2.D.cols(), 5);
  EXPECT_EQ(l2.D.nonZeros(), 0);
  EXPECT_FALSE(l2.has_velocity_output());
}

TEST(ModelLoad, DescriptorWithoutEIsIdentity) {
  TempDir dir{"ecmor_test_model"};
  const DescriptorModel d = small_descriptor(6, 2, 1);
  write_model_files(dir.path(), d, /*with_e=*/false);
  const Model m = load_model(dir.path());
  ASSERT_EQ(kind_of(m), ModelKind::Descriptor);
  const auto& l = std::get<DescriptorModel>(m);
  EXPECT_EQ(Matrix(l.E), Matrix(Matrix::Identity(6, 6)));
  EXPECT_EQ(Matrix(l.A), Matrix(d.A));
  EXPECT_EQ(l.B, d.B);
}

TEST(ModelLoad, KindDetectionErrors) {
  {
    TempDir dir{"ecmor_test_model"};
    write_model_files(dir.path(), small_second_order());
    write_matrix_market(dir / "E.mtx", sparse(Matrix::Identity(4, 4)));
    write_matrix_market(dir / "A.mtx", sparse(Matrix::Identity(4, 4)));
    expect_input_error([&] { (void)load_model(dir.path()); },
                       {dir.path().string(), "both a second-order", "descriptor",
                        "found: A.mtx, B.mtx, C.mtx, D.mtx, E.mtx, K.mtx, M.mtx"});
  }
  {
    TempDir dir{"ecmor_test_model"};
    write_matrix_market(dir / "B.mtx", Matrix(Matrix::Ones(3, 1)));
    write_matrix_market(dir / "C.mtx", Matrix(Matrix::Ones(1, 3)));
    write_raw(dir / "notes.txt", "hello");
    expect_input_error([&] { (void)load_model(dir.path()); },
                       {dir.path().string(), "no model files", "found: B.mtx, C.mtx"});
  }
  {
    TempDir dir{"ecmor_test_model"};
    expect_input_error([&] { (void)load_model(dir.path()); }, {"found: no .mtx or .mtx.gz files"});
    expect_input_error([&] { (void)load_model(dir / "missing"); },
                       {(dir / "missing").string(), "directory does not exist"});
    write_raw(dir / "plain", "x");
    expect_input_error([&] { (void)load_model(dir / "plain"); }, {"not a directory"});
  }
  {
    TempDir dir{"ecmor_test_model"};
    write_model_files(dir.path(), small_second_order());
    fs::remove(dir / "K.mtx");
    expect_input_error(
        [&] { (void)load_model(dir.path()); },
        {"the second-order model is missing K.mtx", "found: B.mtx, C.mtx, D.mtx, M.mtx"});
  }
  {
    TempDir dir{"ecmor_test_model"};
    write_model_files(dir.path(), small_descriptor());
    fs::remove(dir / "C.mtx");
    expect_input_error([&] { (void)load_model(dir.path()); },
                       {"the descriptor model is missing C.mtx"});
  }
  {
    TempDir dir{"ecmor_test_model"};
    write_model_files(dir.path(), small_descriptor());
    write_matrix_market(dir / "Cv.mtx", Matrix(Matrix::Ones(1, 4)));
    expect_input_error([&] { (void)load_model(dir.path()); },
                       {"Cv.mtx does not belong to a descriptor model"});
  }
}

TEST(ModelLoad, SizeMismatchBetweenFilesNamesBothFiles) {
  const auto check = [](const auto& model, const std::string& file, const auto& replacement,
                        const std::vector<std::string>& parts) {
    TempDir dir{"ecmor_test_model"};
    write_model_files(dir.path(), model);
    write_matrix_market(dir / file, replacement);
    std::vector<std::string> all = parts;
    all.push_back("model " + dir.path().string());
    expect_input_error([&] { (void)load_model(dir.path()); }, all);
  };
  const SecondOrderModel s = small_second_order(4, 1, 2);
  check(s, "M.mtx", sparse(Matrix::Identity(3, 3)),
        {"M.mtx is 3 x 3 but K.mtx is 4 x 4: both must be N x N"});
  check(s, "D.mtx", sparse(Matrix::Identity(5, 5)), {"D.mtx is 5 x 5 but K.mtx is 4 x 4"});
  check(s, "K.mtx", sparse(Matrix::Ones(4, 3)), {"K.mtx is 4 x 3: must be square"});
  check(s, "B.mtx", Matrix(Matrix::Ones(3, 1)),
        {"B.mtx is 3 x 1 but K.mtx is 4 x 4: B must have N = 4 rows"});
  check(s, "C.mtx", Matrix(Matrix::Ones(2, 5)),
        {"C.mtx is 2 x 5 but K.mtx is 4 x 4: C must have N = 4 columns"});
  check(s, "Cv.mtx", Matrix(Matrix::Ones(3, 4)),
        {"Cv.mtx is 3 x 4 but C.mtx is 2 x 4: C and Cv must have the same number of rows"});
  const DescriptorModel d = small_descriptor(4);
  check(d, "E.mtx", sparse(Matrix::Identity(5, 5)), {"E.mtx is 5 x 5 but A.mtx is 4 x 4"});
  check(d, "B.mtx", Matrix(Matrix::Ones(5, 1)), {"B.mtx is 5 x 1 but A.mtx is 4 x 4"});
}

TEST(ModelLoad, MalformedOrNonFiniteFileNamesFileAndLine) {
  TempDir dir{"ecmor_test_model"};
  write_model_files(dir.path(), small_second_order(3));
  write_raw(dir / "K.mtx",
            "%%MatrixMarket matrix coordinate real general\n% comment\n3 3 3\n1 1 2\n2 2 nan\n"
            "3 3 2\n");
  expect_input_error([&] { (void)load_model(dir.path()); },
                     {(dir / "K.mtx").string(), "line 5:", "not finite"});
  write_raw(dir / "K.mtx",
            "%%MatrixMarket matrix coordinate real general\n3 3 3\n1 1 2\n2 2 2\n3 3 2\n");
  write_raw(dir / "B.mtx", "%%MatrixMarket matrix coordinate real general\n3 1 3\n1 1 1\n2 1 1\n");
  expect_input_error(
      [&] { (void)load_model(dir.path()); },
      {(dir / "B.mtx").string(), "line 4:", "expected 3 entries, file ends after 2"});
  write_raw(dir / "B.mtx", "%%MatrixMarket matrix coordinate complex general\n3 1 0\n");
  expect_input_error([&] { (void)load_model(dir.path()); },
                     {(dir / "B.mtx").string(), "line 1:", "complex"});
}

// ---------------------------------------------------------------------------------------------
// Reduced models
// ---------------------------------------------------------------------------------------------

// A directory may hold each matrix as .mtx or .mtx.gz, mixed; the model is the same.
TEST(ModelLoad, GzippedAndMixedDirectoriesGiveTheSameModel) {
  TempDir plain{"ecmor_test_gz"}, mixed{"ecmor_test_gz"};
  const SecondOrderModel s = small_second_order(6, 2, 3);
  write_model_files(plain.path(), s);
  for (const char* name : {"M", "D", "K", "B", "C"}) {
    const fs::path from = plain / (std::string(name) + ".mtx");
    if (std::string(name) == "K" || std::string(name) == "C") {
      fs::copy_file(from, mixed / (std::string(name) + ".mtx"));
    } else {
      std::ifstream in(from, std::ios::binary);
      const std::string text((std::istreambuf_iterator<char>(in)), {});
      write_raw(mixed / (std::string(name) + ".mtx.gz"), test::gzip_text(text));
    }
  }
  const auto a = std::get<SecondOrderModel>(load_model(plain.path()));
  const auto b = std::get<SecondOrderModel>(load_model(mixed.path()));
  EXPECT_TRUE(bitwise_equal(Matrix(a.M), Matrix(b.M)));
  EXPECT_TRUE(bitwise_equal(Matrix(a.D), Matrix(b.D)));
  EXPECT_TRUE(bitwise_equal(Matrix(a.K), Matrix(b.K)));
  EXPECT_TRUE(bitwise_equal(a.B, b.B));
  EXPECT_TRUE(bitwise_equal(a.C, b.C));
  EXPECT_TRUE(bitwise_equal(Matrix(b.K), Matrix(s.K)));
}

TEST(ModelLoad, AMatrixInBothFormsIsRefusedNamingBoth) {
  TempDir dir{"ecmor_test_gz"};
  write_model_files(dir.path(), small_second_order());
  write_raw(dir / "K.mtx.gz", test::gzip_text("not read"));
  expect_input_error([&] { (void)load_model(dir.path()); },
                     {dir.path().string(), "K.mtx and K.mtx.gz are both present", "keep one"});
}

TEST(ModelLoad, DamagedGzipNamesTheFileAndTheByte) {
  TempDir dir{"ecmor_test_gz"};
  const SecondOrderModel s = small_second_order();
  write_model_files(dir.path(), s);
  std::ifstream in(dir / "K.mtx", std::ios::binary);
  const std::string gz = test::gzip_text(std::string((std::istreambuf_iterator<char>(in)), {}));
  fs::remove(dir / "K.mtx");
  const std::string cut = gz.substr(0, gz.size() / 2);
  write_raw(dir / "K.mtx.gz", cut);
  expect_input_error([&] { (void)load_model(dir.path()); },
                     {(dir / "K.mtx.gz").string(), "byte " + std::to_string(cut.size()) + ":",
                      "truncated gzip data"});
}

TEST(ReducedModelIo, ProjectionBasesMayBeGzipped) {
  TempDir dir{"ecmor_test_gz"};
  Matrix V(5, 2);
  V << 1, 2, 3, 4, 5, 6, 7, 8, 9, 10;
  const Matrix W = 2.0 * V;
  write_matrix_market(dir / "V.mtx", V);
  write_matrix_market(dir / "W.mtx", W);
  for (const char* name : {"V", "W"}) {
    const fs::path plain = dir / (std::string(name) + ".mtx");
    std::ifstream in(plain, std::ios::binary);
    write_raw(dir / (std::string(name) + ".mtx.gz"),
              test::gzip_text(std::string((std::istreambuf_iterator<char>(in)), {})));
  }
  expect_input_error([&] { (void)read_projection_bases(dir.path()); },
                     {"V.mtx and V.mtx.gz are both present"});
  fs::remove(dir / "V.mtx");
  fs::remove(dir / "W.mtx");
  const ProjectionBases b = read_projection_bases(dir.path());
  EXPECT_TRUE(bitwise_equal(b.V, V));
  EXPECT_TRUE(bitwise_equal(b.W, W));
  fs::remove(dir / "W.mtx.gz");
  expect_input_error([&] { (void)read_projection_bases(dir.path()); },
                     {dir.path().string(), "W.mtx (or W.mtx.gz) is missing"});
}

TEST(ReducedModelIo, RoundTripBothKindsBitwise) {
  TempDir dir{"ecmor_test_model"};
  ReducedSecondOrderModel rs{Matrix::Random(5, 5), Matrix::Random(5, 5), Matrix::Random(5, 5),
                             Matrix::Random(5, 2), Matrix::Random(3, 5), Matrix::Random(3, 5)};
  rs.M(0, 0) = 1.0 / 3.0;
  write_reduced_model(dir.path(), rs);
  for (const char* f : {"Mr.mtx", "Dr.mtx", "Kr.mtx", "Br.mtx", "Cr.mtx", "Cvr.mtx"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  const ReducedModel back = read_reduced_model(dir.path());
  ASSERT_EQ(kind_of(back), ModelKind::SecondOrder);
  const auto& b = std::get<ReducedSecondOrderModel>(back);
  EXPECT_TRUE(bitwise_equal(b.M, rs.M));
  EXPECT_TRUE(bitwise_equal(b.D, rs.D));
  EXPECT_TRUE(bitwise_equal(b.K, rs.K));
  EXPECT_TRUE(bitwise_equal(b.B, rs.B));
  EXPECT_TRUE(bitwise_equal(b.C, rs.C));
  EXPECT_TRUE(bitwise_equal(b.Cv, rs.Cv));

  // Overwriting with a descriptor model removes the second-order files (no ambiguity).
  ReducedDescriptorModel rd{Matrix::Random(4, 4), Matrix::Random(4, 4), Matrix::Random(4, 1),
                            Matrix::Random(2, 4)};
  write_reduced_model(dir.path(), rd);
  EXPECT_FALSE(fs::exists(dir / "Mr.mtx"));
  EXPECT_FALSE(fs::exists(dir / "Cvr.mtx"));
  const ReducedModel back2 = read_reduced_model(dir.path());
  ASSERT_EQ(kind_of(back2), ModelKind::Descriptor);
  const auto& d = std::get<ReducedDescriptorModel>(back2);
  EXPECT_TRUE(bitwise_equal(d.E, rd.E));
  EXPECT_TRUE(bitwise_equal(d.A, rd.A));
  EXPECT_TRUE(bitwise_equal(d.B, rd.B));
  EXPECT_TRUE(bitwise_equal(d.C, rd.C));

  // And back to second order without a velocity output.
  rs.Cv = Matrix();
  write_reduced_model(dir.path(), rs);
  EXPECT_FALSE(fs::exists(dir / "Er.mtx"));
  EXPECT_FALSE(fs::exists(dir / "Cvr.mtx"));
  EXPECT_FALSE(
      std::get<ReducedSecondOrderModel>(read_reduced_model(dir.path())).has_velocity_output());
}

TEST(ReducedModelIo, Errors) {
  TempDir dir{"ecmor_test_model"};
  expect_input_error([&] { (void)read_reduced_model(dir.path()); },
                     {"reduced model", "no reduced model files"});
  ReducedDescriptorModel rd{Matrix::Identity(2, 2), -Matrix::Identity(2, 2), Matrix::Ones(2, 1),
                            Matrix::Ones(1, 2)};
  write_reduced_model(dir.path(), rd);
  write_matrix_market(dir / "Br.mtx", Matrix(Matrix::Ones(3, 1)));
  expect_input_error([&] { (void)read_reduced_model(dir.path()); },
                     {"B has 3 rows: must equal N = 2 (the size of A)"});
  rd.A(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(write_reduced_model(dir / "nan", rd), NumericalError);
}

// ---------------------------------------------------------------------------------------------
// Summaries
// ---------------------------------------------------------------------------------------------

TEST(ModelSummary, DefinitenessAndSizes) {
  const ModelSummary s = summarize(Model(small_second_order(6, 2, 3)));
  EXPECT_EQ(s.kind, ModelKind::SecondOrder);
  EXPECT_EQ(s.size, 6);
  EXPECT_EQ(s.inputs, 2);
  EXPECT_EQ(s.outputs, 3);
  EXPECT_FALSE(s.velocity_output);
  ASSERT_EQ(s.matrices.size(), 5u);
  EXPECT_EQ(s.matrices[0].name, "M");
  EXPECT_EQ(s.matrices[0].definiteness, "positive definite");
  EXPECT_EQ(s.matrices[2].name, "K");
  EXPECT_EQ(s.matrices[2].nnz, 16);
  EXPECT_EQ(s.matrices[3].name, "B");
  EXPECT_EQ(s.matrices[3].definiteness, "not checked");
  EXPECT_EQ(s.matrices[3].nnz, 12);

  DescriptorModel d = small_descriptor(5);
  d.E.coeffRef(4, 4) = 0.0;  // singular E
  ModelSummary ds = summarize(Model(d));
  EXPECT_EQ(find_summary(ds, "E")->definiteness, "not positive definite");
  EXPECT_EQ(find_summary(ds, "A")->definiteness, "negative definite");
  d.A.coeffRef(0, 1) = 5.0;
  ds = summarize(Model(d));
  EXPECT_EQ(find_summary(ds, "A")->definiteness, "not checked");
  EXPECT_GT(find_summary(ds, "A")->relative_asymmetry, 0.1);
}

TEST(ModelSummary, LargeModelsSkipCholesky) {
  const Index n = 200001;
  DescriptorModel d;
  d.E.resize(n, n);
  d.E.setIdentity();
  d.A = -d.E;
  d.B = Matrix::Ones(n, 1);
  d.C = Matrix::Ones(1, n);
  const ModelSummary s = summarize(Model(d));
  EXPECT_EQ(find_summary(s, "E")->definiteness, "not checked");
  EXPECT_EQ(find_summary(s, "A")->definiteness, "not checked");
  EXPECT_EQ(find_summary(s, "E")->nnz, n);
}
