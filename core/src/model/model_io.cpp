// model_io.cpp: loading full models from a directory of Matrix Market files or a .mat file;
// writing and reading reduced models; summaries for `ecmor info`.
//
// Both containers go through one loader (load_from, read_reduced_from): the kind detection, the
// required and forbidden matrices, the size checks and ecmor::validate are written once; a
// Container only says how a matrix is named, found, sized and read.
#include "ecmor/model/model_io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "model/mat_file.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;

/// A model container as the loader sees it. Matrices are asked for by role ("K", or "Kr" for a
/// reduced model); messages name them as the container stores them.
class Container {
 public:
  explicit Container(std::string origin) : origin_(std::move(origin)) {}
  virtual ~Container() = default;
  Container(const Container&) = delete;
  Container& operator=(const Container&) = delete;

  [[noreturn]] void fail(const std::string& rule) const { throw InputError(origin_ + ": " + rule); }
  const std::string& origin() const { return origin_; }

  virtual bool has(const std::string& role) const = 0;
  /// How the role is stored, for lists: "K.mtx" or "K".
  virtual std::string name(const std::string& role) const = 0;
  /// The same in a sentence: "K.mtx" or "variable K".
  virtual std::string label(const std::string& role) const = 0;
  /// Everything the container holds (also what is not a model matrix), for messages.
  virtual std::string found_list() const = 0;
  /// "file" or "variable".
  virtual std::string item() const = 0;
  /// rows, cols: cheap (a header), before anything large is read.
  virtual std::pair<Index, Index> shape(const std::string& role) const = 0;
  virtual SparseMatrix sparse(const std::string& role) const = 0;
  virtual Matrix dense(const std::string& role) const = 0;
  /// A descriptor model with a D: the rule differs between the containers (see the overrides).
  virtual void check_feedthrough() const = 0;

  void require(const std::vector<std::string>& roles, const std::string& kind) const {
    for (const std::string& r : roles)
      if (!has(r))
        fail("the " + kind + " model is missing " + label(r) + " (found: " + found_list() + ")");
  }
  void forbid(const std::vector<std::string>& roles, const std::string& kind,
              const std::string& markers) const {
    for (const std::string& r : roles)
      if (has(r))
        fail(label(r) + " does not belong to a " + kind + " model (" + markers +
             " found); found: " + found_list());
  }

 private:
  std::string origin_;
};

/// Model-directory inspection: which .mtx and .mtx.gz files are there. A matrix may be stored
/// either way, and the two may be mixed in one directory; the same matrix in both is refused.
class ModelDir final : public Container {
 public:
  ModelDir(const fs::path& dir, std::string origin) : Container(std::move(origin)), dir_(dir) {
    std::error_code ec;
    const fs::file_status st = fs::status(dir, ec);
    if (ec || !fs::exists(st)) fail("directory does not exist");
    if (!fs::is_directory(st)) fail("not a directory (nor a .mat file)");
    fs::directory_iterator it(dir, ec);
    if (ec) fail("cannot list directory: " + ec.message());
    std::map<std::string, std::set<std::string>> files_of;  // stem -> its file names
    for (const fs::directory_entry& e : it) {
      const std::string name = e.path().filename().string();
      const std::string stem = matrix_stem(name);
      std::error_code ec2;
      if (stem.empty() || !e.is_regular_file(ec2)) continue;
      found_.insert(name);
      files_of[stem].insert(name);
    }
    for (const auto& [stem, names] : files_of) {
      if (names.size() > 1)
        fail(fmt::format("{} are both present: keep one (which of them holds {} is ambiguous)",
                         fmt::join(names, " and "), stem));
      file_of_[stem] = *names.begin();
    }
  }

  bool has(const std::string& role) const override { return file_of_.count(role) > 0; }
  std::string name(const std::string& role) const override {
    const auto it = file_of_.find(role);
    return it == file_of_.end() ? role + ".mtx" : it->second;
  }
  std::string label(const std::string& role) const override { return name(role); }
  std::string item() const override { return "file"; }
  fs::path file(const std::string& role) const { return dir_ / name(role); }

  std::string found_list() const override {
    return found_.empty() ? "no .mtx or .mtx.gz files" : fmt::format("{}", fmt::join(found_, ", "));
  }

  std::pair<Index, Index> shape(const std::string& role) const override {
    const MatrixMarketHeader h = read_matrix_market_header(file(role));
    return {h.rows, h.cols};
  }
  SparseMatrix sparse(const std::string& role) const override {
    return read_matrix_market_sparse(file(role));
  }
  Matrix dense(const std::string& role) const override {
    return read_matrix_market_dense(file(role));
  }
  /// The benchmark models' convention has no feedthrough: a D.mtx beside A.mtx is a misplaced file.
  void check_feedthrough() const override { forbid({"D"}, "descriptor", "E.mtx/A.mtx"); }

 private:
  /// "K" for "K.mtx" or "K.mtx.gz"; empty for any other name.
  static std::string matrix_stem(const std::string& name) {
    for (const std::string suffix : {".mtx", ".mtx.gz"})
      if (name.size() > suffix.size() &&
          name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
        return name.substr(0, name.size() - suffix.size());
    return {};
  }

  fs::path dir_;
  std::set<std::string> found_;
  std::map<std::string, std::string> file_of_;  // stem -> file name
};

/// "model <file>", with the renamed roles: "model m.mat (variables: K = Stiff, M = Mass)".
std::string mat_origin(const std::string& what, const fs::path& file,
                       const std::map<std::string, std::string>& variables) {
  std::string s = what + " " + file.string();
  std::string renamed;
  for (const auto& [role, var] : variables) {
    if (role == var) continue;
    renamed += (renamed.empty() ? "" : ", ") + role + " = " + var;
  }
  return renamed.empty() ? s : s + " (variables: " + renamed + ")";
}

/// A .mat file: roles are read from the variables of their own names unless renamed.
class MatModel final : public Container {
 public:
  MatModel(const fs::path& file, const std::string& what,
           const std::map<std::string, std::string>& variables,
           const std::vector<std::string>& roles)
      : Container(mat_origin(what, file, variables)), reader_(file, origin()) {
    std::map<std::string, std::string> role_of;  // variable -> role
    for (const auto& [role, var] : variables) {
      if (std::find(roles.begin(), roles.end(), role) == roles.end())
        fail(fmt::format("variables: unknown role '{}' (roles: {})", role, fmt::join(roles, ", ")));
      if (var.empty()) fail("variables: " + role + " is renamed to an empty name");
    }
    for (const std::string& role : roles) {
      const auto it = variables.find(role);
      const std::string var = it == variables.end() ? role : it->second;
      if (const auto [other, fresh] = role_of.emplace(var, role); !fresh)
        fail("variables: " + other->second + " and " + role + " are both read from variable " +
             var + ": each matrix needs its own variable");
      var_[role] = var;
    }
  }

  bool has(const std::string& role) const override { return reader_.has(name(role)); }
  std::string name(const std::string& role) const override {
    const auto it = var_.find(role);
    return it == var_.end() ? role : it->second;
  }
  std::string label(const std::string& role) const override { return "variable " + name(role); }
  std::string item() const override { return "variable"; }
  std::string found_list() const override { return reader_.found_list(); }
  std::pair<Index, Index> shape(const std::string& role) const override {
    return reader_.shape(name(role));
  }
  SparseMatrix sparse(const std::string& role) const override { return reader_.sparse(name(role)); }
  Matrix dense(const std::string& role) const override { return reader_.dense(name(role)); }

  /// MATLAB state-space files (ss/dss objects saved as A, B, C, D, E) carry the feedthrough D. An
  /// all-zero D is the usual case and means the same as none; any other value would change H(s)
  /// by a constant that ecmor's models cannot hold, so it is refused rather than dropped.
  void check_feedthrough() const override {
    const SparseMatrix D = sparse("D");
    for (Index j = 0; j < D.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(D, j); it; ++it)
        if (it.value() != 0.0)
          fail(label("D") + " beside " + label("A") +
               " is the feedthrough (y = C x + D u) and is non-zero (D(" +
               std::to_string(it.row() + 1) + ", " + std::to_string(it.col() + 1) +
               ") = " + fmt::format("{}", it.value()) +
               "): ecmor's descriptor models have no feedthrough term; remove D or set it to "
               "zero");
  }

 private:
  detail::MatReader reader_;
  std::map<std::string, std::string> var_;  // role -> variable
};

struct Shape {
  std::string label;
  Index rows = 0, cols = 0;
  std::string str() const {
    return label + " is " + std::to_string(rows) + " x " + std::to_string(cols);
  }
};

Shape shape_of(const Container& d, const std::string& role) {
  const auto [rows, cols] = d.shape(role);
  return Shape{d.label(role), rows, cols};
}

/// Checks the sizes the container declares against each other before anything large is loaded.
/// `defining` is K or A; `square` the other coefficient matrices; C and optional Cv outputs.
void check_shapes(const Container& d, const std::string& defining,
                  const std::vector<std::string>& square, bool has_cv) {
  const Shape ref = shape_of(d, defining);
  if (ref.rows != ref.cols) d.fail(ref.str() + ": must be square");
  const Index n = ref.rows;
  const std::string n_str = std::to_string(n);
  for (const std::string& role : square) {
    if (!d.has(role)) continue;
    const Shape s = shape_of(d, role);
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
// A matrix this close to symmetric is treated as symmetric by the summary (is_positive_definite's
// default threshold).
constexpr double kSymmetryTol = 1e-10;

MatrixSummary summarize_sparse(const std::string& name, const SparseMatrix& A, bool check,
                               bool negate) {
  MatrixSummary s;
  s.name = name;
  s.rows = A.rows();
  s.cols = A.cols();
  s.nnz = A.nonZeros();
  s.relative_asymmetry = relative_asymmetry(A);
  s.definiteness = "not checked";
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
const std::vector<std::string> kReducedRoles = {"Mr", "Dr", "Kr", "Br", "Cr", "Cvr", "Er", "Ar"};

void remove_if_present(const fs::path& p) {
  std::error_code ec;
  fs::remove(p, ec);  // false without error when p does not exist
  if (ec) throw IoError("cannot remove stale file " + p.string() + ": " + ec.message());
}

/// The loader of both containers.
Model load_from(const Container& d) {
  const bool second = d.has("M") || d.has("K");
  const bool descriptor = d.has("E") || d.has("A");
  if (second && descriptor)
    d.fail("both a second-order (" + d.name("M") + ", " + d.name("K") + ") and a descriptor (" +
           d.name("E") + ", " + d.name("A") + ") " + d.item() +
           " set are present, the kind is ambiguous; found: " + d.found_list());
  if (!second && !descriptor)
    d.fail("no model " + d.item() + "s: expected " + d.name("M") + ", " + d.name("K") + ", " +
           d.name("B") + ", " + d.name("C") + " [, " + d.name("D") + ", " + d.name("Cv") +
           "] (second order) or [" + d.name("E") + ",] " + d.name("A") + ", " + d.name("B") + ", " +
           d.name("C") + " (descriptor); found: " + d.found_list());

  if (second) {
    d.require({"M", "K", "B", "C"}, "second-order");
    const bool has_cv = d.has("Cv");
    check_shapes(d, "K", {"M", "D"}, has_cv);
    SecondOrderModel m;
    m.K = d.sparse("K");
    m.M = d.sparse("M");
    if (d.has("D")) {
      m.D = d.sparse("D");
    } else {
      m.D.resize(m.K.rows(), m.K.cols());
      m.D.makeCompressed();
    }
    m.B = d.dense("B");
    m.C = d.dense("C");
    if (has_cv) m.Cv = d.dense("Cv");
    Model model(std::move(m));
    validate(model, d.origin());
    return model;
  }
  d.require({"A", "B", "C"}, "descriptor");
  if (d.has("D")) d.check_feedthrough();
  d.forbid({"Cv"}, "descriptor", d.name("E") + "/" + d.name("A"));
  check_shapes(d, "A", {"E"}, false);
  DescriptorModel m;
  m.A = d.sparse("A");
  m.E = d.has("E") ? d.sparse("E") : sparse_identity(m.A.rows());
  m.B = d.dense("B");
  m.C = d.dense("C");
  Model model(std::move(m));
  validate(model, d.origin());
  return model;
}

/// The reader of reduced models from both containers (dense; Dr absent: 0, Er absent: I).
ReducedModel read_reduced_from(const Container& d) {
  const bool second = d.has("Mr") || d.has("Kr");
  const bool descriptor = d.has("Er") || d.has("Ar");
  if (second && descriptor)
    d.fail("both a second-order (" + d.name("Mr") + ", " + d.name("Kr") + ") and a descriptor (" +
           d.name("Er") + ", " + d.name("Ar") + ") " + d.item() +
           " set are present, the kind is ambiguous; found: " + d.found_list());
  if (!second && !descriptor)
    d.fail("no reduced model " + d.item() + "s: expected " + d.name("Mr") + ", " + d.name("Dr") +
           ", " + d.name("Kr") + ", " + d.name("Br") + ", " + d.name("Cr") + " [, " +
           d.name("Cvr") + "] or " + d.name("Er") + ", " + d.name("Ar") + ", " + d.name("Br") +
           ", " + d.name("Cr") + "; found: " + d.found_list());
  ReducedModel model;
  if (second) {
    d.require({"Mr", "Kr", "Br", "Cr"}, "reduced second-order");
    ReducedSecondOrderModel m;
    m.M = d.dense("Mr");
    m.K = d.dense("Kr");
    m.D = d.has("Dr") ? d.dense("Dr") : Matrix::Zero(m.K.rows(), m.K.cols());
    m.B = d.dense("Br");
    m.C = d.dense("Cr");
    if (d.has("Cvr")) m.Cv = d.dense("Cvr");
    model = std::move(m);
  } else {
    d.require({"Ar", "Br", "Cr"}, "reduced descriptor");
    ReducedDescriptorModel m;
    m.A = d.dense("Ar");
    m.E = d.has("Er") ? d.dense("Er") : Matrix::Identity(m.A.rows(), m.A.cols());
    m.B = d.dense("Br");
    m.C = d.dense("Cr");
    model = std::move(m);
  }
  validate(model, d.origin());
  return model;
}

/// Calls f(name, matrix, kind) for each matrix of a reduced model, in the order written:
/// Mr Dr Kr Br Cr [Cvr] (second order) or Er Ar Br Cr (descriptor).
void for_each_reduced_matrix(
    const ReducedModel& model,
    const std::function<void(const std::string&, const Matrix&, const char*)>& f) {
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model)) {
    const char* kind = "second order";
    f("Mr", so->M, kind);
    f("Dr", so->D, kind);
    f("Kr", so->K, kind);
    f("Br", so->B, kind);
    f("Cr", so->C, kind);
    if (so->has_velocity_output()) f("Cvr", so->Cv, kind);
  } else {
    const auto& de = std::get<ReducedDescriptorModel>(model);
    const char* kind = "descriptor";
    f("Er", de.E, kind);
    f("Ar", de.A, kind);
    f("Br", de.B, kind);
    f("Cr", de.C, kind);
  }
}

}  // namespace

Model load_model(const ModelSource& source) {
  const fs::path& path = source.path;
  if (is_mat_path(path)) {
    const MatModel file(path, "model", source.variables, model_variable_roles());
    return load_from(file);
  }
  const ModelDir dir(path, "model " + path.string());
  if (!source.variables.empty())
    dir.fail(
        "'variables' renames the variables of a .mat file; a model directory has fixed file "
        "names (M.mtx, K.mtx, ...)");
  return load_from(dir);
}

Model load_model(const fs::path& path) { return load_model(ModelSource{path, {}}); }

void write_reduced_model(const fs::path& dir, const ReducedModel& model) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError("cannot create directory " + dir.string() + ": " + ec.message());
  const auto file = [&](const std::string& name) { return dir / (name + ".mtx"); };
  for_each_reduced_matrix(model, [&](const std::string& name, const Matrix& A, const char* kind) {
    write_matrix_market(file(name), A, "reduced model: " + name + " (" + kind + ")");
  });
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model)) {
    if (!so->has_velocity_output()) remove_if_present(file("Cvr"));
    // Files of a previously written model of the other kind would make the directory ambiguous.
    for (const std::string& n : kDescriptorReduced) remove_if_present(file(n));
  } else {
    for (const std::string& n : kSecondOrderReduced) remove_if_present(file(n));
  }
}

void write_reduction(const fs::path& dir, const ReducedModel& model, const Matrix& V,
                     const Matrix& W, OutputFormat format) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError("cannot create directory " + dir.string() + ": " + ec.message());
  if (format == OutputFormat::Mat) {
    for (const std::string& n : kReducedRoles) remove_if_present(dir / (n + ".mtx"));
    remove_if_present(dir / "V.mtx");
    remove_if_present(dir / "W.mtx");
  } else {
    write_reduced_model(dir, model);
    write_matrix_market(dir / "V.mtx", V, "right projection basis V");
    write_matrix_market(dir / "W.mtx", W, "left projection basis W");
  }
  const fs::path mat = dir / kReducedModelMatFile;
  if (format == OutputFormat::Mtx) {
    remove_if_present(mat);
    return;
  }
  write_named_file_atomically(mat, [&](const fs::path& tmp) {
    detail::MatWriter out(tmp, mat);
    for_each_reduced_matrix(
        model, [&](const std::string& name, const Matrix& A, const char*) { out.write(name, A); });
    out.write("V", V);
    // Galerkin (W = V, bit for bit): the file says so by leaving W out rather than doubling.
    const bool galerkin = W.rows() == V.rows() && W.cols() == V.cols() && W == V;
    if (!galerkin) out.write("W", W);
    out.close();
  });
}

void write_mat_file(const fs::path& path, const std::vector<NamedMatrix>& matrices,
                    const std::string& header) {
  write_named_file_atomically(path, [&](const fs::path& tmp) {
    detail::MatWriter out(tmp, path, header.c_str());
    for (const NamedMatrix& m : matrices) out.write(m.name, m.value);
    out.close();
  });
}

ProjectionBases read_projection_bases(const fs::path& run_dir) {
  std::error_code ec;
  if (const fs::path V = find_matrix_market_file(run_dir, "V"); !V.empty()) {
    const fs::path W = find_matrix_market_file(run_dir, "W");
    if (W.empty())
      throw InputError(run_dir.string() + ": " + V.filename().string() +
                       " is there but W.mtx (or W.mtx.gz) is missing");
    ProjectionBases b;
    b.V = read_matrix_market_dense(V);
    b.W = read_matrix_market_dense(W);
    return b;
  }
  const fs::path mat = run_dir / kReducedModelMatFile;
  if (!fs::is_regular_file(mat, ec))
    throw InputError(run_dir.string() + ": no projection bases: neither V.mtx nor " +
                     kReducedModelMatFile + " (the output of `ecmor reduce`)");
  const detail::MatReader file(mat, mat.string());
  ProjectionBases b;
  b.V = file.dense("V");
  b.W = file.has("W") ? file.dense("W") : b.V;
  return b;
}

ReducedModel read_reduced_model(const fs::path& path) {
  if (is_mat_path(path)) {
    const MatModel file(path, "reduced model", {}, kReducedRoles);
    return read_reduced_from(file);
  }
  const ModelDir dir(path, "reduced model " + path.string());
  const bool has_mtx = std::any_of(kReducedRoles.begin(), kReducedRoles.end(),
                                   [&](const std::string& r) { return dir.has(r); });
  std::error_code ec;
  if (!has_mtx && fs::is_regular_file(path / kReducedModelMatFile, ec)) {
    const MatModel file(path / kReducedModelMatFile, "reduced model", {}, kReducedRoles);
    return read_reduced_from(file);
  }
  return read_reduced_from(dir);
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
    if (const auto form = second_order_form(de)) {
      s.second_order_size = form->size();
      s.second_order_symmetric = relative_asymmetry(form->M) <= kSymmetryTol &&
                                 relative_asymmetry(form->D) <= kSymmetryTol &&
                                 relative_asymmetry(form->K) <= kSymmetryTol;
    }
  }
  return s;
}

}  // namespace ecmor
