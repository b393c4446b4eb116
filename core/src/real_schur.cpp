// real_schur.cpp: see real_schur.hpp.
#include "real_schur.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

extern "C" {
// LAPACK (the library behind liblapack.so.3: OpenBLAS's, or the reference one). The trailing
// arguments are the lengths of the two character arguments (gfortran's calling convention).
void dgees_(const char* jobvs, const char* sort, int (*select)(const double*, const double*),
            const int* n, double* a, const int* lda, int* sdim, double* wr, double* wi, double* vs,
            const int* ldvs, double* work, const int* lwork, int* bwork, int* info, std::size_t,
            std::size_t);
void dggev_(const char* jobvl, const char* jobvr, const int* n, double* a, const int* lda,
            double* b, const int* ldb, double* alphar, double* alphai, double* beta, double* vl,
            const int* ldvl, double* vr, const int* ldvr, double* work, const int* lwork, int* info,
            std::size_t, std::size_t);
}

namespace ecmor::detail {

bool real_schur(const Matrix& F, Matrix& T, Matrix& U) {
  const int n = static_cast<int>(F.rows());
  T = F;
  U.resize(n, n);
  if (n == 0) return true;
  int sdim = 0, info = 0, lwork = -1;
  std::vector<double> wr(static_cast<std::size_t>(n)), wi(static_cast<std::size_t>(n));
  double query = 0.0;
  dgees_("V", "N", nullptr, &n, T.data(), &n, &sdim, wr.data(), wi.data(), U.data(), &n, &query,
         &lwork, nullptr, &info, 1, 1);
  if (info != 0) return false;
  lwork = std::max(static_cast<int>(query), 3 * n);
  std::vector<double> work(static_cast<std::size_t>(lwork));
  dgees_("V", "N", nullptr, &n, T.data(), &n, &sdim, wr.data(), wi.data(), U.data(), &n,
         work.data(), &lwork, nullptr, &info, 1, 1);
  if (info != 0) return false;
  // dgees leaves rounding-level entries below the blocks' subdiagonals: T is quasi-triangular.
  for (int j = 0; j < n; ++j)
    for (int i = j + 2; i < n; ++i) T(i, j) = 0.0;
  return true;
}

bool generalized_eigenvalues(const Matrix& A, const Matrix& B, ComplexVector& alpha, Vector& beta) {
  const int n = static_cast<int>(A.rows());
  alpha.resize(n);
  beta.resize(n);
  if (n == 0) return true;
  Matrix a = A, b = B;
  std::vector<double> ar(static_cast<std::size_t>(n)), ai(static_cast<std::size_t>(n));
  int info = 0, lwork = -1, one = 1;
  double query = 0.0, unused = 0.0;
  dggev_("N", "N", &n, a.data(), &n, b.data(), &n, ar.data(), ai.data(), beta.data(), &unused, &one,
         &unused, &one, &query, &lwork, &info, 1, 1);
  if (info != 0) return false;
  lwork = std::max(static_cast<int>(query), 8 * n);
  std::vector<double> work(static_cast<std::size_t>(lwork));
  dggev_("N", "N", &n, a.data(), &n, b.data(), &n, ar.data(), ai.data(), beta.data(), &unused, &one,
         &unused, &one, work.data(), &lwork, &info, 1, 1);
  if (info != 0) return false;
  for (int i = 0; i < n; ++i)
    alpha(i) = Complex(ar[static_cast<std::size_t>(i)], ai[static_cast<std::size_t>(i)]);
  return true;
}

void triangularize_blocks(ComplexMatrix& T, ComplexMatrix& U) {
  const Index n = T.rows();
  for (Index k = n - 1; k >= 1; --k) {
    const Complex c = T(k, k - 1);
    if (c == 0.0) continue;
    // Eigenvalues of [[a, b], [c, d]]: (a + d) / 2 +- sqrt(((a - d) / 2)^2 + b c).
    const Complex a = T(k - 1, k - 1), b = T(k - 1, k), d = T(k, k);
    const Complex half = 0.5 * (a - d);
    const Complex lambda = 0.5 * (a + d) + std::sqrt(half * half + b * c);
    const Complex mu = lambda - d;
    const double r = std::hypot(std::abs(mu), std::abs(c));
    const Complex cs = mu / r, sn = c / r;
    // G = [[conj(cs), conj(sn)], [-sn, cs]]; rows k-1, k of T from column k-1 on; columns of T
    // (rows 0..k) and of U by G^H.
    for (Index j = k - 1; j < n; ++j) {
      const Complex t1 = T(k - 1, j), t2 = T(k, j);
      T(k - 1, j) = std::conj(cs) * t1 + std::conj(sn) * t2;
      T(k, j) = -sn * t1 + cs * t2;
    }
    for (Index i = 0; i <= k; ++i) {
      const Complex t1 = T(i, k - 1), t2 = T(i, k);
      T(i, k - 1) = t1 * cs + t2 * sn;
      T(i, k) = -t1 * std::conj(sn) + t2 * std::conj(cs);
    }
    for (Index i = 0; i < n; ++i) {
      const Complex u1 = U(i, k - 1), u2 = U(i, k);
      U(i, k - 1) = u1 * cs + u2 * sn;
      U(i, k) = -u1 * std::conj(sn) + u2 * std::conj(cs);
    }
    T(k, k - 1) = 0.0;
    --k;  // the block's upper row is done too
  }
}

}  // namespace ecmor::detail
