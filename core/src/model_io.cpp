// model_io.cpp: loading full models from a directory of Matrix Market files; writing and reading
// reduced models; summaries for `ecmor info`.
#include "ecmor/model_io.hpp"

#include <algorithm>
#include <limits>
#include <set>
#include <string>
#include <system_error>
#include <vector>

#include "ecmor/error.hpp"
#include "ecmor/matrix_market.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;

/// Model-directory inspection: which .mtx files are there.
class ModelDir {
 public:
  ModelDir(const fs::path& dir, std::string origin) : dir_(dir), origin_(std::move(origin)) {
    std::error_code ec;
    const fs::file_status st = fs::status(dir, ec);
    if (ec || !fs::exists(st)) fail("directory does not exist");
    if (!fs::is_directory(st)) fail("not a directory");
    fs::directory_iterator it(dir, ec);
    if (ec) fail("cannot list directory: " + ec.message());
    for (const fs::directory_entry& e : it) {
      std::error_code ec2;
      if (e.path().extension() == ".mtx" && e.is_regular_file(ec2))
        found_.insert(e.path().filename().string());
    }
  }

  [[noreturn]] void fail(const std::string& rule) const { throw InputError(origin_ + ": " + rule); }

  bool has(const std::string& name) const { return found_.count(name + ".mtx") > 0; }
  fs::path file(const std::string& name) const { return dir_ / (name + ".mtx"); }
  const std::string& origin() const { return origin_; }

  std::string found_list() const {
    if (found_.empty()) return "no .mtx files";
    std::string s;
    for (const std::string& f : found_) {
      if (!s.empty()) s += ", ";
      s += f;
    }
    return s;
  }

  void require(const std::vector<std::string>& names, const std::string& kind) const {
    for (const std::string& n : names)
      if (!has(n))
        fail("the " + kind + " model is missing " + n + ".mtx (found: " + found_list() + ")");
  }
  void forbid(const std::vector<std::string>& names, const std::string& kind,
              const std::string& markers) const {
    for (const std::string& n : names)
      if (has(n))
        fail(n + ".mtx does not belong to a " + kind + " model (" + markers +
             " found); found: " + found_list());
  }

 private:
  fs::path dir_;
  std::string origin_;
  std::set<std::string> found_;
};

struct Shape {
  std::string file;
  Index rows = 0, cols = 0;
  std::string str() const {
    return file + " is " + std::to_string(rows) + " x " + std::to_string(cols);
  }
};

Shape shape_of(const ModelDir& d, const std::string& name) {
  const MatrixMarketHeader h = read_matrix_market_header(d.file(name));
  return Shape{name + ".mtx", h.rows, h.cols};
}

/// Checks the sizes declared by the headers against each other before anything large is loaded.
/// `defining` is K or A; `square` the other coefficient matrices; C and optional Cv outputs.
void check_shapes(const ModelDir& d, const std::string& defining,
                  const std::vector<std::string>& square, bool has_cv) {
  const Shape ref = shape_of(d, defining);
  if (ref.rows != ref.cols) d.fail(ref.str() + ": must be square");
  const Index n = ref.rows;
  const std::string n_str = std::to_string(n);
  for (const std::string& name : square) {
    if (!d.has(name)) continue;
    const Shape s = shape_of(d, name);
    if (s.rows != n || s.cols != n) d.fail(s.str() + " but " + ref.str() + ": both must be N x N");
  }
  const Shape b = shape_of(d, "B");
  if (b.rows != n) d.fail(b.str() + " but " + ref.str() + ": B must have N = " + n_str + " rows");
  const Shape c = shape_of(d, "C");
  if (c.cols != n)
    d.fail(c.str() + " but " + ref.str() + ": C must have N = " + n_str + " columns");
  if (has_cv) {
    const Shape cv = shape_of(d, "Cv");
    if (cv.cols != n)
      d.fail(cv.str() + " but " + ref.str() + ": Cv must have N = " + n_str + " columns");
    if (cv.rows != c.rows)
      d.fail(cv.str() + " but " + c.str() + ": C and Cv must have the same number of rows");
  }
}

SparseMatrix sparse_identity(Index n) {
  SparseMatrix I(n, n);
  I.setIdentity();
  I.makeCompressed();
  return I;
}

Index dense_nnz(const Matrix& A) { return (A.array() != 0.0).count(); }

constexpr Index kMaxCholeskySize = 200000;

MatrixSummary summarize_sparse(const std::string& name, const SparseMatrix& A, bool check,
                               bool negate) {
  MatrixSummary s;
  s.name = name;
  s.rows = A.rows();
  s.cols = A.cols();
  s.nnz = A.nonZeros();
  s.relative_asymmetry = relative_asymmetry(A);
  s.definiteness = "not checked";
  constexpr double kSymmetryTol = 1e-10;
  if (check && A.rows() == A.cols() && A.rows() <= kMaxCholeskySize &&
      s.relative_asymmetry <= kSymmetryTol) {
    const bool pd = negate ? is_positive_definite(SparseMatrix(-A), kSymmetryTol)
                           : is_positive_definite(A, kSymmetryTol);
    const std::string what = negate ? "negative definite" : "positive definite";
    s.definiteness = pd ? what : "not " + what;
  }
  return s;
}

MatrixSummary summarize_dense(const std::string& name, const Matrix& A) {
  MatrixSummary s;
  s.name = name;
  s.rows = A.rows();
  s.cols = A.cols();
  s.nnz = dense_nnz(A);
  s.relative_asymmetry =
      A.rows() == A.cols() ? relative_asymmetry(A) : std::numeric_limits<double>::quiet_NaN();
  s.definiteness = "not checked";
  return s;
}

const std::vector<std::string> kSecondOrderReduced = {"Mr", "Dr", "Kr", "Cvr"};
const std::vector<std::string> kDescriptorReduced = {"Er", "Ar"};

void remove_if_present(const fs::path& p) {
  std::error_code ec;
  fs::remove(p, ec);  // false without error when p does not exist
  if (ec) throw IoError("cannot remove stale file " + p.string() + ": " + ec.message());
}

}  // namespace

Model load_model(const fs::path& dir) {
  const ModelDir d(dir, "model " + dir.string());
  const bool second = d.has("M") || d.has("K");
  const bool descriptor = d.has("E") || d.has("A");
  if (second && descriptor)
    d.fail(
        "both a second-order (M.mtx, K.mtx) and a descriptor (E.mtx, A.mtx) file set are "
        "present, the kind is ambiguous; found: " +
        d.found_list());
  if (!second && !descriptor)
    d.fail(
        "no model files: expected M.mtx, K.mtx, B.mtx, C.mtx [, D.mtx, Cv.mtx] (second order) "
        "or [E.mtx,] A.mtx, B.mtx, C.mtx (descriptor); found: " +
        d.found_list());

  if (second) {
    d.require({"M", "K", "B", "C"}, "second-order");
    const bool has_cv = d.has("Cv");
    check_shapes(d, "K", {"M", "D"}, has_cv);
    SecondOrderModel m;
    m.K = read_matrix_market_sparse(d.file("K"));
    m.M = read_matrix_market_sparse(d.file("M"));
    if (d.has("D")) {
      m.D = read_matrix_market_sparse(d.file("D"));
    } else {
      m.D.resize(m.K.rows(), m.K.cols());
      m.D.makeCompressed();
    }
    m.B = read_matrix_market_dense(d.file("B"));
    m.C = read_matrix_market_dense(d.file("C"));
    if (has_cv) m.Cv = read_matrix_market_dense(d.file("Cv"));
    Model model(std::move(m));
    validate(model, d.origin());
    return model;
  }
  d.require({"A", "B", "C"}, "descriptor");
  d.forbid({"D", "Cv"}, "descriptor", "E.mtx/A.mtx");
  check_shapes(d, "A", {"E"}, false);
  DescriptorModel m;
  m.A = read_matrix_market_sparse(d.file("A"));
  m.E = d.has("E") ? read_matrix_market_sparse(d.file("E")) : sparse_identity(m.A.rows());
  m.B = read_matrix_market_dense(d.file("B"));
  m.C = read_matrix_market_dense(d.file("C"));
  Model model(std::move(m));
  validate(model, d.origin());
  return model;
}

void write_reduced_model(const fs::path& dir, const ReducedModel& model) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError("cannot create directory " + dir.string() + ": " + ec.message());
  const auto file = [&](const std::string& name) { return dir / (name + ".mtx"); };
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model)) {
    write_matrix_market(file("Mr"), so->M, "reduced model: Mr (second order)");
    write_matrix_market(file("Dr"), so->D, "reduced model: Dr (second order)");
    write_matrix_market(file("Kr"), so->K, "reduced model: Kr (second order)");
    write_matrix_market(file("Br"), so->B, "reduced model: Br (second order)");
    write_matrix_market(file("Cr"), so->C, "reduced model: Cr (second order)");
    if (so->has_velocity_output())
      write_matrix_market(file("Cvr"), so->Cv, "reduced model: Cvr (second order)");
    else
      remove_if_present(file("Cvr"));
    // Files of a previously written model of the other kind would make the directory ambiguous.
    for (const std::string& n : kDescriptorReduced) remove_if_present(file(n));
  } else {
    const auto& de = std::get<ReducedDescriptorModel>(model);
    write_matrix_market(file("Er"), de.E, "reduced model: Er (descriptor)");
    write_matrix_market(file("Ar"), de.A, "reduced model: Ar (descriptor)");
    write_matrix_market(file("Br"), de.B, "reduced model: Br (descriptor)");
    write_matrix_market(file("Cr"), de.C, "reduced model: Cr (descriptor)");
    for (const std::string& n : kSecondOrderReduced) remove_if_present(file(n));
  }
}

ReducedModel read_reduced_model(const fs::path& dir) {
  const ModelDir d(dir, "reduced model " + dir.string());
  const bool second = d.has("Mr") || d.has("Kr");
  const bool descriptor = d.has("Er") || d.has("Ar");
  if (second && descriptor)
    d.fail(
        "both a second-order (Mr.mtx, Kr.mtx) and a descriptor (Er.mtx, Ar.mtx) file set are "
        "present, the kind is ambiguous; found: " +
        d.found_list());
  if (!second && !descriptor)
    d.fail(
        "no reduced model files: expected Mr.mtx, Dr.mtx, Kr.mtx, Br.mtx, Cr.mtx [, Cvr.mtx] "
        "or Er.mtx, Ar.mtx, Br.mtx, Cr.mtx; found: " +
        d.found_list());
  ReducedModel model;
  if (second) {
    d.require({"Mr", "Kr", "Br", "Cr"}, "reduced second-order");
    ReducedSecondOrderModel m;
    m.M = read_matrix_market_dense(d.file("Mr"));
    m.K = read_matrix_market_dense(d.file("Kr"));
    m.D =
        d.has("Dr") ? read_matrix_market_dense(d.file("Dr")) : Matrix::Zero(m.K.rows(), m.K.cols());
    m.B = read_matrix_market_dense(d.file("Br"));
    m.C = read_matrix_market_dense(d.file("Cr"));
    if (d.has("Cvr")) m.Cv = read_matrix_market_dense(d.file("Cvr"));
    model = std::move(m);
  } else {
    d.require({"Ar", "Br", "Cr"}, "reduced descriptor");
    ReducedDescriptorModel m;
    m.A = read_matrix_market_dense(d.file("Ar"));
    m.E = d.has("Er") ? read_matrix_market_dense(d.file("Er"))
                      : Matrix::Identity(m.A.rows(), m.A.cols());
    m.B = read_matrix_market_dense(d.file("Br"));
    m.C = read_matrix_market_dense(d.file("Cr"));
    model = std::move(m);
  }
  validate(model, d.origin());
  return model;
}

ModelSummary summarize(const Model& model) {
  ModelSummary s;
  s.kind = kind_of(model);
  s.size = size_of(model);
  s.inputs = inputs_of(model);
  s.outputs = outputs_of(model);
  if (const auto* so = std::get_if<SecondOrderModel>(&model)) {
    s.velocity_output = so->has_velocity_output();
    s.matrices.push_back(summarize_sparse("M", so->M, true, false));
    s.matrices.push_back(summarize_sparse("D", so->D, true, false));
    s.matrices.push_back(summarize_sparse("K", so->K, true, false));
    s.matrices.push_back(summarize_dense("B", so->B));
    s.matrices.push_back(summarize_dense("C", so->C));
    if (so->has_velocity_output()) s.matrices.push_back(summarize_dense("Cv", so->Cv));
  } else {
    const auto& de = std::get<DescriptorModel>(model);
    s.matrices.push_back(summarize_sparse("E", de.E, true, false));
    s.matrices.push_back(summarize_sparse("A", de.A, true, true));
    s.matrices.push_back(summarize_dense("B", de.B));
    s.matrices.push_back(summarize_dense("C", de.C));
  }
  return s;
}

}  // namespace ecmor
