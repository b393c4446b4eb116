#pragma once
// interpolation.hpp: the data IRKA iterates on (shifts and tangential directions), the pole-residue
// form of a reduced model it derives them from, and the comparisons of shift sets that its
// convergence, cycling and stagnation tests use. Private to the irka plugin (see README.md).
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::irka {

/// Shifts sigma_i closed under conjugation, each pair stored as (sigma, conj sigma) adjacent with
/// Im sigma > 0 first, real shifts after the pairs; column i of b (m x r) and c (p x r) are the
/// right and left tangential directions of shift i (conjugate for conjugate shifts).
struct Interpolation {
  std::vector<Complex> shifts;
  ComplexMatrix b;
  ComplexMatrix c;
  Index size() const { return static_cast<Index>(shifts.size()); }
};

/// Reduced poles lambda_i with residue directions: Gr(s) = sum_i c_i b_i^T / (s - lambda_i).
struct PoleResidues {
  ComplexVector poles;
  ComplexMatrix b;  ///< m x n
  ComplexMatrix c;  ///< p x n
  /// Reciprocal condition estimate of the eigenvector matrix (0: defective to working precision).
  double eigenvector_rcond = 0.0;
};

/// Pole-residue form of E x' = A x + B u, y = C x (E nonsingular, A diagonalisable).
/// \throws NumericalError when E is numerically singular or the eigenvectors are (numerically)
///         dependent, naming what failed.
inline PoleResidues pole_residues(const Matrix& E, const Matrix& A, const Matrix& B,
                                  const Matrix& C) {
  const Index n = A.rows();
  PoleResidues out;
  if (n == 0) return out;
  const Eigen::PartialPivLU<Matrix> lu(E);
  const double rcond = lu.rcond();
  if (!(rcond > std::numeric_limits<double>::epsilon() * static_cast<double>(n))) {
    throw NumericalError(fmt::format(
        "the reduced E = W' E V is numerically singular (reciprocal condition {:.2e}): the bases "
        "V and W are (nearly) orthogonal to each other",
        rcond));
  }
  const Matrix F = lu.solve(A);
  const Matrix G = lu.solve(B);
  const Eigen::EigenSolver<Matrix> eig(F);
  if (eig.info() != Eigen::Success) {
    throw NumericalError("the eigenvalues of the reduced model did not converge (QR iteration)");
  }
  out.poles = eig.eigenvalues();
  const ComplexMatrix X = eig.eigenvectors();
  const Eigen::PartialPivLU<ComplexMatrix> xlu(X);
  out.eigenvector_rcond = xlu.rcond();
  if (!(out.eigenvector_rcond > 1e3 * std::numeric_limits<double>::epsilon())) {
    throw NumericalError(fmt::format(
        "the reduced model is not diagonalisable to working precision (eigenvector matrix "
        "reciprocal condition {:.2e}): its poles and residues, hence the next shifts, are "
        "undefined",
        out.eigenvector_rcond));
  }
  out.c = C.cast<Complex>() * X;
  out.b = xlu.solve(G.cast<Complex>()).transpose();
  return out;
}

/// Pole-residue form of a symmetric definite reduced model (E SPD, A symmetric, as a one-sided
/// projection W = V of a symmetric definite model gives): A x = lambda E x by the symmetric
/// generalised eigensolver, so the poles are real and the eigenvectors E-orthonormal (X' E X = I,
/// X^-1 = X' E): b_i = B' x_i, c_i = C x_i. The symmetric parts of E and A are used (rounding).
/// \throws NumericalError when E is not numerically positive definite.
inline PoleResidues symmetric_pole_residues(const Matrix& E, const Matrix& A, const Matrix& B,
                                            const Matrix& C) {
  PoleResidues out;
  if (A.rows() == 0) return out;
  const Matrix Es = 0.5 * (E + E.transpose()), As = 0.5 * (A + A.transpose());
  const Eigen::LLT<Matrix> llt(Es);
  if (llt.info() != Eigen::Success) {
    throw NumericalError(
        "the reduced E = V' E V of a one-sided projection is not numerically positive definite: "
        "the basis V is (nearly) rank deficient");
  }
  const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> eig(As, Es);
  if (eig.info() != Eigen::Success) {
    throw NumericalError("the symmetric generalised eigenvalues of the reduced model failed");
  }
  const Matrix& X = eig.eigenvectors();
  out.poles = eig.eigenvalues().cast<Complex>();
  out.b = (B.transpose() * X).cast<Complex>();
  out.c = (C * X).cast<Complex>();
  out.eigenvector_rcond = Eigen::PartialPivLU<Matrix>(X).rcond();
  return out;
}

/// The H2 inner product <Ga, Gb> = (1/2 pi) integral trace(Ga(i w)^H Gb(i w)) dw of two stable
/// models in pole-residue form: -sum_ij (c_i^H d_j)(b_i^H e_j) / (conj(lambda_i) + mu_j).
inline Complex h2_inner(const PoleResidues& a, const PoleResidues& b) {
  const ComplexMatrix cc = a.c.adjoint() * b.c;  // c_i^H d_j
  const ComplexMatrix bb = a.b.adjoint() * b.b;  // b_i^H e_j
  Complex sum(0.0, 0.0);
  for (Index i = 0; i < a.poles.size(); ++i) {
    for (Index j = 0; j < b.poles.size(); ++j) {
      sum -= cc(i, j) * bb(i, j) / (std::conj(a.poles(i)) + b.poles(j));
    }
  }
  return sum;
}

/// ||Gb - Ga||_H2 / ||Gb||_H2 from the pole-residue forms, O(r^2 (m + p)); infinity when a pole
/// of either model has Re >= 0 (no H2 norm). Computed as ||Ga||^2 + ||Gb||^2 - 2 Re <Ga, Gb>, so
/// a change below about 1e-7 is rounding: fine for convergence tolerances of 1e-7 and above.
inline double relative_h2_change(const PoleResidues& a, const PoleResidues& b) {
  for (const auto* p : {&a, &b}) {
    for (const Complex& z : p->poles) {
      if (!(z.real() < 0.0)) return std::numeric_limits<double>::infinity();
    }
  }
  const double aa = h2_inner(a, a).real(), bb = h2_inner(b, b).real();
  const double ab = h2_inner(a, b).real();
  if (!(bb > 0.0)) return std::numeric_limits<double>::infinity();
  return std::sqrt(std::max(0.0, aa + bb - 2.0 * ab) / bb);
}

/// Orders the shifts as Interpolation requires (pairs (Im > 0, Im < 0) adjacent, sorted by |Im|,
/// then real shifts ascending), permuting the direction columns alike. Imaginary parts below
/// 1e-12 |sigma| are set to zero (a real shift) with real directions. The caller guarantees
/// closure under conjugation.
/// \throws NumericalError if a shift has no conjugate partner.
inline Interpolation canonical(const std::vector<Complex>& shifts, const ComplexMatrix& b,
                               const ComplexMatrix& c) {
  const Index r = static_cast<Index>(shifts.size());
  std::vector<Index> upper, lower, real;
  std::vector<Complex> s = shifts;
  for (Index i = 0; i < r; ++i) {
    if (std::abs(s[i].imag()) <= 1e-12 * std::abs(s[i])) {
      s[i] = Complex(s[i].real(), 0.0);
      real.push_back(i);
    } else if (s[i].imag() > 0.0) {
      upper.push_back(i);
    } else {
      lower.push_back(i);
    }
  }
  if (upper.size() != lower.size()) {
    throw NumericalError(
        fmt::format("{} shifts with Im > 0 but {} with Im < 0: the shift set is not "
                    "closed under conjugation",
                    upper.size(), lower.size()));
  }
  std::sort(upper.begin(), upper.end(), [&](Index x, Index y) {
    return s[x].imag() != s[y].imag() ? s[x].imag() < s[y].imag() : s[x].real() < s[y].real();
  });
  std::sort(real.begin(), real.end(), [&](Index x, Index y) { return s[x].real() < s[y].real(); });
  Interpolation out;
  out.b.resize(b.rows(), r);
  out.c.resize(c.rows(), r);
  Index k = 0;
  for (Index i : upper) {
    out.shifts.push_back(s[i]);
    out.shifts.push_back(std::conj(s[i]));
    out.b.col(k) = b.col(i);
    out.b.col(k + 1) = b.col(i).conjugate();
    out.c.col(k) = c.col(i);
    out.c.col(k + 1) = c.col(i).conjugate();
    k += 2;
  }
  for (Index i : real) {
    out.shifts.push_back(s[i]);
    // A real shift's directions are real up to a complex factor; the subspace does not care about
    // the factor, so keep the larger of the real and imaginary parts.
    auto real_part = [](const ComplexVector& v) -> ComplexVector {
      const double re = v.real().norm(), im = v.imag().norm();
      const Vector part = re >= im ? Vector(v.real()) : Vector(v.imag());
      return part.cast<Complex>();
    };
    out.b.col(k) = real_part(b.col(i));
    out.c.col(k) = real_part(c.col(i));
    ++k;
  }
  return out;
}

/// Sine of the angle between two direction vectors (0: the same line; phase-invariant).
inline double direction_angle(const ComplexVector& x, const ComplexVector& y) {
  const double nx = x.norm(), ny = y.norm();
  if (nx == 0.0 || ny == 0.0) return nx == ny ? 0.0 : 1.0;
  const double cosine = std::min(1.0, std::abs(x.dot(y)) / (nx * ny));
  return std::sqrt(std::max(0.0, 1.0 - cosine * cosine));
}

/// How far two interpolation data sets of the same size are apart: a greedy nearest matching of
/// the shifts, then the largest of |sigma_new - sigma_old| / |sigma_old| and the sines of the
/// angles between matched directions b and c (so MIMO data converge only when the tangential
/// directions do too). Infinity when the sizes differ.
inline double data_change(const Interpolation& previous, const Interpolation& next,
                          bool with_directions = true) {
  if (previous.size() != next.size()) return std::numeric_limits<double>::infinity();
  const std::size_t r = previous.shifts.size();
  std::vector<bool> used(r, false);
  double worst = 0.0;
  for (std::size_t i = 0; i < r; ++i) {
    const Complex s = next.shifts[i];
    std::size_t best = r;
    double distance = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < r; ++j) {
      if (used[j]) continue;
      const double d = std::abs(s - previous.shifts[j]);
      if (d < distance) {
        distance = d;
        best = j;
      }
    }
    used[best] = true;
    const double scale =
        std::max(std::abs(previous.shifts[best]), std::numeric_limits<double>::min());
    const auto ib = static_cast<Index>(i), jb = static_cast<Index>(best);
    worst = std::max(worst, distance / scale);
    if (with_directions) {
      worst = std::max({worst, direction_angle(previous.b.col(jb), next.b.col(ib)),
                        direction_angle(previous.c.col(jb), next.c.col(ib))});
    }
  }
  return worst;
}

/// A relaxed IRKA step: each new shift moves only the fraction alpha from its matched old shift
/// towards its new value (the fixed points are those of the plain step, alpha = 1). Pairs are
/// matched with pairs (their members with Im > 0) and real shifts with real shifts, greedily by
/// distance, so the result stays closed under conjugation; directions are the new ones. When the
/// numbers of pairs differ the plain step is returned. A 2-cycle of the plain iteration (an
/// eigenvalue of its Jacobian near -1) becomes a contraction for alpha = 1/2.
inline Interpolation relax(const Interpolation& previous, const Interpolation& next, double alpha) {
  if (alpha >= 1.0 || previous.size() != next.size()) return next;
  auto members = [](const Interpolation& d, bool pairs) {
    std::vector<Index> out;
    for (Index i = 0; i < d.size(); ++i) {
      const Complex s = d.shifts[static_cast<std::size_t>(i)];
      if (pairs ? s.imag() > 0.0 : s.imag() == 0.0) out.push_back(i);
    }
    return out;
  };
  std::vector<Complex> shifts = next.shifts;
  for (const bool pairs : {true, false}) {
    const std::vector<Index> old_set = members(previous, pairs), new_set = members(next, pairs);
    if (old_set.size() != new_set.size()) return next;
    std::vector<bool> used(old_set.size(), false);
    for (const Index i : new_set) {
      const Complex s = next.shifts[static_cast<std::size_t>(i)];
      std::size_t best = 0;
      double distance = std::numeric_limits<double>::infinity();
      for (std::size_t j = 0; j < old_set.size(); ++j) {
        const double d = std::abs(s - previous.shifts[static_cast<std::size_t>(old_set[j])]);
        if (!used[j] && d < distance) {
          distance = d;
          best = j;
        }
      }
      used[best] = true;
      const Complex old = previous.shifts[static_cast<std::size_t>(old_set[best])];
      shifts[static_cast<std::size_t>(i)] = old + alpha * (s - old);
      if (pairs)
        shifts[static_cast<std::size_t>(i) + 1] = std::conj(shifts[static_cast<std::size_t>(i)]);
    }
  }
  return canonical(shifts, next.b, next.c);
}

}  // namespace ecmor::irka
