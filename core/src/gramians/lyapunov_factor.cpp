// lyapunov_factor.cpp: Gramian factors by Hammarling's method. Templated on the real scalar type:
// a long double instantiation was measured (heat_cont's s_10 = 7e-8 s_1 agreed with the reference
// to 5.8e-11 instead of 9.0e-11 in double, at 10-20x the time) and dropped as not worth it. The
// Schur step is LAPACK's (double) since issue 27; another precision would need its own.
#include "ecmor/gramians/lyapunov_factor.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>
#include <complex>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "base/number_text.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/dense_kernels.hpp"
#include "linalg/dense_lapack.hpp"

namespace ecmor {

namespace {

constexpr std::string_view kOrigin = "lyapunov_factors";

template <typename S>
using Mat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;
template <typename S>
using Vec = Eigen::Matrix<S, Eigen::Dynamic, 1>;
template <typename S>
using CMat = Eigen::Matrix<std::complex<S>, Eigen::Dynamic, Eigen::Dynamic>;
template <typename S>
using CVec = Eigen::Matrix<std::complex<S>, Eigen::Dynamic, 1>;

template <typename S>
bool nearly_symmetric(const Mat<S>& X) {
  const S scale = X.cwiseAbs().maxCoeff();
  return (X - X.transpose()).cwiseAbs().maxCoeff() <= S(1e-14) * scale;
}

/// F = U T U^H: T complex upper triangular (from the real Schur form, one complex rotation per
/// 2 x 2 block, as SchurPencil does) or, for a symmetric F, real diagonal d with real U.
template <typename S>
struct Schur {
  bool symmetric = false;
  Vec<S> d;
  Mat<S> Ur;
  CMat<S> T, U;
};

/// Hammarling's recursion: the upper triangular R with R R^H = X for T X + X T^H + G G^H = 0
/// (T upper triangular, or diagonal when `diagonal`, all Re t_kk < 0). With T = [T1 t; 0 tau],
/// R = [R1 r; 0 rho], G = [G1; g'] (g' the last row):
///     rho = ||g|| / sqrt(-2 Re tau),
///     (T1 + conj(tau) I) r = -t rho - G1 g / rho,
///     T1 X1 + X1 T1^H + G1~ G1~^H = 0 with G1~ = G1 - r g' / rho,
/// which is the same problem one size smaller with as many columns (m) as before. A zero row g
/// gives rho = 0 and r = 0 (the whole last column of X vanishes, X being semidefinite).
template <typename S>
CMat<S> hammarling(const CMat<S>& T, CMat<S> G, bool diagonal) {
  using C = std::complex<S>;
  const Eigen::Index n = T.rows();
  CMat<S> R = CMat<S>::Zero(n, n);
  CVec<S> rhs(n);
  Eigen::Matrix<C, 1, Eigen::Dynamic> g;
  for (Eigen::Index k = n - 1; k >= 0; --k) {
    const C tau = T(k, k);
    if (!(tau.real() < S(0))) {
      throw NumericalError(std::string(kOrigin) + ": an eigenvalue of the pencil has Re >= 0 (" +
                           detail::number_text(static_cast<double>(tau.real())) +
                           "): the Lyapunov equation has no semidefinite solution");
    }
    g = G.row(k);
    const S norm_g = g.norm();
    if (norm_g == S(0)) continue;
    const S rho = norm_g / std::sqrt(S(-2) * tau.real());
    R(k, k) = rho;
    if (k == 0) break;
    auto r = rhs.head(k);
    r.noalias() = G.topRows(k) * g.adjoint();
    r /= -rho;
    if (diagonal) {
      for (Eigen::Index i = 0; i < k; ++i) r(i) /= T(i, i) + std::conj(tau);
    } else {
      r -= rho * T.col(k).head(k);
      // Back substitution with T1 + conj(tau) I, column oriented (T is column major).
      for (Eigen::Index i = k - 1; i >= 0; --i) {
        r(i) /= T(i, i) + std::conj(tau);
        if (i > 0) r.head(i).noalias() -= T.col(i).head(i) * r(i);
      }
    }
    R.col(k).head(k) = r;
    G.topRows(k).noalias() -= (r / rho) * g;
  }
  return R;
}

/// Rank-revealing compression of a factor: for X = R R^H, the column-pivoted QR R^H = Q K Pi'
/// gives X = Pi K^H K Pi', so Pi K_k^H (the first k rows of K) is a factor with k columns; k keeps
/// the pivots |K_jj| > eps |K_11| (what is dropped is below the rounding of the factor itself).
/// Done in Schur coordinates, before the product with the n x n Schur vectors, which then costs
/// n^2 k instead of n^3 (rail_1357: k ~ 300 of 1357). The QR is LAPACK's (dense_lapack.hpp):
/// Eigen's unblocked one took about half of a dense balanced truncation at n = 3 002.
template <typename Scalar>
Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> compress(
    const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& R) {
  using M = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
  using Real = typename Eigen::NumTraits<Scalar>::Real;
  static_assert(std::is_same_v<Real, double>, "the QR is LAPACK's (double)");
  M K = R.adjoint();
  std::vector<int> perm;
  if (!detail::column_pivoted_qr(K, perm))
    throw NumericalError(std::string(kOrigin) + ": LAPACK's column-pivoted QR refused a factor");
  const Eigen::Index n = R.rows();
  const Eigen::Index kmax = std::min(R.rows(), R.cols());
  const Real top = kmax > 0 ? std::abs(K(0, 0)) : Real(0);
  const Real floor = std::numeric_limits<Real>::epsilon() * top;
  Eigen::Index k = 0;
  while (k < kmax && std::abs(K(k, k)) > floor) ++k;
  if (k == 0) return M::Zero(n, 1);
  const M Kk = K.topRows(k).template triangularView<Eigen::Upper>();
  M Z(n, k);
  for (Eigen::Index j = 0; j < n; ++j)
    Z.row(perm[static_cast<std::size_t>(j)]) = Kk.col(j).adjoint();
  return Z;
}

/// Real factor of the solution of F X + X F' + G G' = 0 from F's Schur form; `adjoint`: the
/// equation F' X + X F + G G' = 0 instead (T^H flipped: J T^H J is upper triangular).
template <typename S>
Mat<S> factor_from_schur(const Schur<S>& s, const Mat<S>& G, bool adjoint) {
  using C = std::complex<S>;
  const Eigen::Index n = G.rows();
  if (s.symmetric) {
    // F = Ur diag(d) Ur' is its own transpose: T X + X T + (Ur'G)(Ur'G)' = 0 with T = diag(d);
    // R is real (real diagonal T, real right-hand side).
    const CMat<S> T = s.d.template cast<C>().asDiagonal();
    const CMat<S> R = hammarling<S>(T, CMat<S>((s.Ur.transpose() * G).template cast<C>()), true);
    return s.Ur * compress<S>(Mat<S>(R.real()));
  }
  CMat<S> R;
  if (!adjoint) {
    R = hammarling<S>(s.T, CMat<S>(s.U.adjoint() * G.template cast<C>()), false);
  } else {
    // F' = U T^H U^H; with the flip J: T2 = J T^H J upper triangular, G2 = J U^H G, and
    // X = U J R2 R2^H J U^H.
    const CMat<S> T2 = s.T.adjoint().reverse();
    const CMat<S> G2 = (s.U.adjoint() * G.template cast<C>()).colwise().reverse();
    R = hammarling<S>(T2, G2, false).colwise().reverse();
  }
  // X = U R R^H U^H is real: X = Re(Z) Re(Z)' + Im(Z) Im(Z)' for Z = U Rk (k columns), a real
  // factor with 2k columns, compressed once more (now real, k <= n).
  const CMat<S> Z = dense_product(s.U, compress<C>(R));  // n x n by n x k: the BLAS's
  Mat<S> W(n, 2 * Z.cols());
  W << Z.real(), Z.imag();
  return compress<S>(W);
}

template <typename S>
LyapunovFactors factors_in(const Matrix& A_d, const Matrix& E_d, const Matrix& B_d,
                           const Matrix& C_d) {
  const Eigen::Index n = A_d.rows();
  const S eps = std::numeric_limits<S>::epsilon();
  const Mat<S> A = A_d.cast<S>();
  const Mat<S> B = B_d.cast<S>();
  const Mat<S> Ct = C_d.transpose().cast<S>();
  bool a_symmetric = nearly_symmetric<S>(A);
  enum class Reduction { Identity, Cholesky, Lu } reduction = Reduction::Identity;
  Mat<S> F, Gc, Go;
  Eigen::LLT<Mat<S>> llt;
  Eigen::PartialPivLU<Mat<S>> lu;
  if (E_d.size() == 0) {
    F = A;
    Gc = B;
    Go = Ct;
  } else {
    const Mat<S> E = E_d.cast<S>();
    if (nearly_symmetric<S>(E)) {
      llt.compute(Mat<S>(S(0.5) * (E + E.transpose())));
      if (llt.info() == Eigen::Success) {
        const S rc = llt.rcond();
        if (std::isfinite(static_cast<double>(rc)) && rc > static_cast<S>(n) * eps) {
          reduction = Reduction::Cholesky;
        }
      }
    }
    if (reduction == Reduction::Cholesky) {
      // F = L^-1 A L^-T; P = L^-T Yc L^-1 with F Yc + Yc F' + (L^-1 B)(L^-1 B)' = 0, and
      // E'QE = L Yo L' with F' Yo + Yo F + (L^-1 C')(L^-1 C')' = 0.
      const Mat<S> As = a_symmetric ? Mat<S>(S(0.5) * (A + A.transpose())) : A;
      const Mat<S> LA = llt.matrixL().solve(As);
      F = llt.matrixL().solve(Mat<S>(LA.transpose())).transpose();
      if (a_symmetric) F = (S(0.5) * (F + F.transpose())).eval();
      Gc = llt.matrixL().solve(B);
      Go = llt.matrixL().solve(Ct);
    } else {
      a_symmetric = false;
      lu.compute(E);
      const auto dg = lu.matrixLU().diagonal().cwiseAbs();
      const S rc = (dg.minCoeff() > S(0) && dg.allFinite()) ? lu.rcond() : S(0);
      if (!(rc > static_cast<S>(n) * eps)) {
        throw InputError(std::string(kOrigin) +
                         ": E is numerically singular (reciprocal condition " +
                         detail::number_text(static_cast<double>(rc)) +
                         "): descriptor models with singular E (DAEs) are not supported");
      }
      reduction = Reduction::Lu;
      // F = E^-1 A; P from (F, E^-1 B); Y = E'QE solves F'Y + YF + C'C = 0 directly.
      F = lu.solve(A);
      Gc = lu.solve(B);
      Go = Ct;
    }
  }

  Schur<S> s;
  s.symmetric = a_symmetric;
  if (a_symmetric) {
    const Eigen::SelfAdjointEigenSolver<Mat<S>> es(Mat<S>(S(0.5) * (F + F.transpose())));
    if (es.info() != Eigen::Success)
      throw NumericalError(std::string(kOrigin) +
                           ": the symmetric eigenvalue iteration of A did not converge");
    s.d = es.eigenvalues();
    s.Ur = es.eigenvectors();
  } else {
    // LAPACK's Schur form (dense_lapack.hpp), in double: another S needs its own Schur step.
    static_assert(std::is_same_v<S, double>, "the Schur step is LAPACK's dgees (double)");
    Matrix T, U;
    if (!detail::real_schur(F, T, U))
      throw NumericalError(std::string(kOrigin) +
                           ": the Schur iteration (QR) of A did not converge");
    s.T = T.cast<std::complex<S>>();
    s.U = U.cast<std::complex<S>>();
    detail::triangularize_blocks(s.T, s.U);
  }

  const Mat<S> Yc = factor_from_schur<S>(s, Gc, false);
  const Mat<S> Yo = factor_from_schur<S>(s, Go, true);
  LyapunovFactors out;
  out.symmetric = a_symmetric;
  switch (reduction) {
    case Reduction::Identity:
      out.Zc = Yc.template cast<double>();
      out.Zo = Yo.template cast<double>();
      out.Zq = out.Zo;
      break;
    case Reduction::Cholesky:
      out.Zc = Mat<S>(llt.matrixU().solve(Yc)).template cast<double>();
      out.Zq = Mat<S>(llt.matrixU().solve(Yo)).template cast<double>();
      out.Zo = Mat<S>(llt.matrixL() * Yo).template cast<double>();
      break;
    case Reduction::Lu:
      out.Zc = Yc.template cast<double>();
      out.Zo = Yo.template cast<double>();
      // Zq = E^-T Zo.
      out.Zq = Mat<S>(lu.transpose().solve(Yo)).template cast<double>();
      break;
  }
  return out;
}

void check(const Matrix& X, Eigen::Index rows, Eigen::Index cols, std::string_view name) {
  if ((rows >= 0 && X.rows() != rows) || (cols >= 0 && X.cols() != cols)) {
    throw InputError(std::string(kOrigin) + ": " + std::string(name) + " is " +
                     std::to_string(X.rows()) + " x " + std::to_string(X.cols()) +
                     ": inconsistent with A (" + std::to_string(rows >= 0 ? rows : cols) + ")");
  }
  if (!X.allFinite())
    throw InputError(std::string(kOrigin) + ": " + std::string(name) + " has a non-finite value");
}

}  // namespace

LyapunovFactors lyapunov_factors(const Matrix& A, const Matrix& E, const Matrix& B,
                                 const Matrix& C) {
  const Index n = A.rows();
  if (n == 0 || A.cols() != n)
    throw InputError(std::string(kOrigin) + ": A is " + std::to_string(A.rows()) + " x " +
                     std::to_string(A.cols()) + ": must be square and non-empty");
  check(A, n, n, "A");
  if (E.size() > 0) check(E, n, n, "E");
  check(B, n, -1, "B");
  check(C, -1, n, "C");
  return factors_in<double>(A, E, B, C);
}

}  // namespace ecmor
