#pragma once
// incremental_projection.hpp: the Petrov-Galerkin projection of the krylov plugin, kept across
// requests. Private to the plugin (see README.md, "What is incremental").
//
// Strategies call reduce() with point lists that extend the previous one, so the leading columns
// of V (and W) stay fixed while columns are appended or the tail after a kept prefix is rebuilt.
// ecmor::project recomputes W' T V for every coefficient matrix T from scratch, O(N n^2) each per
// call; here the reduced blocks of the first p columns are kept, and going to n columns computes
// only the new rows and columns:
//
//     [ Tr_old           W_old' (T V_new) ]
//     [ (T' W_new)' V_old   W_new' (T V_new) ]
//
// i.e. O(nnz(T) k + N n k) for k new columns. The lower-left block uses T' W_new instead of the
// products T V_old, so nothing N x n is stored besides V and W themselves (the extra memory is the
// n x n reduced blocks); for a symmetric T (exactly, checked once) T' W_new = T W_new, and
// one-sided (W = V) the lower-left block is the transpose of the upper-right one: only the upper
// triangle is computed and mirrored, so Mr, Dr, Kr are exactly symmetric. The Gram matrices V'V
// (and W'W, W'V two-sided) are kept the same way (T = I) for the orthogonality diagnostics.
#include <fmt/format.h>

#include <algorithm>
#include <variant>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::krylov {

/// Grows the reduced matrices W' T V, W' B, C V (and the Gram matrices) column by column.
class IncrementalProjection {
 public:
  /// Binds to a full model (which must outlive this object) and records which coefficient
  /// matrices are exactly symmetric. Starts empty. `extra` (N x N, outliving this object, may be
  /// nullptr) is one more matrix projected alongside the model's, W' extra V, e.g. the block E11
  /// of a first-order model reduced through its second-order form.
  explicit IncrementalProjection(const Model* model, const SparseMatrix* extra = nullptr)
      : m_model(model) {
    if (const auto* so = std::get_if<SecondOrderModel>(model)) {
      m_ops = {&so->M, &so->D, &so->K};
      m_B = &so->B;
      m_C = &so->C;
      if (so->has_velocity_output()) m_Cv = &so->Cv;
    } else {
      const auto& ds = std::get<DescriptorModel>(*model);
      m_ops = {&ds.E, &ds.A};
      m_B = &ds.B;
      m_C = &ds.C;
    }
    m_has_extra = extra != nullptr;
    if (m_has_extra) m_ops.push_back(extra);
    for (const SparseMatrix* T : m_ops) m_symmetric.push_back(relative_asymmetry(*T) == 0.0);
    m_reduced.assign(m_ops.size(), Matrix(0, 0));
    m_Br.resize(0, m_B->cols());
    m_Cr.resize(m_C->rows(), 0);
    if (m_Cv != nullptr) m_Cvr.resize(m_Cv->rows(), 0);
  }

  /// Forgets everything (no columns projected).
  void reset() { keep(0); }

  /// Keeps the projection of the first `columns` columns only: the caller is about to change V
  /// (or W) after them. Columns before them must be unchanged (bit for bit) at the next extend().
  void keep(Index columns) {
    const Index p = std::min(columns, m_p);
    for (Matrix& R : m_reduced) R = Matrix(R.topLeftCorner(p, p));
    m_Br = Matrix(m_Br.topRows(p));
    m_Cr = Matrix(m_Cr.leftCols(p));
    if (m_Cv != nullptr) m_Cvr = Matrix(m_Cvr.leftCols(p));  // 0 x 0 without a velocity output
    m_Gvv = Matrix(m_Gvv.topLeftCorner(p, p));
    // W'W and W'V exist two-sided only (0 x 0 otherwise).
    const Index pw = std::min(p, m_Gww.rows());
    m_Gww = Matrix(m_Gww.topLeftCorner(pw, pw));
    m_Gwv = Matrix(m_Gwv.topLeftCorner(pw, pw));
    m_p = p;
  }

  /// Number of columns projected so far.
  Index columns() const { return m_p; }

  /// Projects the first n columns of V and W (W is ignored one-sided: W = V), computing only the
  /// columns beyond columns(). Strong guarantee: on a throw nothing changes.
  /// \throws NumericalError if a new column of V or W is not finite.
  void extend(const Matrix& V, const Matrix& W, Index n, bool two_sided) {
    if (n <= m_p) return;
    const Index p = m_p, k = n - p;
    const auto Vo = V.leftCols(p);
    const auto Vn = V.middleCols(p, k);
    const auto Wo = two_sided ? W.leftCols(p) : V.leftCols(p);
    const auto Wn = two_sided ? W.middleCols(p, k) : V.middleCols(p, k);
    if (!Vn.allFinite() || !Wn.allFinite()) {
      throw NumericalError("projection: the basis V or W contains NaN or Inf");
    }
    std::vector<Matrix> reduced(m_ops.size());
    for (std::size_t t = 0; t < m_ops.size(); ++t) {
      const SparseMatrix& T = *m_ops[t];
      Matrix R = Matrix::Zero(n, n);
      R.topLeftCorner(p, p) = m_reduced[t];
      if (T.nonZeros() > 0 && !two_sided && m_symmetric[t]) {
        // V'TV with T symmetric: the upper triangle, mirrored. Half the dense work, and Tr is
        // exactly symmetric (not only to rounding), which the stability certificate needs.
        const Matrix TVn = T * Vn;
        R.topRightCorner(p, k).noalias() = Vo.transpose() * TVn;
        R.bottomLeftCorner(k, p) = R.topRightCorner(p, k).transpose();
        auto Rnn = R.bottomRightCorner(k, k);
        Rnn.template triangularView<Eigen::Upper>() = Vn.transpose() * TVn;
        Rnn.template triangularView<Eigen::StrictlyLower>() = Rnn.transpose();
      } else if (T.nonZeros() > 0) {
        const Matrix TVn = T * Vn;
        // T' W_new for the new rows: no N x n product of T with the old columns is needed.
        const Matrix TtWn = m_symmetric[t] ? Matrix(T * Wn) : Matrix(T.transpose() * Wn);
        R.topRightCorner(p, k).noalias() = Wo.transpose() * TVn;
        R.bottomLeftCorner(k, p).noalias() = TtWn.transpose() * Vo;
        R.bottomRightCorner(k, k).noalias() = Wn.transpose() * TVn;
      }
      reduced[t] = std::move(R);
    }
    Matrix Br(n, m_B->cols());
    Br.topRows(p) = m_Br;
    Br.bottomRows(k).noalias() = Wn.transpose() * (*m_B);
    Matrix Cr(m_C->rows(), n);
    Cr.leftCols(p) = m_Cr;
    Cr.rightCols(k).noalias() = (*m_C) * Vn;
    Matrix Cvr;
    if (m_Cv != nullptr) {
      Cvr.resize(m_Cv->rows(), n);
      Cvr.leftCols(p) = m_Cvr;
      Cvr.rightCols(k).noalias() = (*m_Cv) * Vn;
    }
    Matrix Gvv = gram(m_Gvv, Vo, Vn, Vo, Vn);
    Matrix Gww, Gwv;
    if (two_sided) {
      Gww = gram(m_Gww, Wo, Wn, Wo, Wn);
      Gwv = gram(m_Gwv, Wo, Wn, Vo, Vn);
    }
    // Commit.
    m_reduced = std::move(reduced);
    m_Br = std::move(Br);
    m_Cr = std::move(Cr);
    m_Cvr = std::move(Cvr);
    m_Gvv = std::move(Gvv);
    m_Gww = std::move(Gww);
    m_Gwv = std::move(Gwv);
    m_p = n;
  }

  /// The reduced model of the first n <= columns() columns: Mr = W'MV, Dr, Kr (or Er, Ar),
  /// Br = W'B, Cr = CV, Cvr = Cv V, equal to ecmor::project to rounding.
  ReducedModel model(Index n) const {
    if (std::holds_alternative<SecondOrderModel>(*m_model)) {
      ReducedSecondOrderModel r;
      r.M = m_reduced[0].topLeftCorner(n, n);
      r.D = m_reduced[1].topLeftCorner(n, n);
      r.K = m_reduced[2].topLeftCorner(n, n);
      r.B = m_Br.topRows(n);
      r.C = m_Cr.leftCols(n);
      if (m_Cv != nullptr) r.Cv = m_Cvr.leftCols(n);
      return r;
    }
    ReducedDescriptorModel r;
    r.E = m_reduced[0].topLeftCorner(n, n);
    r.A = m_reduced[1].topLeftCorner(n, n);
    r.B = m_Br.topRows(n);
    r.C = m_Cr.leftCols(n);
    return r;
  }

  /// W' extra V of the first n <= columns() columns (exactly symmetric one-sided when extra is);
  /// 0 x 0 without an extra matrix.
  Matrix extra(Index n) const {
    return m_has_extra ? Matrix(m_reduced.back().topLeftCorner(n, n)) : Matrix();
  }

  /// ||V'V - I||_max over the first n columns (ecmor::orthogonality_loss, to rounding).
  double orthogonality_loss_v(Index n) const { return loss(m_Gvv, n); }
  /// ||W'W - I||_max over the first n columns (two-sided only).
  double orthogonality_loss_w(Index n) const { return loss(m_Gww, n); }
  /// W'V of the first n columns (two-sided only).
  Matrix wtv(Index n) const { return m_Gwv.topLeftCorner(n, n); }

 private:
  template <class Old, class New, class OldR, class NewR>
  static Matrix gram(const Matrix& G, const Old& Xo, const New& Xn, const OldR& Yo,
                     const NewR& Yn) {
    const Index p = Xo.cols(), k = Xn.cols(), n = p + k;
    Matrix out(n, n);
    out.topLeftCorner(p, p) = G;
    out.topRightCorner(p, k).noalias() = Xo.transpose() * Yn;
    out.bottomLeftCorner(k, p).noalias() = Xn.transpose() * Yo;
    out.bottomRightCorner(k, k).noalias() = Xn.transpose() * Yn;
    return out;
  }

  static double loss(const Matrix& G, Index n) {
    if (n == 0) return 0.0;
    return (G.topLeftCorner(n, n) - Matrix::Identity(n, n)).cwiseAbs().maxCoeff();
  }

  const Model* m_model;
  std::vector<const SparseMatrix*> m_ops;  // M, D, K or E, A (then the extra matrix, if any)
  bool m_has_extra = false;
  std::vector<bool> m_symmetric;  // T' == T exactly
  const Matrix* m_B = nullptr;
  const Matrix* m_C = nullptr;
  const Matrix* m_Cv = nullptr;   // nullptr: no velocity output
  Index m_p = 0;                  // columns projected
  std::vector<Matrix> m_reduced;  // p x p each
  Matrix m_Br, m_Cr, m_Cvr;
  Matrix m_Gvv, m_Gww, m_Gwv;  // V'V, W'W, W'V (the last two two-sided only)
};

}  // namespace ecmor::krylov
