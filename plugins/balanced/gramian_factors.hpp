#pragma once
/// \file gramian_factors.hpp
/// Gramian factors of the first-order realisation (E, A, B, C) of a full model, computed once per
/// setup() of the balanced reducer (balanced.cpp). Private to the plugin (and its tests).
///
/// Everything downstream (truncation, second-order variants) sees only the factors
///     P ~ Zc Zc',     Q ~ Zq Zq',     E'QE ~ Zo Zo'  (Zo = E' Zq),
/// of the controllability and observability Gramians
///     A P E' + E P A' + B B' = 0,     A' Q E + E' Q A + C' C = 0,
/// so that the low-rank ADI factors (lowrank_factors.hpp) go through the same truncation code: ADI
/// also returns Zc and Zq, and Zo = E' Zq is a product with E (FirstOrderView::apply_e_transposed,
/// no 2N matrix).
///
/// Dense route (this file): the pencil checked by ecmor::stable_pencil (refuses unstable models and
/// singular E), then the factors computed directly, never the Gramians, by Hammarling's method
/// (ecmor::lyapunov_factors, lyapunov_factor.hpp): a factor computed directly has a small normwise
/// error, so the HSVs (singular values of Zo' Zc) carry absolute errors ~ eps s_1, whereas
/// factoring computed Gramians (absolute errors ~ n eps ||X||) moves an HSV s_i by
/// ~ n eps ||P|| ||E'QE|| / s_i (measured on heat_cont: s_10 = 7e-8 s_1 was off by 4e-7 relative).
/// Measured against a long-double factored sign function (test_balanced): the leading ten HSVs of
/// build, iss, cdplayer and heat_cont agree to <= 2e-11 relative in double (heat_cont's
/// s_10 = 7e-8 s_1: 1.4e-11), so no extended precision is needed.
///
/// The frequency-limited right-hand sides (below) are indefinite, which Hammarling's method (a
/// Cholesky factor of the solution, for a right-hand side G G') cannot take: that route keeps
/// Bartels-Stewart on the Schur form (lyapunov.hpp) and factors the (semidefinite) band Gramians
/// afterwards by Cholesky with complete pivoting stopped at the rounding level (psd_factor).
///
/// Frequency-limited Gramians (Gawronski and Juang, "Model reduction in limited time and frequency
/// intervals", Int. J. Systems Sci. 21, 1990), on the band Omega = +-[w1, w2] (rad/s):
///     P_Omega = (1/2pi) int_Omega (iwE - A)^-1 B B' (iwE - A)^-H dw,
///     E' Q_Omega E = (1/2pi) int_Omega E'(iwE - A)^-H C'C (iwE - A)^-1 E dw.
/// With F = E^-1 A, Bt = E^-1 B and the real matrix S = (1/2pi) int_Omega (iwI - F)^-1 dw, they are
/// S P + P S' and S'(E'QE) + (E'QE)S, and they solve
///     A P_Omega E' + E P_Omega A' + E S Bt B' + B Bt' S' E' = 0,
///     A' Q_Omega E + E' Q_Omega A + S' C'C + C'C S = 0,
/// which is how they are computed here: the same Lyapunov solver with these right-hand sides, which
/// need only S Bt and C S. S = s(F) for the scalar function
///     s(l) = (1/2pi) int_Omega dw / (iw - l) = g(l / w2) - g(l / w1),
///     g(z) = (1 / 2 pi i) [Log(i - z) - Log(-i - z)]
/// (for Re l < 0 both logarithms stay in the right half plane: no branch cut is crossed, unlike the
/// textbook form (i/2pi) Log((F + iwI)(F - iwI)^-1), whose argument approaches the negative real
/// axis for |l| << w), applied through the eigendecomposition of F (band_filter_products). The band
/// Gramians are integrals of semidefinite matrices, hence semidefinite, although the right-hand
/// sides are indefinite (which is why FL-BT has neither a bound nor a stability guarantee).
#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <optional>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>
#include <variant>

#include "ecmor/base/error.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/gramians/lyapunov_factor.hpp"
#include "ecmor/linalg/dense_kernels.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::balanced {

/// The factors and how they were obtained.
struct GramianFactors {
  Matrix Zc;                ///< P ~ Zc Zc' (state x kc)
  Matrix Zq;                ///< Q ~ Zq Zq' (state x ko)
  Matrix Zo;                ///< E'QE ~ Zo Zo', Zo = E' Zq
  double seconds = 0.0;     ///< wall time of the Gramians and factors
  double residual_c = 0.0;  ///< ||A P E' + E P A' + R_c||_F / ||R_c||_F with P = Zc Zc'
  double residual_o = 0.0;  ///< same for Q = Zq Zq' (R_c = B B', R_o = C'C, or the band's)
  bool band_limited = false;
  Index states = 0;  ///< size of the first-order state (N or 2N)
  /// Rows per block whose rounding errors scale with the block itself (0: one block). The low-rank
  /// factors of a second-order model are computed through s^2 M + s D + K, positions and velocities
  /// each to its own relative accuracy: N here (balance() in balanced.cpp says what it is for).
  Index block_rows = 0;
};

/// ||A Z Z' E' + E Z Z' A' + R||_F / ||R||_F without forming Z Z' (n^2 k instead of n^3 flops).
inline double factored_lyapunov_residual(const Matrix& A, const Matrix& E, const Matrix& Z,
                                         const Matrix& R) {
  // n x n by n x k with k up to n: the BLAS's products (dense_kernels.hpp says why).
  const Matrix AZ = dense_product(A, Z);
  const Matrix EZ = dense_product(E, Z);
  Matrix res = dense_product(AZ, EZ, false, true);
  res += res.transpose().eval();
  res += R;
  const double rn = R.norm();
  return rn > 0.0 ? res.norm() / rn : res.norm();
}

/// A factor Z (n x k, k <= n) with Z Z' ~ X for a symmetric positive semidefinite X: Cholesky with
/// complete (diagonal) pivoting, right-looking so that every step pivots on the largest diagonal of
/// the current Schur complement (Eigen::LDLT pivots on stale diagonals and is not rank revealing).
/// Stops when the largest remaining diagonal is <= eps max_i X_ii: the remainder X - Z Z' is
/// semidefinite with trace <= n eps max_i X_ii, within the rounding of X itself (a backward-stable
/// solver leaves absolute errors of about n eps ||X||), so the dropped part carries no information.
/// Cost O(n k^2): low-rank Gramians give short factors, as low-rank ADI would.
inline Matrix psd_factor(const Matrix& X) {
  const Index n = X.rows();
  Vector diag = X.diagonal();
  const double dmax = n > 0 ? diag.maxCoeff() : 0.0;
  if (!(dmax > 0.0)) return Matrix::Zero(n, 1);
  const double floor = std::numeric_limits<double>::epsilon() * dmax;
  Matrix Z(n, std::min<Index>(n, 64));
  Index k = 0;
  while (k < n) {
    Index j = 0;
    const double pivot = diag.maxCoeff(&j);
    if (!(pivot > floor)) break;
    if (k == Z.cols()) Z.conservativeResize(n, std::min<Index>(n, 2 * Z.cols()));
    Vector z = 0.5 * (X.col(j) + X.row(j).transpose());
    if (k > 0) z.noalias() -= Z.leftCols(k) * Z.row(j).head(k).transpose();
    z /= std::sqrt(pivot);
    Z.col(k) = z;
    diag -= z.cwiseAbs2();
    diag(j) = 0.0;  // exactly eliminated (rounding could leave a spurious pivot)
    ++k;
  }
  Z.conservativeResize(n, std::max<Index>(k, 1));
  if (k == 0) Z.setZero();
  return Z;
}

namespace detail {

/// g(z) = (1 / 2 pi i) [Log(i - z) - Log(-i - z)] and its derivatives (Eigen's stem-function
/// signature: a plain function, hence the band is applied by scaling F, not by a capture).
inline std::complex<double> band_stem(std::complex<double> z, int k) {
  const std::complex<double> i(0.0, 1.0);
  const std::complex<double> two_pi_i(0.0, kTwoPi);
  if (k == 0) return (std::log(i - z) - std::log(-i - z)) / two_pi_i;
  double factorial = 1.0;  // (k - 1)!
  for (int j = 2; j < k; ++j) factorial *= static_cast<double>(j);
  return factorial * (std::pow(-i - z, -k) - std::pow(i - z, -k)) / two_pi_i;
}

}  // namespace detail

/// s(l) = (1/2pi) int_{+-[w1, w2]} dw / (iw - l) = g(l / w2) - g(l / w1) for one eigenvalue.
inline std::complex<double> band_scalar(std::complex<double> l, double w1, double w2) {
  return detail::band_stem(l / w2, 0) - detail::band_stem(l / w1, 0);
}

/// S = (1/2pi) int_{+-[w1, w2]} (iw I - F)^-1 dw for a stable F (0 < w1 < w2, rad/s); real. By
/// Schur-Parlett (Eigen's MatrixFunctions): the fallback when F's eigenvectors are ill conditioned.
/// Its Taylor series on clusters of close eigenvalues converge slowly when a cluster lies near the
/// singularities z = +-i of g (a pole near a band edge), hence not the first choice.
inline Matrix band_filter(const Matrix& F, double w1, double w2) {
  const Matrix S2 = Matrix(F / w2).matrixFunction(detail::band_stem);
  const Matrix S1 = Matrix(F / w1).matrixFunction(detail::band_stem);
  Matrix S = S2 - S1;
  if (!S.allFinite()) {
    throw NumericalError(
        fmt::format("balanced: the band filter S(F) of the frequency-limited Gramians on [{:.6g}, "
                    "{:.6g}] rad/s "
                    "is not finite (a pole on the imaginary axis at a band edge?)",
                    w1, w2));
  }
  return S;
}

/// The right-hand sides of the frequency-limited Lyapunov equations need only S Bt and C S
/// (Bt = E^-1 B), not S itself: with F = X L X^-1 (Eigen's QR algorithm), S Bt = X s(L) X^-1 Bt and
/// C S = C X s(L) X^-1, each eigenvalue's s(l) exact (no series). The error is about
/// eps cond(X); when the eigenvectors are ill conditioned (rcond(X) < 1e-10: a nearly defective F)
/// the Schur-Parlett S is used instead.
struct BandFilterProducts {
  Matrix SB;  ///< S Bt, n x m
  Matrix CS;  ///< C S, p x n
  double eigenvector_rcond = 0.0;
  bool schur_parlett = false;
};

inline BandFilterProducts band_filter_products(const Matrix& F, const Matrix& Bt, const Matrix& C,
                                               double w1, double w2) {
  BandFilterProducts out;
  const Eigen::EigenSolver<Matrix> es(F);
  if (es.info() == Eigen::Success) {
    const ComplexMatrix X = es.eigenvectors();
    const Eigen::PartialPivLU<ComplexMatrix> lu(X);
    out.eigenvector_rcond = lu.rcond();
    if (out.eigenvector_rcond >= 1e-10) {
      ComplexVector sv(F.rows());
      for (Index i = 0; i < F.rows(); ++i) sv(i) = band_scalar(es.eigenvalues()(i), w1, w2);
      const ComplexMatrix XiB = lu.solve(ComplexMatrix(Bt.cast<Complex>()));
      out.SB = (X * (sv.asDiagonal() * XiB)).real();
      // C S = ((C X) s(L)) X^-1, i.e. (C S)' = X^-T (s(L) (C X)').
      const ComplexMatrix CX = C.cast<Complex>() * X;
      const ComplexMatrix rhs = sv.asDiagonal() * CX.transpose();
      const Eigen::PartialPivLU<ComplexMatrix> lut(X.transpose());
      out.CS = lut.solve(rhs).transpose().real();
      if (out.SB.allFinite() && out.CS.allFinite()) return out;
    }
  }
  const Matrix S = band_filter(F, w1, w2);
  out.schur_parlett = true;
  out.SB = S * Bt;
  out.CS = C * S;
  return out;
}

/// For a refused singular E: its finite poles by dense shift-invert (eigenvalues mu of
/// (A - sigma E)^-1 E, lambda = sigma + 1/mu, mu ~ 0 the infinite ones; QZ does not converge on
/// pencils as badly scaled as peec's), and a text naming those with Re >= 0, or "".
inline std::string singular_e_poles_text(const Matrix& A, const Matrix& E) {
  const double sigma = -A.norm() / std::max(E.norm(), std::numeric_limits<double>::min());
  const Eigen::PartialPivLU<Matrix> lu(A - sigma * E);
  if (!(lu.rcond() > 1e-14)) return {};
  const Eigen::EigenSolver<Matrix> es(Matrix(lu.solve(E)), false);
  if (es.info() != Eigen::Success) return {};
  const ComplexVector mu = es.eigenvalues();
  const double largest_mu = mu.size() > 0 ? mu.cwiseAbs().maxCoeff() : 0.0;
  Index finite = 0, unstable = 0;
  double largest = -std::numeric_limits<double>::infinity();
  for (const Complex& z : mu) {
    if (!(std::abs(z) > 1e-12 * largest_mu)) continue;
    const Complex l = sigma + 1.0 / z;
    ++finite;
    if (l.real() >= -1e-12 * std::abs(l)) ++unstable;
    largest = std::max(largest, l.real());
  }
  if (unstable == 0) return {};
  return fmt::format(
      "; besides, {} of its {} computed finite poles have Re >= 0 (largest real part {:.3e}), "
      "which for a singular E may also be perturbed infinite eigenvalues",
      unstable, finite, largest);
}

/// The refusal of a model whose Gramians do not exist (the dense solver broke down with `e`).
inline InputError no_gramians(const NumericalError& e) {
  return InputError(fmt::format(
      "balanced: the Gramians do not exist to working precision: {} (an undamped or marginally "
      "damped model, poles on or next to the imaginary axis, has no finite Gramians)",
      e.what()));
}

/// The Gramian factors of a stable model with nonsingular E (M) of at most kMaxDenseStates
/// first-order states; `band` (Hz) set: the frequency-limited Gramians on that band.
/// \throws InputError naming the problem for a model too large for dense Gramians, an unstable or
///         undamped model (Gramians do not exist) and a singular E or M (a DAE).
inline GramianFactors dense_gramian_factors(const Model& model,
                                            const std::optional<Band>& band = std::nullopt) {
  const auto started = std::chrono::steady_clock::now();
  const bool second = std::holds_alternative<SecondOrderModel>(model);
  const Index states = second ? 2 * size_of(model) : size_of(model);
  if (states > kMaxDenseStates) {
    throw InputError(fmt::format(
        "balanced: the model has {} first-order states{}: dense Gramians are limited to "
        "kMaxDenseStates = {} (a dense Schur form of that size takes minutes): use gramians: auto "
        "or lowrank (low-rank ADI factors)",
        states, second ? fmt::format(" (2N, N = {})", size_of(model)) : std::string(),
        kMaxDenseStates));
  }
  const ReducedModel dense = densify(model);
  const ReducedDescriptorModel fo = first_order_realization(dense);
  std::optional<SchurPencil> pencil;
  try {
    // Checks stability (all poles Re < 0) and a nonsingular E, as ecmor::gramians does.
    pencil.emplace(stable_pencil(dense, "gramians"));
  } catch (const InputError& e) {
    const std::string what = e.what();
    const bool singular = what.find("singular") != std::string::npos;
    const std::string poles_text =
        singular && !second ? singular_e_poles_text(fo.A, fo.E) : std::string();
    throw InputError(fmt::format(
        "balanced: the Gramians do not exist: {}{}{}", what, poles_text,
        singular ? (second ? " (the realisation's E = diag(I, M): M is singular)"
                           : " (E singular: a DAE; balanced truncation of descriptor systems with "
                             "singular E, by spectral projectors, is not implemented)")
                 : " (an unstable model has no Gramians: balanced truncation needs all poles "
                   "with Re < 0)"));
  }
  const Index n = fo.A.rows();
  Matrix Rc = fo.B * fo.B.transpose();
  Matrix Ro = fo.C.transpose() * fo.C;
  GramianFactors out;
  out.states = n;
  if (band) {
    // A P E' + E P A' + S~BB' + BB'S~' = 0 with S~ B = E (S Bt), and
    // A'QE + E'QA + S'C'C + C'CS = 0: only S Bt and C S are needed.
    out.band_limited = true;
    const Eigen::PartialPivLU<Matrix> lu(fo.E);
    const Matrix F = lu.solve(fo.A);
    const Matrix Bt = lu.solve(fo.B);
    const BandFilterProducts bf =
        band_filter_products(F, Bt, fo.C, kTwoPi * band->f_min_hz, kTwoPi * band->f_max_hz);
    const Matrix SB = fo.E * bf.SB;
    Rc = SB * fo.B.transpose();
    Rc = (Rc + Rc.transpose()).eval();
    Ro = bf.CS.transpose() * fo.C;
    Ro = (Ro + Ro.transpose()).eval();
  }
  if (!band) {
    // Hammarling's method: the factors directly (see the file comment).
    LyapunovFactors f;
    try {
      f = lyapunov_factors(fo.A, fo.E, fo.B, fo.C);
    } catch (const NumericalError& e) {
      throw no_gramians(e);
    }
    out.Zc = std::move(f.Zc);
    out.Zq = std::move(f.Zq);
    out.Zo = std::move(f.Zo);
  } else {
    Matrix P, Q;
    try {
      P = solve_sylvester(*pencil, *pencil, Rc);
      // A'QE + E'QA + Ro = 0 is the Lyapunov equation of the transposed pencil; a symmetric
      // pencil is its own transpose.
      if (pencil->symmetric()) {
        Q = solve_sylvester(*pencil, *pencil, Ro);
      } else {
        const SchurPencil transposed(Matrix(fo.A.transpose()), Matrix(fo.E.transpose()),
                                     "gramians");
        Q = solve_sylvester(transposed, transposed, Ro);
      }
    } catch (const NumericalError& e) {
      throw no_gramians(e);
    }
    out.Zc = psd_factor(P);
    out.Zq = psd_factor(Q);
    out.Zo = fo.E.transpose() * out.Zq;
  }
  out.residual_c = factored_lyapunov_residual(fo.A, fo.E, out.Zc, Rc);
  out.residual_o =
      factored_lyapunov_residual(Matrix(fo.A.transpose()), Matrix(fo.E.transpose()), out.Zq, Ro);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return out;
}

}  // namespace ecmor::balanced
