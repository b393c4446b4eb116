#pragma once
/// \file lyapunov.hpp
/// Dense Lyapunov and Sylvester equations and the Gramians of small (dense) stable models, for H2
/// norms (h2_norm.hpp), balanced truncation references and IRKA diagnostics.
///
/// Method (Bartels and Stewart, "Solution of the matrix equation AX + XB = C", CACM 15, 1972):
/// the pencil (A, E) is first brought to a standard matrix F with the same eigenvalues,
///  * E empty (= I):                       F = A;
///  * E symmetric positive definite:       F = L^-1 A L^-T with E = L L' (Cholesky), which keeps
///                                         F symmetric when A is (rail models);
///  * otherwise (E nonsingular):           F = E^-1 A (LU with partial pivoting);
/// then F = U T U^H (complex Schur form, T upper triangular, obtained from the real Schur form by
/// one complex rotation per 2 x 2 block; for a symmetric F the symmetric
/// eigendecomposition, T diagonal and U real orthogonal), and the triangular equation
/// T Y + Y T2^H + U^H Q U2 = 0 is solved column by column, O(n^3) in total.
/// Cost: one Schur form per pencil, about 25 n^3 flops; n = 600 takes about a second, a
/// symmetric n = 1357 (rail) under 2 s. Residuals measured on random stable A (n = 5, 50, 300):
/// 1e-15..1e-14 relative.

#include <memory>
#include <string>
#include <string_view>

#include "ecmor/export.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// Solves the Lyapunov equation  A X + X A' + Q = 0  (dense). A is n x n with no two eigenvalues
/// summing to zero (lambda_i + conj(lambda_j) != 0, e.g. A stable), Q is n x n symmetric. The
/// result is symmetrised ((X + X') / 2).
/// \throws InputError when A or Q is not n x n, or holds a non-finite value (naming the matrix and
///         the entry); NumericalError naming the two eigenvalues when lambda_i + conj(lambda_j) is
///         zero to working precision (the equation is singular: A is not stable enough).
ECMOR_API Matrix solve_lyapunov(const Matrix& A, const Matrix& Q);

/// Solves the generalized Lyapunov equation  A X E' + E X A' + Q = 0  (E nonsingular; E empty
/// means E = I). Same eigenvalue condition on the pencil's eigenvalues (those of E^-1 A).
/// \throws InputError as above (E must be n x n or empty) and when E is numerically singular
///         (LU reciprocal condition below n eps: a DAE, "not supported"); NumericalError as above.
ECMOR_API Matrix solve_lyapunov(const Matrix& A, const Matrix& E, const Matrix& Q);

/// Solves the Sylvester equation  A X + X B' + Q = 0  (A n x n, B m x m, Q and X n x m), with
/// lambda_i(A) + conj(mu_j(B)) != 0 for all eigenvalue pairs.
/// \throws as solve_lyapunov, naming A, B and Q.
ECMOR_API Matrix solve_sylvester(const Matrix& A, const Matrix& B, const Matrix& Q);

/// Solves the generalized Sylvester equation  A X F' + E X B' + Q = 0  (E, F nonsingular; empty
/// means identity), e.g. the cross Gramian A_a X E_b' + E_a X A_b' + B_a B_b' = 0 of two models.
/// Condition: lambda_i(A, E) + conj(mu_j(B, F)) != 0.
ECMOR_API Matrix solve_sylvester(const Matrix& A, const Matrix& E, const Matrix& B, const Matrix& F,
                                 const Matrix& Q);

/// A pencil (A, E) brought once to its standard form F and the Schur form of F (see the file
/// comment), for repeated Lyapunov and Sylvester solves with the same matrices (e.g. two Gramians
/// and a cross Gramian in an H2 error, or the solves of an iterative method). Cheap to copy
/// (shared, immutable); thread-safe.
class ECMOR_API SchurPencil {
 public:
  /// \param A system matrix, n x n, finite
  /// \param E descriptor matrix, n x n or empty (= I), finite and nonsingular
  /// \param origin prefix of error messages (e.g. "solve_lyapunov" or "gramians")
  /// \throws InputError on wrong sizes, non-finite values or a numerically singular E;
  ///         NumericalError if the Schur (or symmetric eigen) iteration fails.
  SchurPencil(const Matrix& A, const Matrix& E, std::string_view origin = "SchurPencil");
  /// n.
  Index size() const;
  /// The eigenvalues of the pencil (of F), in the order of the Schur form's diagonal.
  const ComplexVector& eigenvalues() const;
  /// True when F is symmetric (A symmetric, E identity or symmetric positive definite): the Schur
  /// form is a real symmetric eigendecomposition and solves are done in real arithmetic.
  bool symmetric() const;
  /// "identity", "cholesky" or "lu": how E was removed.
  std::string reduction() const;

  struct Impl;
  const Impl& impl() const { return *m_impl; }

 private:
  std::shared_ptr<const Impl> m_impl;
};

/// Solves  A1 X F2' + E1 X A2' + Q = 0  with left = (A1, E1), right = (A2, F2) (Q and X are
/// n1 x n2); left and right may be the same pencil (Lyapunov equation, Q symmetric: the result is
/// then symmetrised).
/// \throws InputError when Q is not n1 x n2 or not finite; NumericalError naming the eigenvalues
///         when lambda_i(left) + conj(mu_j(right)) is zero to working precision.
ECMOR_API Matrix solve_sylvester(const SchurPencil& left, const SchurPencil& right,
                                 const Matrix& Q);

/// trace(Cl X Cr') for the solution X of  A1 X F2' + E1 X A2' + Bl Br' = 0  (left = (A1, E1),
/// right = (A2, F2)) without forming X or the n1 x n2 right-hand side: the low-rank factors are
/// carried into Schur coordinates (O(n^2 (m + p))), so only the triangular solve is O(n^3), and
/// with two symmetric pencils it is O(n1 n2). This is the H2 inner product <G1, G2> of
/// G1 = Cl (s E1 - A1)^-1 Bl and G2 = Cr (s F2 - A2)^-1 Br (h2_norm.hpp).
/// \throws InputError when Bl is not n1 x m, Br not n2 x m, Cl not p x n1, Cr not p x n2 or a
///         value is not finite; NumericalError as solve_sylvester.
ECMOR_API double sylvester_trace(const SchurPencil& left, const SchurPencil& right,
                                 const Matrix& Bl, const Matrix& Br, const Matrix& Cl,
                                 const Matrix& Cr);

/// Relative residual ||A X E' + E X A' + Q||_F / ||Q||_F of a (generalized) Lyapunov solution;
/// E empty means E = I. ||Q||_F = 0 gives the absolute residual.
/// \throws InputError on inconsistent sizes.
ECMOR_API double lyapunov_residual(const Matrix& A, const Matrix& E, const Matrix& X,
                                   const Matrix& Q);

/// Controllability and observability Gramians of the first-order realisation (E, A, B, C) of a
/// stable model (first_order_realization):
///     A P E' + E P A' + B B' = 0,     A' Q E + E' Q A + C' C = 0.
/// With them ||G||_H2^2 = trace(C P C') = trace(B' Q B), and the Hankel singular values are the
/// square roots of the eigenvalues of P E' Q E.
struct Gramians {
  Matrix P;  ///< controllability Gramian, n x n symmetric positive semidefinite
  Matrix Q;  ///< observability Gramian, n x n symmetric positive semidefinite
};

/// Both Gramians of a stable reduced (dense) model.
/// \throws InputError "H2 norm / Gramians undefined: the model has k poles with Re >= 0 (largest
///         real part x)" for a model that is not asymptotically stable (checked first, with the
///         pencil's eigenvalues, or ecmor::poles when E is singular); InputError when E (M) is
///         numerically singular ("... not supported": the transfer function of a DAE may be
///         improper and has no finite H2 norm in general).
ECMOR_API Gramians gramians(const ReducedModel& model);

/// The controllability Gramian P alone (half the cost of gramians()). Throws as gramians().
ECMOR_API Matrix controllability_gramian(const ReducedModel& model);

/// The pencil (A, E) of the model's first-order realisation, checked as gramians() checks it
/// (stable, E nonsingular). \param origin prefixes the messages of the singular-E error.
ECMOR_API SchurPencil stable_pencil(const ReducedModel& model,
                                    std::string_view origin = "gramians");

}  // namespace ecmor
