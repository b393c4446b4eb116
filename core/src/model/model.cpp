// model.cpp: model accessors, structural validation, symmetry and definiteness checks (CHOLMOD).
#include "ecmor/model/model.hpp"

#include <cholmod.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "ecmor/base/error.hpp"

namespace ecmor {
namespace {

std::string dims(Index r, Index c) { return std::to_string(r) + " x " + std::to_string(c); }

template <class Mat>
std::string dims(const Mat& A) {
  return dims(A.rows(), A.cols());
}

std::string sci(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

class Validator {
 public:
  explicit Validator(std::string_view origin) : origin_(origin) {}

  [[noreturn]] void fail(const std::string& rule) const { throw InputError(origin_ + ": " + rule); }

  /// Square coefficient matrix defining N (K or A).
  template <class Mat>
  Index defining(const Mat& A, const char* name) const {
    if (A.rows() != A.cols()) fail(std::string(name) + " is " + dims(A) + ": must be square");
    if (A.rows() == 0) fail(std::string(name) + " is 0 x 0: the model has no states");
    return A.rows();
  }

  template <class Mat>
  void coefficient(const Mat& A, const char* name, Index n, const char* ref) const {
    if (A.rows() != A.cols()) fail(std::string(name) + " is " + dims(A) + ": must be square");
    if (A.rows() != n)
      fail(std::string(name) + " is " + dims(A) + ": must be N x N = " + dims(n, n) +
           " (the size of " + ref + ")");
  }

  void input(const Matrix& B, Index n, const char* ref) const {
    if (B.rows() != n)
      fail("B has " + std::to_string(B.rows()) + " rows: must equal N = " + std::to_string(n) +
           " (the size of " + ref + ")");
    if (B.cols() == 0) fail("B is " + dims(B) + ": the model needs at least one input");
  }

  void output(const Matrix& C, const char* name, Index n, const char* ref) const {
    if (C.cols() != n)
      fail(std::string(name) + " has " + std::to_string(C.cols()) +
           " columns: must equal N = " + std::to_string(n) + " (the size of " + ref + ")");
    if (C.rows() == 0)
      fail(std::string(name) + " is " + dims(C) + ": the model needs at least one output");
  }

  void finite(const SparseMatrix& A, const char* name) const {
    for (Index j = 0; j < A.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(A, j); it; ++it)
        if (!std::isfinite(it.value())) nonfinite(name, it.row(), it.col(), it.value());
  }
  void finite(const Matrix& A, const char* name) const {
    if (A.allFinite()) return;
    for (Index j = 0; j < A.cols(); ++j)
      for (Index i = 0; i < A.rows(); ++i)
        if (!std::isfinite(A(i, j))) nonfinite(name, i, j, A(i, j));
  }

 private:
  [[noreturn]] void nonfinite(const char* name, Index i, Index j, double v) const {
    fail(std::string(name) + " has a non-finite value (" + (std::isnan(v) ? "NaN" : "Inf") +
         ") at (" + std::to_string(i + 1) + ", " + std::to_string(j + 1) + ")");
  }
  std::string origin_;
};

template <class Mat>
void validate_second_order(const SecondOrderSystem<Mat>& m, std::string_view origin) {
  const Validator v(origin);
  const Index n = v.defining(m.K, "K");
  v.coefficient(m.M, "M", n, "K");
  v.coefficient(m.D, "D", n, "K");
  v.input(m.B, n, "K");
  v.output(m.C, "C", n, "K");
  if (m.has_velocity_output()) {
    v.output(m.Cv, "Cv", n, "K");
    if (m.Cv.rows() != m.C.rows())
      v.fail("Cv is " + dims(m.Cv) + " but C is " + dims(m.C) +
             ": C and Cv must have the same number of rows (outputs)");
  }
  v.finite(m.M, "M");
  v.finite(m.D, "D");
  v.finite(m.K, "K");
  v.finite(m.B, "B");
  v.finite(m.C, "C");
  v.finite(m.Cv, "Cv");
}

template <class Mat>
void validate_descriptor(const DescriptorSystem<Mat>& m, std::string_view origin) {
  const Validator v(origin);
  const Index n = v.defining(m.A, "A");
  v.coefficient(m.E, "E", n, "A");
  v.input(m.B, n, "A");
  v.output(m.C, "C", n, "A");
  v.finite(m.E, "E");
  v.finite(m.A, "A");
  v.finite(m.B, "B");
  v.finite(m.C, "C");
}

/// Result of a Cholesky attempt.
struct CholeskyResult {
  bool success = false;
  Index failed_column = -1;  ///< 0-based column where the factorisation broke down
  double rcond = 0.0;        ///< CHOLMOD's cheap reciprocal condition estimate of L
};

/// Cholesky factorisation with CHOLMOD of the symmetric part of square A (lower triangle used).
CholeskyResult cholesky(const SparseMatrix& A_in) {
  CholeskyResult r;
  const Index n = A_in.rows();
  if (n == 0) {
    r.success = true;
    r.rcond = 1.0;
    return r;
  }
  // Symmetric part, lower triangle, compressed (CHOLMOD reads stype = -1: lower part only).
  SparseMatrix At = A_in.transpose();
  SparseMatrix S = 0.5 * (A_in + At);
  // Symmetric diagonal (Jacobi) scaling: definiteness is invariant under it, and it makes the
  // singularity test below independent of how badly the matrix is scaled (lf10's M: 3e-11..7e-5).
  Vector d = S.diagonal();
  for (Index i = 0; i < n; ++i) {
    if (!(d(i) > 0.0)) {  // a non-positive (or NaN) diagonal entry: not positive definite
      r.failed_column = i;
      return r;
    }
    d(i) = 1.0 / std::sqrt(d(i));
  }
  S = d.asDiagonal() * S * d.asDiagonal();
  SparseMatrix L = S.triangularView<Eigen::Lower>();
  L.makeCompressed();

  cholmod_common c;
  cholmod_start(&c);
  c.print = 0;  // no "CHOLMOD warning: not positive definite" on stderr
  c.error_handler = nullptr;
  c.quick_return_if_not_posdef = 1;
  c.supernodal = CHOLMOD_AUTO;
  c.final_ll = 1;

  cholmod_sparse cs{};
  cs.nrow = static_cast<std::size_t>(n);
  cs.ncol = static_cast<std::size_t>(n);
  cs.nzmax = static_cast<std::size_t>(L.nonZeros());
  cs.p = L.outerIndexPtr();
  cs.i = L.innerIndexPtr();
  cs.nz = nullptr;
  cs.x = L.valuePtr();
  cs.z = nullptr;
  cs.stype = -1;
  cs.itype = CHOLMOD_INT;
  cs.xtype = CHOLMOD_REAL;
  cs.dtype = CHOLMOD_DOUBLE;
  cs.sorted = 1;
  cs.packed = 1;

  cholmod_factor* f = cholmod_analyze(&cs, &c);
  if (f != nullptr) {
    cholmod_factorize(&cs, f, &c);
    if (c.status == CHOLMOD_OK && f->minor == f->n) {
      r.success = true;
      r.rcond = cholmod_rcond(f, &c);
    } else if (f->minor < f->n) {
      // f->minor counts columns of the fill-reducing permuted matrix; report the user's column.
      const auto* perm = static_cast<const int*>(f->Perm);
      r.failed_column = static_cast<Index>(perm != nullptr ? perm[f->minor] : f->minor);
    }
    cholmod_free_factor(&f, &c);
  }
  cholmod_finish(&c);
  return r;
}

/// A factorisation (of the Jacobi-scaled matrix) whose pivots span more than this ratio
/// (CHOLMOD's rcond = (min/max diag L)^2) is treated as numerically singular: a singular
/// positive semidefinite matrix typically factors with a last pivot of order n eps. (Since the
/// pivots bound the extreme eigenvalues, only matrices with condition number > 1 / (n eps) after
/// scaling can be flagged.)
double singular_rcond(Index n) {
  return static_cast<double>(std::max<Index>(n, 1)) * std::numeric_limits<double>::epsilon();
}

}  // namespace

std::string to_string(ModelKind kind) {
  switch (kind) {
    case ModelKind::SecondOrder:
      return "second order";
    case ModelKind::Descriptor:
      return "descriptor";
  }
  return "unknown";
}

ModelKind kind_of(const Model& model) {
  return std::holds_alternative<SecondOrderModel>(model) ? ModelKind::SecondOrder
                                                         : ModelKind::Descriptor;
}
ModelKind kind_of(const ReducedModel& model) {
  return std::holds_alternative<ReducedSecondOrderModel>(model) ? ModelKind::SecondOrder
                                                                : ModelKind::Descriptor;
}
Index size_of(const Model& model) {
  return std::visit([](const auto& m) { return m.size(); }, model);
}
Index size_of(const ReducedModel& model) {
  return std::visit([](const auto& m) { return m.size(); }, model);
}
Index inputs_of(const Model& model) {
  return std::visit([](const auto& m) { return m.inputs(); }, model);
}
Index outputs_of(const Model& model) {
  return std::visit([](const auto& m) { return m.outputs(); }, model);
}
Index inputs_of(const ReducedModel& model) {
  return std::visit([](const auto& m) { return m.inputs(); }, model);
}
Index outputs_of(const ReducedModel& model) {
  return std::visit([](const auto& m) { return m.outputs(); }, model);
}

void validate(const Model& model, std::string_view origin) {
  if (const auto* so = std::get_if<SecondOrderModel>(&model))
    validate_second_order(*so, origin);
  else
    validate_descriptor(std::get<DescriptorModel>(model), origin);
}

void validate(const ReducedModel& model, std::string_view origin) {
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model))
    validate_second_order(*so, origin);
  else
    validate_descriptor(std::get<ReducedDescriptorModel>(model), origin);
}

double relative_asymmetry(const SparseMatrix& A) {
  if (A.rows() != A.cols()) return std::numeric_limits<double>::infinity();
  const double norm = A.norm();
  if (norm == 0.0) return 0.0;
  const SparseMatrix At = A.transpose();
  const SparseMatrix diff = A - At;
  return diff.norm() / norm;
}

double relative_asymmetry(const Matrix& A) {
  if (A.rows() != A.cols()) return std::numeric_limits<double>::infinity();
  const double norm = A.norm();
  if (norm == 0.0) return 0.0;
  return (A - A.transpose()).norm() / norm;
}

bool is_positive_definite(const SparseMatrix& A, double symmetry_tol) {
  if (A.rows() != A.cols()) return false;
  if (!(relative_asymmetry(A) <= symmetry_tol)) return false;
  const CholeskyResult r = cholesky(A);
  return r.success && r.rcond > singular_rcond(A.rows());
}

void require_spd_mass(const Model& model, std::string_view origin, double symmetry_tol) {
  const bool second = kind_of(model) == ModelKind::SecondOrder;
  const SparseMatrix& A =
      second ? std::get<SecondOrderModel>(model).M : std::get<DescriptorModel>(model).E;
  const std::string name = second ? "M" : "E";
  const std::string prefix = std::string(origin) + ": " + name;
  if (A.rows() != A.cols()) throw InputError(prefix + " is " + dims(A) + ": must be square");
  const double asym = relative_asymmetry(A);
  if (!(asym <= symmetry_tol))
    throw InputError(prefix + " is not symmetric (relative asymmetry " + sci(asym) + " > " +
                     sci(symmetry_tol) + ")");
  const CholeskyResult r = cholesky(A);
  if (!r.success) {
    if (r.failed_column >= 0)
      throw InputError(prefix + " is not positive definite (Cholesky failed at column " +
                       std::to_string(r.failed_column + 1) + ")");
    throw InputError(prefix + " is not positive definite (Cholesky failed)");
  }
  if (!(r.rcond > singular_rcond(A.rows())))
    throw InputError(prefix + " is numerically singular (Cholesky pivot ratio estimate " +
                     sci(r.rcond) + ")");
}

namespace {

/// The four n x n blocks of an N x N sparse matrix (N = 2n), each built from the stored values
/// that are nonzero (an explicitly stored zero is no coupling).
struct Blocks {
  SparseMatrix b11, b12, b21, b22;
};

Blocks split(const SparseMatrix& X, Index n) {
  using Triplet = Eigen::Triplet<double, SparseMatrix::StorageIndex>;
  std::vector<Triplet> t[2][2];
  for (Index j = 0; j < X.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(X, j); it; ++it) {
      if (it.value() == 0.0) continue;
      const Index r = it.row(), c = it.col();
      const int bi = r < n ? 0 : 1, bj = c < n ? 0 : 1;
      t[bi][bj].emplace_back(static_cast<SparseMatrix::StorageIndex>(r - bi * n),
                             static_cast<SparseMatrix::StorageIndex>(c - bj * n), it.value());
    }
  }
  Blocks b;
  SparseMatrix* out[2][2] = {{&b.b11, &b.b12}, {&b.b21, &b.b22}};
  for (int i = 0; i < 2; ++i) {
    for (int k = 0; k < 2; ++k) {
      out[i][k]->resize(n, n);
      // No duplicates: each (row, col) of X is stored once in a compressed or uncompressed matrix.
      out[i][k]->setFromTriplets(t[i][k].begin(), t[i][k].end());
    }
  }
  return b;
}

/// True if the sparse matrices hold the same nonzero values at the same positions (bit for bit).
bool same_entries(const SparseMatrix& X, const SparseMatrix& Y) {
  if (X.rows() != Y.rows() || X.cols() != Y.cols() || X.nonZeros() != Y.nonZeros()) return false;
  for (Index j = 0; j < X.outerSize(); ++j) {
    SparseMatrix::InnerIterator a(X, j), b(Y, j);
    for (; a && b; ++a, ++b) {
      if (a.row() != b.row() || a.value() != b.value()) return false;
    }
    if (a || b) return false;
  }
  return true;
}

}  // namespace

std::optional<SecondOrderModel> second_order_form(const DescriptorModel& model) {
  const Index N = model.A.rows();
  // Shapes first: a malformed model is simply "not this pattern" (validate() names its faults).
  if (N < 2 || N % 2 != 0 || model.A.cols() != N || model.E.rows() != N || model.E.cols() != N ||
      model.B.rows() != N || model.C.cols() != N) {
    return std::nullopt;
  }
  const Index n = N / 2;
  // B1 = 0: the input drives the velocity equation only.
  if (model.B.cols() > 0 && model.B.topRows(n).cwiseAbs().maxCoeff() != 0.0) return std::nullopt;
  Blocks e = split(model.E, n);
  if (e.b12.nonZeros() > 0 || e.b21.nonZeros() > 0) return std::nullopt;
  Blocks a = split(model.A, n);
  if (a.b11.nonZeros() > 0) return std::nullopt;
  // A12 == E11 exactly: the first block row is E11 q' = E11 v, i.e. q' = v once E11 is
  // nonsingular (checked last: the Cholesky is the only non-trivial cost).
  e.b11.makeCompressed();
  a.b12.makeCompressed();
  if (!same_entries(a.b12, e.b11)) return std::nullopt;
  if (!is_positive_definite(e.b11)) return std::nullopt;

  SecondOrderModel so;
  so.M = std::move(e.b22);
  so.K = -a.b21;
  so.D = -a.b22;
  so.M.makeCompressed();
  so.K.makeCompressed();
  so.D.makeCompressed();
  so.B = model.B.bottomRows(n);
  so.C = model.C.leftCols(n);
  const Matrix C2 = model.C.rightCols(n);
  if (C2.size() > 0 && C2.cwiseAbs().maxCoeff() != 0.0) so.Cv = C2;
  return so;
}

}  // namespace ecmor
