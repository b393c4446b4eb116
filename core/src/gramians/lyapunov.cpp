// lyapunov.cpp: dense Lyapunov and Sylvester equations by Bartels-Stewart on the complex Schur
// form, Gramians of small stable models, and the dense conversion of small full models.
#include "ecmor/gramians/lyapunov.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "base/number_text.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "linalg/dense_lapack.hpp"
#include "linalg/qz_solver.hpp"

namespace ecmor {

namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

std::string dims(const Matrix& X) {
  return std::to_string(X.rows()) + " x " + std::to_string(X.cols());
}

/// Sizes (rows x cols, negative: not checked) and finiteness of one argument.
void check_matrix(const Matrix& X, Index rows, Index cols, std::string_view origin,
                  std::string_view name, std::string_view rule) {
  if ((rows >= 0 && X.rows() != rows) || (cols >= 0 && X.cols() != cols))
    throw InputError(std::string(origin) + ": " + std::string(name) + " is " + dims(X) +
                     ": must be " + std::to_string(rows) + " x " + std::to_string(cols) + " " +
                     std::string(rule));
  for (Index j = 0; j < X.cols(); ++j)
    for (Index i = 0; i < X.rows(); ++i)
      if (!std::isfinite(X(i, j)))
        throw InputError(std::string(origin) + ": " + std::string(name) +
                         " has a non-finite value (" + detail::number_text(X(i, j)) + ") at (" +
                         std::to_string(i + 1) + ", " + std::to_string(j + 1) + ")");
}

void check_square(const Matrix& A, std::string_view origin, std::string_view name) {
  if (A.rows() != A.cols() || A.rows() == 0)
    throw InputError(std::string(origin) + ": " + std::string(name) + " is " + dims(A) +
                     ": must be square and non-empty");
  check_matrix(A, A.rows(), A.rows(), origin, name, "");
}

/// Reciprocal condition estimate of an LU, 0 for an exactly singular one (Eigen's estimator is
/// meaningless when a pivot is exactly zero).
double safe_rcond(const Eigen::PartialPivLU<Matrix>& lu) {
  const auto d = lu.matrixLU().diagonal().cwiseAbs();
  if (!(d.minCoeff() > 0.0) || !d.allFinite()) return 0.0;
  const double rc = lu.rcond();
  return std::isfinite(rc) ? rc : 0.0;
}

bool nearly_symmetric(const Matrix& X) {
  const double scale = X.cwiseAbs().maxCoeff();
  return (X - X.transpose()).cwiseAbs().maxCoeff() <= 1e-14 * scale;
}

}  // namespace

// The pencil in standard form F = S A T with S E T = I, and F = U T U^H.
struct SchurPencil::Impl {
  enum class Reduction { Identity, Cholesky, Lu };
  Reduction reduction = Reduction::Identity;
  Index n = 0;
  std::string origin;
  Eigen::LLT<Matrix> llt;          // E = L L'
  Eigen::PartialPivLU<Matrix> lu;  // E = P^-1 L U
  double e_rcond = 1.0;            // reciprocal condition of E (1 for identity)
  bool symmetric = false;          // F symmetric: T = diag(d) real, U = Ur real orthogonal
  Vector d;
  Matrix Ur;
  ComplexMatrix T, U;
  ComplexVector eigenvalues;
  double scale = 0.0;  // max |lambda| (or ||F||), for the singularity test

  /// S M: the left transformation applied to M.
  Matrix left(const Matrix& M) const {
    switch (reduction) {
      case Reduction::Identity:
        return M;
      case Reduction::Cholesky:
        return llt.matrixL().solve(M);
      case Reduction::Lu:
        return lu.solve(M);
    }
    return M;
  }
  /// T Y: the right transformation (X = T Y T2').
  Matrix back(const Matrix& Y) const {
    if (reduction == Reduction::Cholesky) return llt.matrixU().solve(Y);
    return Y;
  }
  /// T' M.
  Matrix back_transposed(const Matrix& M) const {
    if (reduction == Reduction::Cholesky) return llt.matrixL().solve(M);
    return M;
  }
};

SchurPencil::SchurPencil(const Matrix& A, const Matrix& E, std::string_view origin) {
  auto impl = std::make_shared<Impl>();
  impl->origin = std::string(origin);
  check_square(A, origin, "A");
  const Index n = A.rows();
  impl->n = n;
  if (E.size() > 0) check_matrix(E, n, n, origin, "E", "(the size of A) or empty (= I)");

  Matrix F;
  // Symmetry up to rounding (products such as V' E V are symmetric only to a few ulps); the
  // symmetric part is used then, a change at the level of the data's own rounding.
  bool a_symmetric = nearly_symmetric(A);
  if (E.size() == 0) {
    impl->reduction = Impl::Reduction::Identity;
    F = A;
  } else {
    // Cholesky first when E is symmetric: F = L^-1 A L^-T stays symmetric with A, and is as well
    // conditioned as the pencil allows. Otherwise (or if E is indefinite) F = E^-1 A.
    bool done = false;
    if (nearly_symmetric(E)) {
      impl->llt.compute(Matrix(0.5 * (E + E.transpose())));
      if (impl->llt.info() == Eigen::Success) {
        const double rc = impl->llt.rcond();
        if (std::isfinite(rc) && rc > static_cast<double>(n) * kEps) {
          impl->reduction = Impl::Reduction::Cholesky;
          impl->e_rcond = rc;
          const Matrix LA =
              impl->llt.matrixL().solve(a_symmetric ? Matrix(0.5 * (A + A.transpose())) : A);
          F = impl->llt.matrixL().solve(Matrix(LA.transpose())).transpose();
          if (a_symmetric) F = 0.5 * (F + F.transpose());
          done = true;
        }
      }
    }
    if (!done) {
      impl->reduction = Impl::Reduction::Lu;
      a_symmetric = false;
      impl->lu.compute(E);
      impl->e_rcond = safe_rcond(impl->lu);
      if (!(impl->e_rcond > static_cast<double>(n) * kEps))
        throw InputError(std::string(origin) +
                         ": E is numerically singular (reciprocal condition " +
                         detail::number_text(impl->e_rcond) +
                         " <= n eps = " + detail::number_text(static_cast<double>(n) * kEps) +
                         "): descriptor models with singular E (DAEs) are not supported");
      F = impl->lu.solve(A);
    }
  }

  impl->symmetric = a_symmetric;
  if (a_symmetric) {
    Eigen::SelfAdjointEigenSolver<Matrix> es(Matrix(0.5 * (F + F.transpose())));
    if (es.info() != Eigen::Success)
      throw NumericalError(std::string(origin) +
                           ": the symmetric eigenvalue iteration of A did not converge");
    impl->d = es.eigenvalues();
    impl->Ur = es.eigenvectors();
    impl->eigenvalues = impl->d.cast<Complex>();
  } else {
    // The real Schur form is 3-4x faster than a complex one (measured with Eigen: 1.4 s vs 5.2 s
    // at n = 602); its 2 x 2 blocks are then triangularised by one complex rotation each.
    Matrix T, U;
    if (!detail::real_schur(F, T, U))
      throw NumericalError(std::string(origin) +
                           ": the Schur iteration (QR) of A did not converge");
    impl->T = T.cast<Complex>();
    impl->U = U.cast<Complex>();
    detail::triangularize_blocks(impl->T, impl->U);
    impl->eigenvalues = impl->T.diagonal();
  }
  impl->scale = impl->eigenvalues.size() > 0 ? impl->eigenvalues.cwiseAbs().maxCoeff() : 0.0;
  m_impl = std::move(impl);
}

Index SchurPencil::size() const { return m_impl->n; }
const ComplexVector& SchurPencil::eigenvalues() const { return m_impl->eigenvalues; }
bool SchurPencil::symmetric() const { return m_impl->symmetric; }
std::string SchurPencil::reduction() const {
  switch (m_impl->reduction) {
    case Impl::Reduction::Identity:
      return "identity";
    case Impl::Reduction::Cholesky:
      return "cholesky";
    case Impl::Reduction::Lu:
      return "lu";
  }
  return "?";
}

namespace {

[[noreturn]] void throw_singular(const SchurPencil::Impl& l, const SchurPencil::Impl& r,
                                 bool lyapunov, Complex li, Complex mj, double tol) {
  const Complex sum = li + std::conj(mj);
  std::string msg = l.origin + ": the equation is singular: ";
  if (lyapunov) {
    msg += "eigenvalues lambda_i = " + detail::number_text(li) +
           " and lambda_j = " + detail::number_text(mj) +
           " of A (of the pencil (A, E)) give lambda_i + conj(lambda_j) = " +
           detail::number_text(sum) +
           ", zero to working precision (|.| <= " + detail::number_text(tol) +
           "): A is not stable enough (a stable A, all Re lambda < 0, always gives a unique "
           "solution)";
  } else {
    msg += "eigenvalue lambda_i = " + detail::number_text(li) +
           " of the left pencil and mu_j = " + detail::number_text(mj) +
           " of the right pencil give lambda_i + conj(mu_j) = " + detail::number_text(sum) +
           ", zero to working precision (|.| <= " + detail::number_text(tol) +
           "): both must be stable enough (all Re < 0 gives a unique solution)";
  }
  (void)r;
  throw NumericalError(msg);
}

}  // namespace

namespace {

/// U^H M for the pencil's Schur vectors U (M real, n x k).
ComplexMatrix schur_adjoint_times(const SchurPencil::Impl& p, const Matrix& M) {
  if (p.symmetric) return (p.Ur.transpose() * M).cast<Complex>();
  return p.U.adjoint() * M.cast<Complex>();
}

/// Solves T1 Z + Z T2^H + C = 0 in place (Z holds C on entry), T1, T2 the pencils' triangular
/// (or diagonal) Schur factors.
void solve_triangular(const SchurPencil::Impl& l, const SchurPencil::Impl& r, ComplexMatrix& Z,
                      bool lyapunov, double tol) {
  const Index n = l.n, m = r.n;
  // Columns from the last: (T1 + conj(T2_jj) I) z_j = -c_j - sum_{k>j} conj(T2_jk) z_k.
  ComplexVector rhs(n);
  for (Index j = m - 1; j >= 0; --j) {
    rhs = -Z.col(j);
    const Index tail = m - 1 - j;
    if (!r.symmetric && tail > 0)
      rhs.noalias() -= Z.rightCols(tail) * r.T.row(j).tail(tail).adjoint();
    const Complex mj = r.symmetric ? Complex(r.d(j)) : r.T(j, j);
    const Complex cmj = std::conj(mj);
    // Back substitution, column oriented (T1 is column major).
    for (Index i = n - 1; i >= 0; --i) {
      const Complex li = l.symmetric ? Complex(l.d(i)) : l.T(i, i);
      const Complex den = li + cmj;
      if (!(std::abs(den) > tol)) throw_singular(l, r, lyapunov, li, mj, tol);
      const Complex zi = rhs(i) / den;
      rhs(i) = zi;
      if (!l.symmetric && i > 0) rhs.head(i).noalias() -= l.T.col(i).head(i) * zi;
    }
    Z.col(j) = rhs;
  }
}

double singular_tolerance(const SchurPencil::Impl& l, const SchurPencil::Impl& r) {
  return 100.0 * static_cast<double>(std::max(l.n, r.n)) * kEps *
         std::max({l.scale, r.scale, std::numeric_limits<double>::min()});
}

}  // namespace

Matrix solve_sylvester(const SchurPencil& left, const SchurPencil& right, const Matrix& Q) {
  const auto& l = left.impl();
  const auto& r = right.impl();
  const bool lyapunov = &l == &r;
  const Index n = l.n, m = r.n;
  check_matrix(Q, n, m, l.origin, "Q", "(rows: the left pencil's size, columns: the right one's)");
  const double tol = singular_tolerance(l, r);

  // Q~ = S1 Q S2' = S1 (S2 Q')'.
  const Matrix Qt = l.left(Matrix(r.left(Matrix(Q.transpose())).transpose()));
  Matrix Y;  // F1 Y + Y F2' + Q~ = 0
  if (l.symmetric && r.symmetric) {
    // Diagonal Schur forms: Z_ij = -C_ij / (d1_i + d2_j), real arithmetic throughout.
    Matrix C = l.Ur.transpose() * Qt * r.Ur;
    for (Index j = 0; j < m; ++j)
      for (Index i = 0; i < n; ++i) {
        const double den = l.d(i) + r.d(j);
        if (!(std::abs(den) > tol)) throw_singular(l, r, lyapunov, l.d(i), r.d(j), tol);
        C(i, j) = -C(i, j) / den;
      }
    Y = l.Ur * C * r.Ur.transpose();
  } else {
    // C = U1^H Q~ U2 = U1^H (U2^H Q~')^H.
    const ComplexMatrix W = schur_adjoint_times(r, Matrix(Qt.transpose())).adjoint();
    ComplexMatrix Z = l.symmetric ? ComplexMatrix(l.Ur.transpose().cast<Complex>() * W)
                                  : ComplexMatrix(l.U.adjoint() * W);
    solve_triangular(l, r, Z, lyapunov, tol);
    const ComplexMatrix U1Z =
        l.symmetric ? ComplexMatrix(l.Ur.cast<Complex>() * Z) : ComplexMatrix(l.U * Z);
    Y = r.symmetric ? Matrix((U1Z * r.Ur.transpose().cast<Complex>()).real())
                    : Matrix((U1Z * r.U.adjoint()).real());
  }
  // X = T1 Y T2' = T1 (T2 Y')'.
  Matrix X = l.back(Matrix(r.back(Matrix(Y.transpose())).transpose()));
  if (!X.allFinite())
    throw NumericalError(l.origin +
                         ": the solution has non-finite entries (the equation is "
                         "singular or badly scaled)");
  if (lyapunov) X = 0.5 * (X + X.transpose()).eval();
  return X;
}

double sylvester_trace(const SchurPencil& left, const SchurPencil& right, const Matrix& Bl,
                       const Matrix& Br, const Matrix& Cl, const Matrix& Cr) {
  const auto& l = left.impl();
  const auto& r = right.impl();
  check_matrix(Bl, l.n, -1, l.origin, "Bl", "(rows: the left pencil's size)");
  check_matrix(Br, r.n, Bl.cols(), l.origin, "Br", "(the right pencil's size x columns of Bl)");
  check_matrix(Cl, -1, l.n, l.origin, "Cl", "(columns: the left pencil's size)");
  check_matrix(Cr, Cl.rows(), r.n, l.origin, "Cr", "(rows of Cl x the right pencil's size)");
  // In Schur coordinates: C = (U1^H S1 Bl)(U2^H S2 Br)^H, and trace(Cl X Cr') with
  // X = T1 U1 Z U2^H T2' is trace(cl Z cr^H), cl = Cl T1 U1 = (U1^T T1' Cl')^T.
  const ComplexMatrix bl = schur_adjoint_times(l, l.left(Bl));
  const ComplexMatrix br = schur_adjoint_times(r, r.left(Br));
  ComplexMatrix Z = bl * br.adjoint();
  solve_triangular(l, r, Z, false, singular_tolerance(l, r));
  const ComplexMatrix cl =
      schur_adjoint_times(l, l.back_transposed(Matrix(Cl.transpose()))).adjoint();
  const ComplexMatrix cr =
      schur_adjoint_times(r, r.back_transposed(Matrix(Cr.transpose()))).adjoint();
  // cl here is (U1^H T1' Cl')^H = Cl T1 U1 (T1 real).
  const Complex t = (cl * Z).cwiseProduct(cr.conjugate()).sum();
  if (!std::isfinite(t.real()))
    throw NumericalError(l.origin +
                         ": the trace is not finite (the equation is singular or badly "
                         "scaled)");
  return t.real();
}

Matrix solve_lyapunov(const Matrix& A, const Matrix& Q) { return solve_lyapunov(A, Matrix(), Q); }

Matrix solve_lyapunov(const Matrix& A, const Matrix& E, const Matrix& Q) {
  constexpr std::string_view origin = "solve_lyapunov";
  check_square(A, origin, "A");
  check_matrix(Q, A.rows(), A.rows(), origin, "Q", "(the size of A)");
  const double qn = Q.norm();
  if ((Q - Q.transpose()).norm() > 1e-10 * qn)
    throw InputError(std::string(origin) + ": Q is not symmetric (relative asymmetry " +
                     detail::number_text((Q - Q.transpose()).norm() / qn) + " > 1e-10)");
  const SchurPencil pencil(A, E, origin);
  return solve_sylvester(pencil, pencil, Q);
}

Matrix solve_sylvester(const Matrix& A, const Matrix& B, const Matrix& Q) {
  return solve_sylvester(A, Matrix(), B, Matrix(), Q);
}

Matrix solve_sylvester(const Matrix& A, const Matrix& E, const Matrix& B, const Matrix& F,
                       const Matrix& Q) {
  constexpr std::string_view origin = "solve_sylvester";
  check_square(A, origin, "A");
  check_square(B, origin, "B");
  check_matrix(Q, A.rows(), B.rows(), origin, "Q", "(rows of A x rows of B)");
  const SchurPencil left(A, E, origin);
  SchurPencil right(B, F, origin);
  return solve_sylvester(left, right, Q);
}

double lyapunov_residual(const Matrix& A, const Matrix& E, const Matrix& X, const Matrix& Q) {
  constexpr std::string_view origin = "lyapunov_residual";
  const Index n = A.rows();
  if (A.cols() != n)
    throw InputError(std::string(origin) + ": A is " + dims(A) + ": must be square");
  if (E.size() > 0 && (E.rows() != n || E.cols() != n))
    throw InputError(std::string(origin) + ": E is " + dims(E) + ": must be " + std::to_string(n) +
                     " x " + std::to_string(n) + " (the size of A) or empty");
  if (X.rows() != n || X.cols() != n)
    throw InputError(std::string(origin) + ": X is " + dims(X) + ": must be " + std::to_string(n) +
                     " x " + std::to_string(n) + " (the size of A)");
  if (Q.rows() != n || Q.cols() != n)
    throw InputError(std::string(origin) + ": Q is " + dims(Q) + ": must be " + std::to_string(n) +
                     " x " + std::to_string(n) + " (the size of A)");
  Matrix R;
  if (E.size() == 0) {
    const Matrix AX = A * X;
    R = AX + X * A.transpose() + Q;
  } else {
    const Matrix AXE = A * X * E.transpose();
    R = AXE + E * X * A.transpose() + Q;
  }
  const double qn = Q.norm();
  return qn > 0.0 ? R.norm() / qn : R.norm();
}

namespace {

[[noreturn]] void throw_unstable(const ComplexVector& eig) {
  Index count = 0;
  double largest = -std::numeric_limits<double>::infinity();
  for (const Complex& z : eig) {
    if (!(z.real() < 0.0)) ++count;
    if (std::isnan(z.real()) || z.real() > largest) largest = z.real();
  }
  throw InputError("H2 norm / Gramians undefined: the model has " + std::to_string(count) +
                   " poles with Re >= 0 (largest real part " + detail::number_text(largest) +
                   "); an H2 norm and Gramians need an asymptotically stable model");
}

/// The finite eigenvalues of a pencil (A, E) with singular E of index 1, by deflation: with the
/// SVD E = U diag(s, 0) V', U' A V = [[A11, A12], [A21, A22]], they are the eigenvalues of
/// diag(s)^-1 (A11 - A12 A22^-1 A21) when A22 is nonsingular; nothing otherwise (index > 1).
/// Eigen's QZ does not converge on the shared peec model; this standard-QR route does.
std::optional<ComplexVector> index1_finite_eigenvalues(const Matrix& A, const Matrix& E) {
  const Index n = A.rows();
  const Eigen::BDCSVD<Matrix> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vector& s = svd.singularValues();
  Index r = 0;
  while (r < n && s(r) > static_cast<double>(n) * kEps * s(0)) ++r;
  const Matrix At = svd.matrixU().transpose() * A * svd.matrixV();
  if (r == n) return std::nullopt;
  const Index k = n - r;
  const Eigen::PartialPivLU<Matrix> lu(At.bottomRightCorner(k, k));
  if (!(safe_rcond(lu) > static_cast<double>(n) * kEps)) return std::nullopt;
  if (r == 0) return ComplexVector();
  const Matrix S = At.topLeftCorner(r, r) -
                   At.topRightCorner(r, k) * lu.solve(Matrix(At.bottomLeftCorner(k, r)));
  const Eigen::EigenSolver<Matrix> es(Matrix(s.head(r).cwiseInverse().asDiagonal() * S), false);
  if (es.info() != Eigen::Success) return std::nullopt;
  return ComplexVector(es.eigenvalues());
}

bool all_stable(const ComplexVector& eig) {
  for (const Complex& z : eig)
    if (!(z.real() < 0.0)) return false;
  return true;
}

}  // namespace

SchurPencil stable_pencil(const ReducedModel& model, std::string_view origin) {
  validate(model, origin);
  const ReducedDescriptorModel r = first_order_realization(model);
  std::optional<SchurPencil> pencil;
  try {
    pencil.emplace(r.A, r.E, origin);
  } catch (const InputError&) {
    // A singular E: say first whether the finite poles are stable (an unstable model is the more
    // fundamental problem), then refuse the descriptor model.
    if (const std::optional<ComplexVector> finite = index1_finite_eigenvalues(r.A, r.E)) {
      if (!all_stable(*finite)) throw_unstable(*finite);
    } else {
      // Higher index (e.g. peec): QZ on the pencil, with a larger iteration budget than
      // ecmor::poles uses (Eigen's default does not converge on peec; 1000 n does, in ~9000
      // sweeps), infinite eigenvalues dropped as poles() drops them (|beta| <= n eps ||E||_F).
      // If QZ fails even so, stability stays undecided and the singular E is reported.
      bool decided = false;
      ComplexVector p;
      detail::QzSolver qz;
      qz.setMaxIterations(1000 * r.A.rows());
      qz.compute(r.A, r.E, false);
      if (qz.converged()) {
        decided = true;
        const double tol = static_cast<double>(r.A.rows()) * kEps * r.E.norm();
        std::vector<Complex> kept;
        for (Index i = 0; i < qz.betas().size(); ++i)
          if (std::abs(qz.betas()(i)) > tol) kept.push_back(qz.alphas()(i) / qz.betas()(i));
        p = Eigen::Map<const ComplexVector>(kept.data(), static_cast<Index>(kept.size()));
      }
      if (decided && !all_stable(p)) throw_unstable(p);
    }
    throw;
  }
  if (!all_stable(pencil->eigenvalues())) throw_unstable(pencil->eigenvalues());
  return *pencil;
}

Matrix controllability_gramian(const ReducedModel& model) {
  const SchurPencil pencil = stable_pencil(model, "gramians");
  const ReducedDescriptorModel r = first_order_realization(model);
  return solve_sylvester(pencil, pencil, Matrix(r.B * r.B.transpose()));
}

Gramians gramians(const ReducedModel& model) {
  const SchurPencil pencil = stable_pencil(model, "gramians");
  const ReducedDescriptorModel r = first_order_realization(model);
  Gramians g;
  g.P = solve_sylvester(pencil, pencil, Matrix(r.B * r.B.transpose()));
  // A' Q E + E' Q A + C'C = 0 is the Lyapunov equation of the transposed pencil (A', E'); a
  // symmetric pencil is its own transpose.
  const Matrix CtC = r.C.transpose() * r.C;
  if (pencil.symmetric()) {
    g.Q = solve_sylvester(pencil, pencil, CtC);
  } else {
    const SchurPencil transposed(Matrix(r.A.transpose()), Matrix(r.E.transpose()), "gramians");
    g.Q = solve_sylvester(transposed, transposed, CtC);
  }
  return g;
}

}  // namespace ecmor
