// adi_ops.cpp: the dense norms of adi_ops.hpp.
#include "gramians/adi_ops.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>

namespace ecmor::detail {

double gram_norm(const Matrix& X) {
  if (X.cols() == 0) return 0.0;
  const Matrix G = X.transpose() * X;
  return Eigen::SelfAdjointEigenSolver<Matrix>(G, Eigen::EigenvaluesOnly).eigenvalues().maxCoeff();
}

std::pair<Vector, Matrix> gram_eigen(const Matrix& X) {
  Matrix G = Matrix::Zero(X.cols(), X.cols());
  G.selfadjointView<Eigen::Lower>().rankUpdate(X.transpose());
  Eigen::SelfAdjointEigenSolver<Matrix> es(G.selfadjointView<Eigen::Lower>());
  return {es.eigenvalues().reverse(), es.eigenvectors().rowwise().reverse()};
}

double ldl_norm(const Matrix& W, const Matrix& S) {
  if (W.cols() == 0) return 0.0;
  const Eigen::HouseholderQR<Matrix> qr(W);
  const Index k = std::min(W.rows(), W.cols());
  const Matrix R = qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
  const Matrix T = R * S * R.transpose();
  const Vector ev =
      Eigen::SelfAdjointEigenSolver<Matrix>(Matrix((T + T.transpose()) / 2), Eigen::EigenvaluesOnly)
          .eigenvalues();
  return std::max(std::abs(ev.minCoeff()), std::abs(ev.maxCoeff()));
}

}  // namespace ecmor::detail
