#pragma once
/// \file dense_balanced_truncation.hpp
/// A dense square-root balanced truncation REFERENCE for small stable models (E nonsingular), for
/// tests (e.g. IRKA's): Gramians P, Q from ecmor::gramians, factors P = Lp Lp', Q = Lq Lq' from
/// symmetric eigendecompositions (negative eigenvalues, rounding noise of semidefinite Gramians,
/// clipped to 0), the SVD Lq' E Lp = U S Z', and the Petrov-Galerkin bases
///     V = Lp Z_r S_r^-1/2,   W = Lq U_r S_r^-1/2   (W' E V = I_r),
/// giving Er = I, Ar = W' A V, Br = W' B, Cr = C V. Moore (1981); Tombs and Postlethwaite (1987).
/// The reduced model is stable and ||G - Gr||_inf <= 2 (s_{r+1} + ... + s_n) (Glover 1984).
/// Written independently of the library's DenseBalancing (gramians/balancing.hpp), which IRKA's
/// balanced start uses: a test oracle must not share the code it checks.
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <stdexcept>

#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::test {

struct BalancedTruncation {
  ReducedDescriptorModel model;  ///< order r, Er = I
  Vector hankel;                 ///< all Hankel singular values, descending
  Matrix V, W;                   ///< the projection bases of the first-order realisation
};

/// A factor L with L L' = X for a symmetric positive semidefinite X (eigenvalues below 0 clipped).
inline Matrix psd_factor(const Matrix& X) {
  const Eigen::SelfAdjointEigenSolver<Matrix> es(0.5 * (X + X.transpose()));
  const Vector d = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return es.eigenvectors() * d.asDiagonal();
}

/// Balanced truncation of a stable dense model (of either kind, through its first-order
/// realisation) to order r, 1 <= r <= n, with s_r > 0.
inline BalancedTruncation dense_balanced_truncation(const ReducedModel& model, Index r) {
  const ReducedDescriptorModel fo = first_order_realization(model);
  const Gramians g = gramians(model);
  const Matrix Lp = psd_factor(g.P), Lq = psd_factor(g.Q);
  const Eigen::BDCSVD<Matrix> svd(Lq.transpose() * fo.E * Lp,
                                  Eigen::ComputeThinU | Eigen::ComputeThinV);
  BalancedTruncation bt;
  bt.hankel = svd.singularValues();
  if (r < 1 || r > bt.hankel.size() || !(bt.hankel(r - 1) > 0.0))
    throw std::invalid_argument("dense_balanced_truncation: order r out of range or s_r = 0");
  const Vector s = bt.hankel.head(r).cwiseSqrt().cwiseInverse();
  bt.V = Lp * svd.matrixV().leftCols(r) * s.asDiagonal();
  bt.W = Lq * svd.matrixU().leftCols(r) * s.asDiagonal();
  bt.model.E = bt.W.transpose() * fo.E * bt.V;
  bt.model.A = bt.W.transpose() * fo.A * bt.V;
  bt.model.B = bt.W.transpose() * fo.B;
  bt.model.C = fo.C * bt.V;
  return bt;
}

}  // namespace ecmor::test
