#pragma once
/// \file lyapunov_factor.hpp
/// Gramian factors computed directly (Hammarling's method), without forming the Gramians.
///
/// For a stable pencil (A, E) with nonsingular E and the Lyapunov equations
///     A P E' + E P A' + B B' = 0,        A' Q E + E' Q A + C' C = 0,
/// the factors Zc (P = Zc Zc'), Zo (E'QE = Zo Zo') and Zq = E^-T Zo (Q = Zq Zq') are computed by
/// Hammarling's method (S. J. Hammarling, "Numerical solution of the stable, non-negative definite
/// Lyapunov equation", IMA J. Numer. Anal. 2, 1982): the pencil is brought to a standard matrix F
/// as SchurPencil does (F = A, F = L^-1 A L^-T for E = L L' symmetric positive definite, F = E^-1 A
/// otherwise), F = U T U^H (complex Schur form: the real Schur form with each 2 x 2 block
/// triangularised by one complex rotation, or the symmetric eigendecomposition), and the Cholesky
/// factor R of the solution of T X + X T^H + G G^H = 0 is computed column by column from the last,
/// each step one triangular solve with T's leading block plus a rank-one update of G. The
/// observability factor comes from the same Schur form (F' = U T^H U^H, T^H flipped to upper
/// triangular form).
///
/// Why: a factor computed directly has a small normwise error, so the Hankel singular values (the
/// singular values of Zo' Zc) carry absolute errors of about eps s_1; factoring computed Gramians
/// (absolute errors ~ n eps ||X||) moves an HSV s_i by ~ n eps ||P|| ||E'QE|| / s_i instead, which
/// is far larger for the small ones.
///
/// Precision: double. Measured against a long-double reference (test_balanced): the leading ten
/// HSVs of build, iss, cdplayer and heat_cont agree to <= 2e-11 relative, heat_cont's
/// s_10 = 7e-8 s_1 included; running the same code in long double changed that by less than 2x
/// at 10-20x the cost, so there is no extended-precision option.
///
/// Output size: the factors are compressed by column-pivoted QR (in Schur coordinates, then once
/// more for the real and imaginary parts), keeping the columns whose pivot |K_jj| > eps |K_11|:
/// what is dropped (Gramian eigenvalues below ~eps^2 ||X||) is below the rounding of the factor.

#include "ecmor/export.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// The three factors of the two Gramians of (E, A, B, C).
struct LyapunovFactors {
  Matrix Zc;               ///< P ~ Zc Zc' (n x kc)
  Matrix Zq;               ///< Q ~ Zq Zq' (n x ko)
  Matrix Zo;               ///< E'QE ~ Zo Zo' (n x ko), computed directly, Zq = E^-T Zo
  bool symmetric = false;  ///< F was symmetric (A symmetric, E identity or s.p.d.)
};

/// The Gramian factors of the stable pencil (A, E) by Hammarling's method (see the file comment).
/// \param A  n x n, finite; all eigenvalues of the pencil with Re < 0 (the caller checks stability,
///           e.g. with ecmor::stable_pencil, which also names the offending poles)
/// \param E  n x n, nonsingular, or empty (= I)
/// \param B  n x m, \param C p x n
/// \throws InputError on inconsistent sizes or a numerically singular E (reciprocal condition of
///         its LU <= n eps); NumericalError when the Schur iteration fails or an eigenvalue has
///         Re >= 0 (the equation has no semidefinite solution).
ECMOR_API LyapunovFactors lyapunov_factors(const Matrix& A, const Matrix& E, const Matrix& B,
                                           const Matrix& C);

}  // namespace ecmor
