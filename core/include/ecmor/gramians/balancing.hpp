#pragma once
/// \file balancing.hpp
/// Dense square-root balanced truncation of a small stable model of either kind, through its
/// first-order realisation (E, A, B, C): the Gramians P, Q (gramians()), factors P = Lp Lp',
/// Q = Lq Lq' from symmetric eigendecompositions (negative eigenvalues, rounding noise of
/// semidefinite Gramians, clipped to 0), and the SVD Lq' E Lp = U S Z'. Computed once; every
/// order's truncation is a prefix of the same SVD:
///     V = Lp Z_r S_r^-1/2,   W = Lq U_r S_r^-1/2   (W' E V = I_r),
///     Er = W' E V = I, Ar = W' A V, Br = W' B, Cr = C V.
/// The truncation is stable and ||G - Gr||_inf <= 2 (s_{r+1} + ... + s_n). Moore (1981); Tombs
/// and Postlethwaite (1987); Glover (1984).

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

class ECMOR_API DenseBalancing {
 public:
  /// \throws as gramians() (unstable model, singular E or M); InputError beyond kMaxDenseStates.
  explicit DenseBalancing(const ReducedModel& model);

  /// The Hankel singular values s_1 >= s_2 >= ... >= 0.
  const Vector& hankel_singular_values() const { return m_s; }
  /// How many Hankel singular values are positive: the largest order truncate() accepts.
  Index positive_count() const;
  /// The first-order realisation the bases act on.
  const ReducedDescriptorModel& first_order() const { return m_fo; }

  /// The balanced truncation of order r, Er = I.
  /// \throws InputError unless 1 <= r <= positive_count().
  ReducedDescriptorModel truncate(Index r) const;
  /// Its projection bases V, W (first-order state size x r). Throws as truncate().
  void bases(Index r, Matrix& V, Matrix& W) const;

 private:
  ReducedDescriptorModel m_fo;
  Matrix m_lp, m_lq, m_u, m_z;
  Vector m_s;
};

}  // namespace ecmor
