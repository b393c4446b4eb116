#include "ecmor/model/projection.hpp"

#include <cmath>
#include <string>

#include "ecmor/base/error.hpp"

namespace ecmor {
namespace {

void check_bases(Index n_full, const Matrix& V, const Matrix& W) {
  auto shape = [](const Matrix& X) {
    return std::to_string(X.rows()) + " x " + std::to_string(X.cols());
  };
  if (V.rows() != n_full || W.rows() != n_full || V.cols() != W.cols()) {
    throw InputError("projection: V is " + shape(V) + " and W is " + shape(W) +
                     ": both must be N x n with N = " + std::to_string(n_full));
  }
  if (!V.allFinite() || !W.allFinite()) {
    throw NumericalError("projection: the basis V or W contains NaN or Inf");
  }
}

// W' A V for sparse A: one sparse-times-dense product, then a small dense one.
Matrix galerkin(const Matrix& W, const SparseMatrix& A, const Matrix& V) {
  if (A.nonZeros() == 0) return Matrix::Zero(W.cols(), V.cols());
  Matrix AV = A * V;
  return W.transpose() * AV;
}

}  // namespace

ReducedSecondOrderModel project(const SecondOrderModel& model, const Matrix& V, const Matrix& W) {
  check_bases(model.size(), V, W);
  ReducedSecondOrderModel r;
  r.M = galerkin(W, model.M, V);
  r.D = galerkin(W, model.D, V);
  r.K = galerkin(W, model.K, V);
  r.B = W.transpose() * model.B;
  r.C = model.C * V;
  if (model.has_velocity_output()) r.Cv = model.Cv * V;
  return r;
}

ReducedDescriptorModel project(const DescriptorModel& model, const Matrix& V, const Matrix& W) {
  check_bases(model.size(), V, W);
  ReducedDescriptorModel r;
  r.E = galerkin(W, model.E, V);
  r.A = galerkin(W, model.A, V);
  r.B = W.transpose() * model.B;
  r.C = model.C * V;
  return r;
}

ReducedModel project(const Model& model, const Matrix& V, const Matrix& W) {
  return std::visit([&](const auto& m) -> ReducedModel { return project(m, V, W); }, model);
}

namespace {

Vector apply_gram(const InnerProduct& ip, const Eigen::Ref<const Vector>& x) {
  if (ip.G == nullptr) return x;
  return (*ip.G) * x;
}

}  // namespace

Index orthonormalize_append(Matrix& Q, const Matrix& X, const InnerProduct& ip,
                            double deflation_tol) {
  if (Q.size() != 0 && Q.rows() != X.rows()) {
    throw InputError("orthonormalize_append: Q has " + std::to_string(Q.rows()) +
                     " rows but X has " + std::to_string(X.rows()));
  }
  if (!X.allFinite()) {
    throw NumericalError("orthonormalize_append: a new basis vector contains NaN or Inf");
  }
  const Index n = X.rows();
  Index k = Q.cols();
  Q.conservativeResize(n, k + X.cols());
  // G Q, kept alongside Q so that each projection costs one dense product with Q' (no sparse
  // product per Gram-Schmidt sweep).
  Matrix GQ = (ip.G == nullptr) ? Matrix() : Matrix((*ip.G) * Q.leftCols(k));
  Index appended = 0;
  for (Index j = 0; j < X.cols(); ++j) {
    Vector x = X.col(j);
    Vector gx = apply_gram(ip, x);
    const double norm0 = std::sqrt(std::max(0.0, x.dot(gx)));
    if (!(norm0 > 0.0)) continue;
    double norm = norm0;
    // Classical Gram-Schmidt, repeated once: "twice is enough" (Giraud, Langou, Rozloznik) keeps
    // ||Q'GQ - I|| at round-off level unless the column is numerically dependent, which the
    // deflation test catches.
    for (int pass = 0; pass < 2 && k > 0; ++pass) {
      const Vector h = (ip.G == nullptr) ? Vector(Q.leftCols(k).transpose() * x)
                                         : Vector(GQ.leftCols(k).transpose() * x);
      x.noalias() -= Q.leftCols(k) * h;
      gx = apply_gram(ip, x);
      norm = std::sqrt(std::max(0.0, x.dot(gx)));
    }
    if (norm <= deflation_tol * norm0) continue;  // (nearly) dependent: deflate
    Q.col(k) = x / norm;
    if (ip.G != nullptr) {
      GQ.conservativeResize(n, k + 1);
      GQ.col(k) = gx / norm;
    }
    ++k;
    ++appended;
  }
  Q.conservativeResize(n, k);
  return appended;
}

double orthogonality_loss(const Matrix& Q, const InnerProduct& ip) {
  if (Q.cols() == 0) return 0.0;
  const Matrix gram =
      (ip.G == nullptr) ? Matrix(Q.transpose() * Q) : Matrix(Q.transpose() * ((*ip.G) * Q));
  return (gram - Matrix::Identity(Q.cols(), Q.cols())).cwiseAbs().maxCoeff();
}

}  // namespace ecmor
