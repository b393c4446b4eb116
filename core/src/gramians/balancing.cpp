#include "ecmor/gramians/balancing.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <string>

#include "ecmor/base/error.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/model/dense_model.hpp"

namespace ecmor {
namespace {

/// L with L L' = X for a symmetric positive semidefinite X (eigenvalues below 0 clipped).
Matrix psd_factor(const Matrix& X) {
  const Eigen::SelfAdjointEigenSolver<Matrix> es(0.5 * (X + X.transpose()));
  return es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
}

}  // namespace

DenseBalancing::DenseBalancing(const ReducedModel& model) : m_fo(first_order_realization(model)) {
  const Gramians g = gramians(model);
  m_lp = psd_factor(g.P);
  m_lq = psd_factor(g.Q);
  const Eigen::BDCSVD<Matrix> svd(m_lq.transpose() * m_fo.E * m_lp,
                                  Eigen::ComputeThinU | Eigen::ComputeThinV);
  m_u = svd.matrixU();
  m_z = svd.matrixV();
  m_s = svd.singularValues();
}

Index DenseBalancing::positive_count() const {
  Index k = 0;
  while (k < m_s.size() && m_s(k) > 0.0) ++k;
  return k;
}

void DenseBalancing::bases(Index r, Matrix& V, Matrix& W) const {
  if (r < 1 || r > positive_count())
    throw InputError("balanced truncation: order " + std::to_string(r) + " is outside [1, " +
                     std::to_string(positive_count()) +
                     "], the number of positive Hankel singular values");
  const Vector scale = m_s.head(r).cwiseSqrt().cwiseInverse();
  V = m_lp * m_z.leftCols(r) * scale.asDiagonal();
  W = m_lq * m_u.leftCols(r) * scale.asDiagonal();
}

ReducedDescriptorModel DenseBalancing::truncate(Index r) const {
  Matrix V, W;
  bases(r, V, W);
  ReducedDescriptorModel reduced;
  reduced.E = W.transpose() * m_fo.E * V;
  reduced.A = W.transpose() * m_fo.A * V;
  reduced.B = W.transpose() * m_fo.B;
  reduced.C = m_fo.C * V;
  return reduced;
}

}  // namespace ecmor
