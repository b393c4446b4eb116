// dense_lapack.cpp: see dense_lapack.hpp.
#include "linalg/dense_lapack.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <numeric>
#include <string>
#include <type_traits>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/dense_kernels.hpp"

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
void dgeev_(const char* jobvl, const char* jobvr, const int* n, double* a, const int* lda,
            double* wr, double* wi, double* vl, const int* ldvl, double* vr, const int* ldvr,
            double* work, const int* lwork, int* info, std::size_t, std::size_t);
void dgehrd_(const int* n, const int* ilo, const int* ihi, double* a, const int* lda, double* tau,
             double* work, const int* lwork, int* info);
void dormhr_(const char* side, const char* trans, const int* m, const int* n, const int* ilo,
             const int* ihi, const double* a, const int* lda, const double* tau, double* c,
             const int* ldc, double* work, const int* lwork, int* info, std::size_t, std::size_t);
void dgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
            const double* alpha, const double* a, const int* lda, const double* b, const int* ldb,
            const double* beta, double* c, const int* ldc, std::size_t, std::size_t);
void zgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
            const std::complex<double>* alpha, const std::complex<double>* a, const int* lda,
            const std::complex<double>* b, const int* ldb, const std::complex<double>* beta,
            std::complex<double>* c, const int* ldc, std::size_t, std::size_t);
void dgesdd_(const char* jobz, const int* m, const int* n, double* a, const int* lda, double* s,
             double* u, const int* ldu, double* vt, const int* ldvt, double* work, const int* lwork,
             int* iwork, int* info, std::size_t);
void dgeqp3_(const int* m, const int* n, double* a, const int* lda, int* jpvt, double* tau,
             double* work, const int* lwork, int* info);
void zgeqp3_(const int* m, const int* n, std::complex<double>* a, const int* lda, int* jpvt,
             std::complex<double>* tau, std::complex<double>* work, const int* lwork, double* rwork,
             int* info);
void zgetrf_(const int* m, const int* n, std::complex<double>* a, const int* lda, int* ipiv,
             int* info);
void zgecon_(const char* norm, const int* n, const std::complex<double>* a, const int* lda,
             const double* anorm, double* rcond, std::complex<double>* work, double* rwork,
             int* info, std::size_t);
void zgetrs_(const char* trans, const int* n, const int* nrhs, const std::complex<double>* a,
             const int* lda, const int* ipiv, std::complex<double>* b, const int* ldb, int* info,
             std::size_t);
}

namespace ecmor {

namespace {

template <typename Scalar>
Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> gemm(
    const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& A,
    const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& B, bool ta, bool tb) {
  const Index m = ta ? A.cols() : A.rows(), k = ta ? A.rows() : A.cols();
  const Index kb = tb ? B.cols() : B.rows(), n = tb ? B.rows() : B.cols();
  if (k != kb)
    throw InputError("dense_product: op(A) is " + std::to_string(m) + " x " + std::to_string(k) +
                     " and op(B) is " + std::to_string(kb) + " x " + std::to_string(n) +
                     ": the inner dimensions must agree");
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> C(m, n);
  if (m == 0 || n == 0) return C;
  if (k == 0) return C.setZero();
  const int mi = static_cast<int>(m), ni = static_cast<int>(n), ki = static_cast<int>(k);
  const int lda = static_cast<int>(std::max<Index>(1, A.rows()));
  const int ldb = static_cast<int>(std::max<Index>(1, B.rows()));
  const Scalar one = 1.0, zero = 0.0;
  const char* opa = ta ? "T" : "N";
  const char* opb = tb ? "T" : "N";
  if constexpr (std::is_same_v<Scalar, double>) {
    dgemm_(opa, opb, &mi, &ni, &ki, &one, A.data(), &lda, B.data(), &ldb, &zero, C.data(), &mi, 1,
           1);
  } else {
    zgemm_(opa, opb, &mi, &ni, &ki, &one, A.data(), &lda, B.data(), &ldb, &zero, C.data(), &mi, 1,
           1);
  }
  return C;
}

}  // namespace

Matrix dense_product(const Matrix& A, const Matrix& B, bool transpose_a, bool transpose_b) {
  return gemm(A, B, transpose_a, transpose_b);
}

ComplexMatrix dense_product(const ComplexMatrix& A, const ComplexMatrix& B) {
  return gemm(A, B, false, false);
}

ThinSvd thin_svd(const Matrix& A) {
  if (!A.allFinite()) throw InputError("thin_svd: the matrix has a non-finite entry");
  const int m = static_cast<int>(A.rows()), n = static_cast<int>(A.cols());
  const int k = std::min(m, n);
  ThinSvd out;
  out.U.resize(m, k);
  out.s.resize(k);
  out.V.resize(n, k);
  if (k == 0) return out;
  Matrix a = A, Vt(k, n);
  std::vector<int> iwork(8 * static_cast<std::size_t>(k));
  int info = 0, lwork = -1;
  double query = 0.0;
  dgesdd_("S", &m, &n, a.data(), &m, out.s.data(), out.U.data(), &m, Vt.data(), &k, &query, &lwork,
          iwork.data(), &info, 1);
  if (info == 0) {
    lwork = std::max(static_cast<int>(query), 1);
    std::vector<double> work(static_cast<std::size_t>(lwork));
    dgesdd_("S", &m, &n, a.data(), &m, out.s.data(), out.U.data(), &m, Vt.data(), &k, work.data(),
            &lwork, iwork.data(), &info, 1);
  }
  if (info != 0)
    throw NumericalError("thin_svd: LAPACK's dgesdd " +
                         std::string(info > 0 ? "did not converge" : "refused an argument") +
                         " (info " + std::to_string(info) + ") on a " + std::to_string(m) + " x " +
                         std::to_string(n) + " matrix");
  out.V = Vt.transpose();
  return out;
}

}  // namespace ecmor

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

namespace {

// The calling thread's OpenMP thread count set to 1 for the lifetime of the guard: OpenBLAS's
// OpenMP build then runs its BLAS calls on this thread alone (dense_lapack.hpp, eigenvalues).
class OneBlasThread {
 public:
  OneBlasThread() : m_threads(omp_get_max_threads()) { omp_set_num_threads(1); }
  ~OneBlasThread() { omp_set_num_threads(m_threads); }
  OneBlasThread(const OneBlasThread&) = delete;
  OneBlasThread& operator=(const OneBlasThread&) = delete;

 private:
  int m_threads;
};

}  // namespace

bool eigenvalues(const Matrix& A, ComplexVector& lambda) {
  const int n = static_cast<int>(A.rows());
  lambda.resize(n);
  if (n == 0) return true;
  const OneBlasThread one_thread;
  Matrix a = A;
  std::vector<double> wr(static_cast<std::size_t>(n)), wi(static_cast<std::size_t>(n));
  int info = 0, lwork = -1, one = 1;
  double query = 0.0, unused = 0.0;
  dgeev_("N", "N", &n, a.data(), &n, wr.data(), wi.data(), &unused, &one, &unused, &one, &query,
         &lwork, &info, 1, 1);
  if (info != 0) return false;
  lwork = std::max(static_cast<int>(query), 3 * n);
  std::vector<double> work(static_cast<std::size_t>(lwork));
  dgeev_("N", "N", &n, a.data(), &n, wr.data(), wi.data(), &unused, &one, &unused, &one,
         work.data(), &lwork, &info, 1, 1);
  if (info != 0) return false;
  for (int i = 0; i < n; ++i)
    lambda(i) = Complex(wr[static_cast<std::size_t>(i)], wi[static_cast<std::size_t>(i)]);
  return true;
}

bool lu_solve(ComplexMatrix& A, ComplexMatrix& B, double& rcond) {
  rcond = 0.0;
  const int n = static_cast<int>(A.rows());
  if (n == 0) {
    rcond = 1.0;
    return true;
  }
  const OneBlasThread one_thread;
  std::vector<double> rwork(2 * static_cast<std::size_t>(n));
  std::vector<int> pivots(static_cast<std::size_t>(n));
  std::vector<std::complex<double>> work(2 * static_cast<std::size_t>(n));
  // The 1-norm with |re| + |im| for |a_ij| (LAPACK's cabs1): at most sqrt(2) above the true one,
  // so rcond is at most sqrt(2) low, and no hypot per entry (zlange's), which cost a third as
  // much as the LU itself at n = 278.
  double norm = 0.0;
  for (Index j = 0; j < A.cols(); ++j) {
    const std::complex<double>* a = A.col(j).data();
    double sum = 0.0;
    for (Index i = 0; i < A.rows(); ++i) sum += std::abs(a[i].real()) + std::abs(a[i].imag());
    norm = std::max(norm, sum);
  }
  int info = 0;
  zgetrf_(&n, &n, A.data(), &n, pivots.data(), &info);
  if (info != 0) return false;  // > 0: an exactly zero pivot
  zgecon_("1", &n, A.data(), &n, &norm, &rcond, work.data(), rwork.data(), &info, 1);
  if (info != 0 || !std::isfinite(rcond)) rcond = 0.0;
  const int nrhs = static_cast<int>(B.cols());
  if (nrhs == 0) return true;
  zgetrs_("N", &n, &nrhs, A.data(), &n, pivots.data(), B.data(), &n, &info, 1);
  return info == 0;
}

bool hessenberg_form(Matrix& F, Matrix& G, Matrix& L) {
  const int n = static_cast<int>(F.rows());
  if (n == 0) return true;
  const OneBlasThread one_thread;
  const int one = 1;
  std::vector<double> tau(static_cast<std::size_t>(std::max(n - 1, 1)));
  int info = 0, lwork = -1;
  double query = 0.0;
  dgehrd_(&n, &one, &n, F.data(), &n, tau.data(), &query, &lwork, &info);
  if (info != 0) return false;
  std::vector<double> work(static_cast<std::size_t>(std::max(static_cast<int>(query), n)));
  lwork = static_cast<int>(work.size());
  dgehrd_(&n, &one, &n, F.data(), &n, tau.data(), work.data(), &lwork, &info);
  if (info != 0) return false;
  // Q' G and L Q; the reflectors are below the subdiagonal of F until they are cleared.
  auto apply = [&](const char* side, const char* trans, Matrix& C) {
    const int m = static_cast<int>(C.rows()), k = static_cast<int>(C.cols());
    if (m == 0 || k == 0) return true;
    const int ldc = std::max(m, 1);
    int lw = -1;
    double q = 0.0;
    dormhr_(side, trans, &m, &k, &one, &n, F.data(), &n, tau.data(), C.data(), &ldc, &q, &lw, &info,
            1, 1);
    if (info != 0) return false;
    std::vector<double> w(static_cast<std::size_t>(std::max(static_cast<int>(q), 1)));
    lw = static_cast<int>(w.size());
    dormhr_(side, trans, &m, &k, &one, &n, F.data(), &n, tau.data(), C.data(), &ldc, w.data(), &lw,
            &info, 1, 1);
    return info == 0;
  };
  if (!apply("L", "T", G) || !apply("R", "N", L)) return false;
  for (int j = 0; j < n; ++j)
    for (int i = j + 2; i < n; ++i) F(i, j) = 0.0;
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

namespace {

template <typename Scalar>
bool geqp3(Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& A, std::vector<int>& perm) {
  const int m = static_cast<int>(A.rows()), n = static_cast<int>(A.cols());
  if (m == 0 || n == 0) {
    perm.resize(static_cast<std::size_t>(n));
    std::iota(perm.begin(), perm.end(), 0);
    return true;
  }
  perm.assign(static_cast<std::size_t>(n), 0);  // 0: every column is free to move
  std::vector<Scalar> tau(static_cast<std::size_t>(std::min(m, n)));
  std::vector<double> rwork(2 * static_cast<std::size_t>(n));  // zgeqp3 only
  int info = 0;
  const auto call = [&](Scalar* work, int lwork) {
    if constexpr (std::is_same_v<Scalar, double>) {
      dgeqp3_(&m, &n, A.data(), &m, perm.data(), tau.data(), work, &lwork, &info);
    } else {
      zgeqp3_(&m, &n, A.data(), &m, perm.data(), tau.data(), work, &lwork, rwork.data(), &info);
    }
    return info == 0;
  };
  Scalar query = 0.0;
  if (!call(&query, -1)) return false;
  std::vector<Scalar> work(
      static_cast<std::size_t>(std::max(static_cast<int>(std::real(query)), 3 * n + 1)));
  if (!call(work.data(), static_cast<int>(work.size()))) return false;
  for (int& p : perm) --p;  // LAPACK's pivots are 1-based
  return true;
}

}  // namespace

bool column_pivoted_qr(Matrix& A, std::vector<int>& perm) { return geqp3(A, perm); }

bool column_pivoted_qr(ComplexMatrix& A, std::vector<int>& perm) { return geqp3(A, perm); }

}  // namespace ecmor::detail
