#pragma once
/// \file reduced_response.hpp
/// Fast repeated evaluation of a reduced model's transfer matrix Hr(s) at many frequencies.
///
/// The reduced model is brought once to a first-order realisation x' = F x + G u, y = L x
/// (second order: x = [q; q'], F = [[0, I], [-Mr^-1 Kr, -Mr^-1 Dr]], G = [0; Mr^-1 Br],
/// L = [Cr, Cvr]; descriptor: F = Er^-1 Ar) and F to upper Hessenberg form Q' F Q (orthogonal Q,
/// backward stable). Each frequency then costs O(n^2) (Gaussian elimination with partial pivoting
/// on the Hessenberg matrix s I - Q' F Q) instead of the O(n^3) of a dense LU: Laub's method
/// (A. J. Laub, "Efficient multivariable frequency response computations", IEEE TAC 26, 1981).
/// When Mr (or Er) is singular or ill-conditioned (reciprocal condition < 1e-8), or when the
/// Hessenberg path differs from a dense LU of P_r(s) by more than 1e-8 (relative) at a frequency
/// inside the model's spectrum (a badly scaled model, whose realisation lost digits), the
/// evaluator falls back to a dense LU of P_r(s) per frequency.
///
/// Thread safety: operator() is const and may be called concurrently from several threads (each
/// thread keeps its own scratch space, reused across calls and evaluators).

#include "ecmor/export.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

class ECMOR_API ReducedResponse {
 public:
  /// Precomputes the Hessenberg form (O(n^3) once). The model is copied where needed.
  explicit ReducedResponse(const ReducedModel& model);
  /// Hr(s), p x m. O(n^2 (1 + min(m, p)) / 2) complex multiply-adds and O(n min(m, p))
  /// memory on the Hessenberg path.
  /// \throws NumericalError when s is (numerically) a pole of the reduced model: a pivot of the
  ///         elimination of s I - H is below n eps (max |H_ij| + |s|) (Hessenberg path), or the
  ///         dense LU's reciprocal condition is below eps (fallback path).
  ComplexMatrix operator()(Complex s) const;
  /// True when the O(n^2) Hessenberg path is used.
  bool hessenberg() const { return m_hessenberg; }

 private:
  void self_check();  // the Hessenberg path against the dense LU at one frequency

  ReducedModel m_model;  // for the fallback path
  bool m_hessenberg = false;
  bool m_transposed = false;  // H, G, L describe Hr' (fewer outputs than inputs): transpose back
  Matrix m_minus_H;           // -(Q' F Q) (transposed: -J (Q' F Q)' J), upper Hessenberg
  Matrix m_G;                 // Q' G (transposed: J Q' L')
  Matrix m_L;                 // L Q (transposed: G' Q J)
  double m_scale = 0.0;       // max |H_ij|, for the singularity test
};

}  // namespace ecmor
