// MATLAB .mat models and outputs: files written here with matio directly (MAT v5 and v7.3) are
// read back by load_model and must give the written matrices exactly; every bad input gets an
// error naming the file, the variable and the rule; the YAML keys model.file, model.variables and
// output.format; write_reduction in each format and read_reduced_model back.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "common/bitwise_equal.hpp"
#include "common/mat_test_file.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/run/config.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

using test::bitwise_equal;
using test::MatTestFile;
using test::message_of;
using test::TempDir;

constexpr mat_ft kVersions[] = {MAT_FT_MAT5, MAT_FT_MAT73};

std::string version_name(mat_ft v) { return v == MAT_FT_MAT73 ? "v7.3" : "v5"; }

/// Tridiagonal n x n with values that are not short binary fractions (1/3, 1/7, ...).
SparseMatrix tridiagonal(Index n, double d, double off) {
  std::vector<Eigen::Triplet<double, int>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, d + i / 3.0);
    if (i + 1 < n) {
      t.emplace_back(i, i + 1, off / 7.0);
      t.emplace_back(i + 1, i, off / 7.0);
    }
  }
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

SecondOrderModel second_order(Index n = 5, Index m = 2, Index p = 3) {
  SecondOrderModel s;
  s.M = tridiagonal(n, 4.0, 1.0);
  s.D = tridiagonal(n, 0.1, 0.01);
  s.K = tridiagonal(n, 2.0, -1.0);
  s.B = Matrix::Random(n, m);
  s.C = Matrix::Random(p, n);
  return s;
}

DescriptorModel descriptor(Index n = 6, Index m = 1, Index p = 2) {
  DescriptorModel d;
  d.E = tridiagonal(n, 3.0, 1.0);
  d.A = -tridiagonal(n, 2.0, -1.0);
  d.B = Matrix::Random(n, m);
  d.C = Matrix::Random(p, n);
  return d;
}

/// Expects load_model(source) to throw InputError containing every one of `parts`.
void expect_load_error(const ModelSource& source, const std::vector<std::string>& parts) {
  const std::string msg = message_of<InputError>([&] { (void)load_model(source); });
  for (const std::string& part : parts)
    EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
}

// ---------------------------------------------------------------------------------------------
// Reading models
// ---------------------------------------------------------------------------------------------

TEST(MatModel, SecondOrderReadsBackExactlyInV5AndV73) {
  for (const mat_ft version : kVersions) {
    SCOPED_TRACE(version_name(version));
    TempDir dir{"ecmor_test_mat"};
    SecondOrderModel s = second_order();
    s.Cv = Matrix::Random(3, 5);
    const fs::path file = dir / "model.mat";
    {
      MatTestFile f(file, version);
      f.sparse("M", s.M);
      f.dense("D", Matrix(s.D));  // dense in the file, sparse in the model
      f.sparse("K", s.K);
      f.dense("B", s.B);
      f.sparse("C", s.C.sparseView());  // sparse in the file, dense in the model
      f.dense("Cv", s.Cv);
      f.text("note", "not part of the model");
    }
    EXPECT_TRUE(bitwise_equal(load_model(file), Model(s)));
  }
}

TEST(MatModel, DescriptorReadsBackExactlyInV5AndV73) {
  for (const mat_ft version : kVersions) {
    SCOPED_TRACE(version_name(version));
    TempDir dir{"ecmor_test_mat"};
    const DescriptorModel d = descriptor();
    const fs::path file = dir / "model.MAT";  // the extension in any case
    {
      MatTestFile f(file, version);
      f.model(d);
    }
    EXPECT_TRUE(bitwise_equal(load_model(file), Model(d)));
  }
}

TEST(MatModel, OptionalMatricesDefaultAsInModelDirectories) {
  TempDir dir{"ecmor_test_mat"};
  const SecondOrderModel s = second_order(4, 1, 1);
  {
    MatTestFile f(dir / "so.mat", MAT_FT_MAT5);
    f.sparse("M", s.M);
    f.sparse("K", s.K);
    f.dense("B", s.B);
    f.dense("C", s.C);
  }
  const auto so = std::get<SecondOrderModel>(load_model(dir / "so.mat"));
  EXPECT_EQ(so.D.rows(), 4);
  EXPECT_EQ(so.D.cols(), 4);
  EXPECT_EQ(so.D.nonZeros(), 0);
  EXPECT_FALSE(so.has_velocity_output());

  // Descriptor without E: E = I. A feedthrough D that is all zero (dense or empty) is accepted.
  const DescriptorModel d = descriptor(5, 2, 1);
  for (const bool empty_d : {false, true}) {
    SCOPED_TRACE(empty_d ? "D = []" : "D = zeros(1, 2)");
    const fs::path file = dir / (empty_d ? "empty_d.mat" : "zero_d.mat");
    {
      MatTestFile f(file, MAT_FT_MAT73);
      f.sparse("A", d.A);
      f.dense("B", d.B);
      f.dense("C", d.C);
      f.dense("D", empty_d ? Matrix(0, 0) : Matrix::Zero(1, 2));
    }
    const auto de = std::get<DescriptorModel>(load_model(file));
    EXPECT_EQ(Matrix(de.E), Matrix(Matrix::Identity(5, 5)));
    EXPECT_TRUE(bitwise_equal(de.A, d.A));
  }
}

TEST(MatModel, IntegerSingleAndLogicalClassesAreConvertedToDouble) {
  for (const mat_ft version : kVersions) {
    SCOPED_TRACE(version_name(version));
    TempDir dir{"ecmor_test_mat"};
    const Index n = 4;
    Matrix K = Matrix::Zero(n, n);
    for (Index i = 0; i < n; ++i) {
      K(i, i) = 2.0;
      if (i + 1 < n) K(i, i + 1) = K(i + 1, i) = -1.0;
    }
    const Matrix B = Matrix::Constant(n, 1, 0.5);  // exact in single precision
    Matrix C(1, n);
    C << 1, 2, 3, 250;  // uint8
    const fs::path file = dir / "classes.mat";
    {
      MatTestFile f(file, version);
      f.dense_as<std::uint8_t>("M", Matrix::Identity(n, n), MAT_C_UINT8, MAT_T_UINT8,
                               /*logical=*/true);
      f.dense_as<std::int32_t>("K", K, MAT_C_INT32, MAT_T_INT32);
      f.dense_as<float>("B", B, MAT_C_SINGLE, MAT_T_SINGLE);
      f.dense_as<std::uint8_t>("C", C, MAT_C_UINT8, MAT_T_UINT8);
      f.dense_as<std::int16_t>("D", Matrix::Zero(n, n), MAT_C_INT16, MAT_T_INT16);
    }
    const auto s = std::get<SecondOrderModel>(load_model(file));
    EXPECT_EQ(Matrix(s.M), Matrix(Matrix::Identity(n, n)));
    EXPECT_EQ(Matrix(s.K), K);
    EXPECT_EQ(s.K.nonZeros(), 10);  // the zeros of a dense variable are not stored
    EXPECT_EQ(s.B, B);
    EXPECT_EQ(s.C, C);
    EXPECT_EQ(s.D.nonZeros(), 0);
  }
}

TEST(MatModel, VariablesRenameTheMatrices) {
  TempDir dir{"ecmor_test_mat"};
  const SecondOrderModel s = second_order(4, 1, 2);
  const fs::path file = dir / "renamed.mat";
  {
    MatTestFile f(file, MAT_FT_MAT5);
    f.sparse("Mass", s.M);
    f.sparse("Damp", s.D);
    f.sparse("Stiff", s.K);
    f.dense("B", s.B);
    f.dense("Out", s.C);
  }
  const ModelSource source{file, {{"M", "Mass"}, {"D", "Damp"}, {"K", "Stiff"}, {"C", "Out"}}};
  EXPECT_TRUE(bitwise_equal(load_model(source), Model(s)));

  // Without the renames, the file holds no model at all; a renamed role that is missing is named
  // by its variable, and the message lists the renames.
  expect_load_error({file, {}}, {file.string(), "no model variables: expected M, K, B, C",
                                 "found: B, Damp, Mass, Out, Stiff"});
  expect_load_error({file, {{"M", "Mass"}, {"K", "Stiffness"}}},
                    {"model " + file.string() + " (variables: K = Stiffness, M = Mass)",
                     "the second-order model is missing variable Stiffness"});
}

// ---------------------------------------------------------------------------------------------
// Bad input: one test per rule, each message naming the file, the variable and the rule
// ---------------------------------------------------------------------------------------------

/// A valid second-order file (M, K, B, C, N = 4, two outputs) in `dir`, with the variable `role`
/// written by `replace` instead (left out when `replace` is empty).
fs::path second_order_file(const TempDir& dir, mat_ft version, const std::string& role = "",
                           const std::function<void(MatTestFile&)>& replace = {}) {
  const SecondOrderModel s = second_order(4, 1, 2);
  const fs::path file = dir / ("bad_" + version_name(version) + ".mat");
  MatTestFile f(file, version);
  const auto put = [&](const std::string& name, const auto& write) {
    if (name != role)
      write();
    else if (replace)
      replace(f);
  };
  put("M", [&] { f.sparse("M", s.M); });
  put("K", [&] { f.sparse("K", s.K); });
  put("B", [&] { f.dense("B", s.B); });
  put("C", [&] { f.dense("C", s.C); });
  return file;
}

/// load_model of second_order_file(version, role, replace) must fail with a message naming the
/// file and containing every one of `parts`.
void expect_refused(mat_ft version, const std::string& role,
                    const std::function<void(MatTestFile&)>& replace,
                    const std::vector<std::string>& parts) {
  SCOPED_TRACE(version_name(version) + ", variable " + role);
  TempDir dir{"ecmor_test_mat"};
  const fs::path file = second_order_file(dir, version, role, replace);
  std::vector<std::string> all = parts;
  all.push_back("model " + file.string() + ": ");
  expect_load_error({file, {}}, all);
}

TEST(MatModelErrors, MissingOrUnreadableFile) {
  TempDir dir{"ecmor_test_mat"};
  expect_load_error({dir / "absent.mat", {}},
                    {(dir / "absent.mat").string(), "file does not exist"});
  test::write_raw(dir / "text.mat", "this is not a MAT file, only some text\n");
  expect_load_error({dir / "text.mat", {}}, {(dir / "text.mat").string(), "not a MAT file"});
}

TEST(MatModelErrors, MissingVariable) {
  for (const mat_ft version : kVersions)
    expect_refused(version, "C", {},
                   {"the second-order model is missing variable C", "(found: B, K, M)"});
}

TEST(MatModelErrors, WrongDimensionsNameBothVariables) {
  expect_refused(MAT_FT_MAT5, "B", [](MatTestFile& f) { f.dense("B", Matrix::Ones(3, 1)); },
                 {"variable B is 3 x 1 but variable K is 4 x 4: B must have N = 4 rows"});
  expect_refused(MAT_FT_MAT73, "K",
                 [](MatTestFile& f) { f.sparse("K", Matrix::Ones(4, 3).sparseView()); },
                 {"variable K is 4 x 3: must be square"});
}

TEST(MatModelErrors, SparseVariableTooLargeToHoldDenselyIsRefusedBeforeAllocating) {
  // 2^24 outputs x 4 states: no entries in the file, 512 MiB once dense.
  expect_refused(MAT_FT_MAT5, "C",
                 [](MatTestFile& f) { f.sparse("C", SparseMatrix(Index{1} << 24, 4)); },
                 {"variable C is a sparse 16777216 x 4 matrix: too large to hold densely"});
}

TEST(MatModelErrors, NonNumericClassesAndArraysThatAreNotMatrices) {
  for (const mat_ft version : kVersions) {
    expect_refused(version, "C", [](MatTestFile& f) { f.text("C", "ones(1, 4)"); },
                   {"variable C is a char array", "must be a numeric or logical matrix"});
    expect_refused(version, "M", [](MatTestFile& f) { f.three_d("M", 4, 4, 2); },
                   {"variable M has 3 dimensions (4 x 4 x 2): must be a 2-D matrix"});
  }
}

TEST(MatModelErrors, ComplexVariablesDenseOrSparse) {
  for (const mat_ft version : kVersions)
    for (const bool as_sparse : {false, true})
      expect_refused(version, "K",
                     [&](MatTestFile& f) { f.complex("K", Matrix::Identity(4, 4), as_sparse); },
                     {"variable K is complex", "only real matrices are accepted"});
}

TEST(MatModelErrors, NonFiniteValuesAreNamedWithTheirPosition) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (const mat_ft version : kVersions) {
    expect_refused(version, "K",
                   [&](MatTestFile& f) {
                     SparseMatrix K = tridiagonal(4, 2.0, -1.0);
                     K.coeffRef(1, 2) = kNaN;
                     f.sparse("K", K);
                   },
                   {"K has a non-finite value (NaN) at (2, 3)"});
    expect_refused(version, "B",
                   [&](MatTestFile& f) {
                     Matrix B = Matrix::Ones(4, 1);
                     B(3, 0) = -kInf;
                     f.dense("B", B);
                   },
                   {"B has a non-finite value (Inf) at (4, 1)"});
    // A dense variable read into a sparse matrix keeps its NaN (it is not a zero to drop).
    expect_refused(version, "M",
                   [&](MatTestFile& f) {
                     Matrix M = Matrix::Identity(4, 4);
                     M(2, 1) = kNaN;
                     f.dense("M", M);
                   },
                   {"M has a non-finite value (NaN) at (3, 2)"});
  }
}

TEST(MatModelErrors, BothKindsPresentIsAmbiguous) {
  expect_refused(
      MAT_FT_MAT5, "C",
      [](MatTestFile& f) {
        f.sparse("A", -tridiagonal(4, 2.0, -1.0));
        f.dense("C", Matrix::Ones(2, 4));
      },
      {"both a second-order (M, K) and a descriptor (E, A) variable set are present, the kind is "
       "ambiguous; found: A, B, C, K, M"});
}

TEST(MatModelErrors, NonZeroFeedthroughAndVelocityOutputInADescriptorFile) {
  TempDir dir{"ecmor_test_mat"};
  const DescriptorModel d = descriptor(4, 1, 1);
  const fs::path file = dir / "ss.mat";
  {
    MatTestFile f(file, MAT_FT_MAT73);
    f.model(d);
    f.dense("D", Matrix::Constant(1, 1, 2.5));
  }
  expect_load_error({file, {}}, {file.string(), "variable D beside variable A is the feedthrough",
                                 "is non-zero (D(1, 1) = 2.5",
                                 "ecmor's descriptor models have no feedthrough term"});
  const fs::path cv = dir / "cv.mat";
  {
    MatTestFile f(cv, MAT_FT_MAT5);
    f.model(d);
    f.dense("Cv", Matrix::Ones(1, 4));
  }
  expect_load_error({cv, {}}, {cv.string(), "variable Cv does not belong to a descriptor model"});
}

TEST(MatModelErrors, VariablesMapItself) {
  TempDir dir{"ecmor_test_mat"};
  const fs::path file = second_order_file(dir, MAT_FT_MAT5);
  expect_load_error({file, {{"Stiffness", "K"}}},
                    {file.string(),
                     "variables: unknown role 'Stiffness' (roles: M, D, K, B, C, "
                     "Cv, E, A)"});
  // K read from M's variable while M is still read from it too.
  expect_load_error({file, {{"K", "M"}}},
                    {file.string(), "variables: M and K are both read from variable M"});
  expect_load_error({file, {{"K", ""}}}, {"variables: K is renamed to an empty name"});
  // A directory has fixed file names.
  expect_load_error({dir.path(), {{"K", "Stiff"}}},
                    {dir.path().string(), "'variables' renames the variables of a .mat file"});
}

// ---------------------------------------------------------------------------------------------
// The YAML keys
// ---------------------------------------------------------------------------------------------

const std::string kRest = R"(
band:   {f_min_hz: 1, f_max_hz: 100}
target: {tolerance: 1.0e-3}
reducer: {name: modal}
)";

std::string config_error(const std::string& yaml) {
  return message_of<ConfigError>([&] { (void)parse_run_config(yaml, "run.yaml"); });
}

TEST(MatConfig, ModelFileVariablesAndOutputFormat) {
  const RunConfig c =
      parse_run_config("model: {file: models/plate.mat, variables: {M: Mass, K: Stiff}}" + kRest +
                           "output: {dir: out/plate, format: mat}\n",
                       "run.yaml");
  EXPECT_EQ(c.model.path, (fs::current_path() / "models/plate.mat").lexically_normal());
  const std::map<std::string, std::string> renames = {{"M", "Mass"}, {"K", "Stiff"}};
  EXPECT_EQ(c.model.variables, renames);
  EXPECT_EQ(c.output_format, OutputFormat::Mat);

  const RunConfig d =
      parse_run_config("model: {dir: models/lf10}" + kRest + "output: {dir: out/x}\n", "run.yaml");
  EXPECT_TRUE(d.model.variables.empty());
  EXPECT_EQ(d.output_format, OutputFormat::Mtx);  // the default is unchanged
  EXPECT_EQ(
      parse_run_config("model: {dir: m}" + kRest + "output: {dir: o, format: both}\n", "run.yaml")
          .output_format,
      OutputFormat::Both);
}

TEST(MatConfig, Errors) {
  const std::string out = "output: {dir: o}\n";
  // {model section, expected message}; the model line is line 1.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{dir: m, file: m.mat}",
       "give model.dir (a model directory) or model.file (a .mat file), not both"},
      {"{file: m.h5}",
       "model.file = 'm.h5': must name a MATLAB file ending in .mat (a model directory is "
       "model.dir)"},
      {"{dir: m, variables: {K: Stiff}}",
       "model.variables renames the variables of a .mat file (model.file); the files of a model "
       "directory have fixed names"},
      {"{file: m.mat, variables: {Kk: Stiff}}",
       "unknown key 'Kk' in 'model.variables' (did you mean 'K'?)"},
      {"{file: m.mat, variables: [M, K]}",
       "model.variables must be a mapping from matrix to variable name, e.g. {M: Mass, K: Stiff}, "
       "found a list"},
      {"{file: m.mat, variables: {K: [a, b]}}",
       "model.variables.K must be a single value, found a list"},
      {"{}", "missing required key 'model.dir' (a model directory) or 'model.file' (a .mat file)"},
  };
  for (const auto& [model, message] : cases)
    EXPECT_EQ(config_error("model: " + model + kRest + out), "run.yaml:1: " + message);
  EXPECT_EQ(config_error("model: {dir: m}" + kRest + "output: {dir: o, format: matt}\n"),
            "run.yaml:5: output.format = 'matt': must be one of mtx, mat, both (did you mean "
            "'mat'?)");
}

// ---------------------------------------------------------------------------------------------
// Writing reduced models
// ---------------------------------------------------------------------------------------------

std::vector<std::string> sorted(std::vector<std::string> v) {
  std::sort(v.begin(), v.end());
  return v;
}

TEST(MatOutput, ReducedModelAndBasesRoundTripBitwise) {
  TempDir dir{"ecmor_test_mat"};
  ReducedSecondOrderModel rs{Matrix::Random(3, 3), Matrix::Random(3, 3), Matrix::Random(3, 3),
                             Matrix::Random(3, 2), Matrix::Random(2, 3), Matrix::Random(2, 3)};
  rs.M(0, 0) = 1.0 / 3.0;
  const Matrix V = Matrix::Random(7, 3);
  const Matrix W = Matrix::Random(7, 3);
  write_reduction(dir.path(), rs, V, W, OutputFormat::Mat);
  const fs::path mat = dir / kReducedModelMatFile;
  EXPECT_EQ(sorted(test::mat_variable_names(mat)),
            sorted({"Mr", "Dr", "Kr", "Br", "Cr", "Cvr", "V", "W"}));
  EXPECT_TRUE(bitwise_equal(test::mat_read_dense(mat, "V"), V));
  EXPECT_TRUE(bitwise_equal(test::mat_read_dense(mat, "W"), W));
  EXPECT_FALSE(fs::exists(dir / "Mr.mtx"));
  EXPECT_FALSE(fs::exists(dir / "V.mtx"));
  for (const fs::path& path : {dir.path(), mat})  // the run directory or the file itself
    EXPECT_TRUE(bitwise_equal(read_reduced_model(path), ReducedModel(rs))) << path;

  // Galerkin (W = V): no W variable. A descriptor model replaces the second-order one.
  const ReducedDescriptorModel rd{Matrix::Random(4, 4), Matrix::Random(4, 4), Matrix::Random(4, 1),
                                  Matrix::Random(1, 4)};
  const Matrix V4 = Matrix::Random(7, 4);
  write_reduction(dir.path(), rd, V4, V4, OutputFormat::Mat);
  EXPECT_EQ(sorted(test::mat_variable_names(mat)), sorted({"Er", "Ar", "Br", "Cr", "V"}));
  EXPECT_TRUE(bitwise_equal(read_reduced_model(dir.path()), ReducedModel(rd)));
}

// write_mat_file (model_io.hpp), the writer the interop library's .mat body uses: the variables in
// the given order, bit for bit; a non-finite entry names the variable and leaves no file behind.
TEST(MatOutput, NamedMatricesRoundTripInOrderAndNonFiniteOnesAreNamed) {
  TempDir dir{"ecmor_test_mat"};
  const fs::path mat = dir / "named.mat";
  const Matrix a = Matrix::Random(3, 4), b = Matrix::Constant(1, 1, 1.0 / 3.0);
  write_mat_file(mat, {{"zeta", a}, {"alpha", b}, {"empty", Matrix(0, 2)}}, "test header");
  EXPECT_EQ(test::mat_variable_names(mat), (std::vector<std::string>{"zeta", "alpha", "empty"}));
  EXPECT_TRUE(bitwise_equal(test::mat_read_dense(mat, "zeta"), a));
  EXPECT_TRUE(bitwise_equal(test::mat_read_dense(mat, "alpha"), b));
  EXPECT_EQ(test::mat_read_dense(mat, "empty").cols(), 2);

  Matrix bad = Matrix::Zero(2, 2);
  bad(1, 0) = std::numeric_limits<double>::quiet_NaN();
  const fs::path other = dir / "other.mat";
  const std::string msg = message_of<NumericalError>([&] {
    write_mat_file(other, {{"ok", a}, {"bad", bad}}, "x");
  });
  EXPECT_NE(msg.find("variable bad"), std::string::npos) << msg;
  EXPECT_NE(msg.find(other.string()), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(other));
}

TEST(MatOutput, FormatsReplaceEachOther) {
  TempDir dir{"ecmor_test_mat"};
  const ReducedDescriptorModel rd{Matrix::Identity(2, 2), -Matrix::Identity(2, 2),
                                  Matrix::Ones(2, 1), Matrix::Ones(1, 2)};
  const Matrix V = Matrix::Random(5, 2);
  const fs::path mat = dir / kReducedModelMatFile;
  write_reduction(dir.path(), rd, V, V, OutputFormat::Both);
  EXPECT_TRUE(fs::exists(mat));
  EXPECT_TRUE(fs::exists(dir / "Ar.mtx"));
  EXPECT_TRUE(fs::exists(dir / "W.mtx"));  // the .mtx output keeps writing W as before
  EXPECT_TRUE(
      bitwise_equal(read_matrix_market_dense(dir / "V.mtx"), test::mat_read_dense(mat, "V")));
  write_reduction(dir.path(), rd, V, V, OutputFormat::Mtx);
  EXPECT_FALSE(fs::exists(mat));
  EXPECT_TRUE(fs::exists(dir / "Ar.mtx"));
  write_reduction(dir.path(), rd, V, V, OutputFormat::Mat);
  EXPECT_TRUE(fs::exists(mat));
  for (const char* f : {"Er.mtx", "Ar.mtx", "Br.mtx", "Cr.mtx", "V.mtx", "W.mtx"})
    EXPECT_FALSE(fs::exists(dir / f)) << f;
  // Nothing is written for a non-finite model; the error names the file and the variable.
  ReducedDescriptorModel bad = rd;
  bad.A(1, 1) = std::numeric_limits<double>::quiet_NaN();
  TempDir dir2{"ecmor_test_mat"};
  const std::string msg = message_of<NumericalError>(
      [&] { write_reduction(dir2.path(), bad, V, V, OutputFormat::Mat); });
  EXPECT_NE(msg.find((dir2 / kReducedModelMatFile).string()), std::string::npos) << msg;
  EXPECT_NE(msg.find("variable Ar has a non-finite value"), std::string::npos) << msg;
  EXPECT_TRUE(fs::is_empty(dir2.path()));
}

TEST(MatOutput, ReadingErrorsNameTheFile) {
  TempDir dir{"ecmor_test_mat"};
  const fs::path mat = dir / kReducedModelMatFile;
  {
    MatTestFile f(mat, MAT_FT_MAT5);
    f.dense("Ar", -Matrix::Identity(2, 2));
    f.dense("Br", Matrix::Ones(3, 1));
    f.dense("Cr", Matrix::Ones(1, 2));
  }
  const std::string msg = message_of<InputError>([&] { (void)read_reduced_model(dir.path()); });
  EXPECT_NE(msg.find("reduced model " + mat.string()), std::string::npos) << msg;
  EXPECT_NE(msg.find("B has 3 rows: must equal N = 2 (the size of A)"), std::string::npos) << msg;
}

}  // namespace
}  // namespace ecmor
