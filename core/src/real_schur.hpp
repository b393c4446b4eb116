#pragma once
// real_schur.hpp: dense eigenproblems by LAPACK: the real Schur form F = U T U' (dgees) and the
// eigenvalues of a pencil (dggev). Private to core (lyapunov.cpp, lyapunov_factor.cpp,
// hinf_norm.cpp).
//
// Why not Eigen::RealSchur: Eigen's Hessenberg reduction and double-shift QR are unblocked and
// single-threaded; at n = 3 002 (the first-order form of triplechain_mess_n1501) they took most of
// an eight-minute dense balanced truncation, 76 % of it applying 3 x 3 reflectors. LAPACK's dgees
// reduces to Hessenberg form with blocked (level-3) reflectors and runs the small-bulge multishift
// QR with aggressive early deflation, both through the optimised BLAS (docs/benchmarks.md).
#include "ecmor/types.hpp"

namespace ecmor::detail {

/// F = U T U' with T quasi-upper triangular (1 x 1 and 2 x 2 diagonal blocks, the 2 x 2 ones for
/// complex conjugate pairs, in LAPACK's standard form) and U orthogonal. False when the QR
/// iteration did not converge (T and U are then unspecified).
bool real_schur(const Matrix& F, Matrix& T, Matrix& U);

/// The generalized eigenvalues alpha_i / beta_i of the pencil (A, B) by LAPACK's dggev (QZ after
/// permuting to isolate eigenvalues; more robust than Eigen's RealQZ, which failed to converge on
/// a 172 x 172 Hamiltonian error pencil of build_so that dggev solves). alpha complex, beta real
/// and >= 0 (beta = 0: an infinite eigenvalue). False when the QZ iteration failed.
bool generalized_eigenvalues(const Matrix& A, const Matrix& B, ComplexVector& alpha, Vector& beta);

/// Rotates each 2 x 2 block of a real Schur form F = U T U' to upper triangular form (complex T
/// and U, F = U T U^H): the first row of the rotation is the normalised eigenvector
/// [lambda - t_kk; t_k,k-1] of the block.
void triangularize_blocks(ComplexMatrix& T, ComplexMatrix& U);

}  // namespace ecmor::detail
