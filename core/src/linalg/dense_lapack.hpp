#pragma once
// dense_lapack.hpp: dense steps that Eigen does with unblocked code, by LAPACK: the real Schur
// form F = U T U' (dgees), the Hessenberg form (dgehrd), the eigenvalues of a matrix (dgeev) or a
// pencil (dggev), the column-pivoted QR (dgeqp3 / zgeqp3) and the complex LU solve (zgetrf /
// zgetrs). Private to core (lyapunov.cpp,
// lyapunov_factor.cpp, hinf_norm.cpp, frequency_response.cpp).
//
// Why not Eigen::RealSchur: Eigen's Hessenberg reduction and double-shift QR are unblocked and
// single-threaded; at n = 3 002 (the first-order form of triplechain_mess_n1501) they took most of
// an eight-minute dense balanced truncation, 76 % of it applying 3 x 3 reflectors. LAPACK's dgees
// reduces to Hessenberg form with blocked (level-3) reflectors and runs the small-bulge multishift
// QR with aggressive early deflation, both through the optimised BLAS (docs/benchmarks.md).
#include <vector>

#include "ecmor/base/types.hpp"

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

/// The eigenvalues of the square matrix A by LAPACK's dgeev (no eigenvectors), computed on the
/// calling thread alone. False when the QR iteration did not converge.
/// Why here and not Eigen::EigenSolver: the poles of every candidate and reference model are
/// computed this way, serially, and at n = 674 (a second-order model of order 337) Eigen's
/// unblocked QR took 0.69 s where dgeev took 0.19 s; in triplechain_mess_n1501_krylov the poles
/// were a quarter of the run. Why one thread: the QR sweeps make thousands of short BLAS calls,
/// and with OpenBLAS's OpenMP build each became a parallel region; on a loaded 2-core machine the
/// same dgeev took 6.4 s with two threads (the threads spin in libgomp against the other load).
/// OpenBLAS's OpenMP build takes its thread count from omp_get_max_threads() of the calling
/// thread, which is set to 1 for the call and restored after it.
bool eigenvalues(const Matrix& A, ComplexVector& lambda);

/// Solves A X = B in place (B becomes X, A its LU factors) by LAPACK's zgetrf / zgetrs (LU with
/// partial pivoting, blocked), on the calling thread alone as eigenvalues() above; rcond is the
/// reciprocal condition number of A in the 1-norm as zgecon estimates it, the norm taken with
/// |re| + |im| per entry (at most sqrt(2) low; 0 when A is exactly singular). False when A is
/// exactly singular (B is then unchanged) or LAPACK refused an argument. Why not
/// Eigen::PartialPivLU: its pivot search and its rcond's norm take |a_ij| by hypot, unblocked;
/// measured at n = 120..500 (a reduced model's P_r(s), six right-hand sides), LU, rcond and solve
/// took 3.2-3.8x as long as here, and on rail_5177_bt (its reference model evaluated by dense LU)
/// hypot alone was 17 % of the run.
bool lu_solve(ComplexMatrix& A, ComplexMatrix& B, double& rcond);

/// The Hessenberg form of F = Q H Q' by LAPACK's dgehrd (blocked reflectors), applied to G and L
/// by dormhr, on the calling thread alone as eigenvalues() above: on return F holds H (zeros below
/// the subdiagonal), G holds Q' G and L holds L Q. Eigen's HessenbergDecomposition is unblocked:
/// at n = 674 it was 15 % of triplechain_mess_n1501_krylov. False when LAPACK refused an argument.
bool hessenberg_form(Matrix& F, Matrix& G, Matrix& L);

/// Rotates each 2 x 2 block of a real Schur form F = U T U' to upper triangular form (complex T
/// and U, F = U T U^H): the first row of the rotation is the normalised eigenvector
/// [lambda - t_kk; t_k,k-1] of the block.
void triangularize_blocks(ComplexMatrix& T, ComplexMatrix& U);

/// A P = Q K by LAPACK's column-pivoted QR (dgeqp3 / zgeqp3, level-3 blocked where the pivoting
/// allows; Eigen's ColPivHouseholderQR is unblocked): on return the upper triangle of A holds K
/// (|K_jj| non-increasing), below it the Householder vectors; column j of A P is column perm[j]
/// of the input (0-based). False when LAPACK reports an argument error.
bool column_pivoted_qr(Matrix& A, std::vector<int>& perm);
bool column_pivoted_qr(ComplexMatrix& A, std::vector<int>& perm);

}  // namespace ecmor::detail
