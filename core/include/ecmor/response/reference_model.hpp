#pragma once
/// \file reference_model.hpp
/// The error estimator's reference model: a Galerkin projection of the full model onto the span of
/// full-model solves it has already paid for, and of bases offered to it.
///
/// Every full-model response H(s_j) costs one sparse factorisation of P(s_j) and the solves
/// Z_j = P(s_j)^-1 B (or P(s_j)^-T (C + s_j Cv)^T when the model has fewer outputs than inputs).
/// The reference basis Q is an orthonormal basis (Euclidean, with deflation) of the real and
/// imaginary parts of all Z_j, plus the columns of any basis offered (a candidate's V and W). The
/// reference model is  Q' M Q, Q' D Q, Q' K Q, Q' B, C Q, Cv Q  (or Q' E Q, Q' A Q, Q' B, C Q).
/// Because Z_j lies in span(Q), the one-sided projection interpolates H at every s_j (and at -s_j
/// and the conjugates, since Q is real): the reference is exact where the full model was solved
/// and, between those points, a rational Krylov approximation that only gets richer during a run.
/// Adding k columns costs O(nnz k + N r k) (the projected matrices are extended, not recomputed).

#include <cstdint>
#include <unordered_set>
#include <vector>

#include "ecmor/export.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace ecmor {

class ECMOR_API ReferenceModel {
 public:
  /// \param deflation_tol  a new direction whose norm after orthogonalisation falls below this
  ///                       fraction of its norm before is dropped (in (0, 1)).
  explicit ReferenceModel(const Model& model, double deflation_tol = 1e-8);
  /// The reference keeps the model by reference: a temporary would dangle.
  ReferenceModel(Model&&, double = 1e-8) = delete;

  /// Adds the real and imaginary parts of the columns of Z (N rows). Returns the number of basis
  /// vectors added (after deflation). \throws InputError if Z does not have N rows.
  Index add(const ComplexMatrix& Z);
  /// Adds the columns of X (N rows); the same rules. A column given before, bit for bit, is
  /// skipped: it is in the span already.
  Index add(const Matrix& X);
  /// Adds every solution (FullSolution::Z), in order.
  Index add(const std::vector<FullSolution>& solutions);

  /// Order r of the reference model (columns of Q).
  Index order() const { return m_Q.cols(); }
  /// Incremented whenever the basis grows: cached evaluations of an older version are stale.
  Index version() const { return m_version; }
  /// The projected model (second order for a second-order full model, else descriptor).
  const ReducedModel& reduced() const { return m_reduced; }
  /// Full dimension N.
  Index full_size() const { return m_Q.rows(); }

 private:
  void extend(Index first_new);
  const Model& m_model;
  double m_deflation_tol;
  Matrix m_Q;
  std::unordered_set<std::uint64_t> m_offered;  // hashes of every column add() has taken
  ReducedModel m_reduced;
  Index m_version = 0;
};

}  // namespace ecmor
