// adi_shifts.cpp: the shift sets of the low-rank ADI iteration (adi_shifts.hpp).
#include "gramians/adi_shifts.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "base/number_text.hpp"
#include "ecmor/base/error.hpp"
#include "linalg/qz_solver.hpp"

namespace ecmor::detail {

namespace {

/// Arnoldi on op with `steps` steps from the normalised start vector; Ritz pairs of op.
template <class Op>
std::vector<RitzPair> arnoldi(const Op& op, Index n, Index steps, const char* what) {
  steps = std::min(steps, n);
  Matrix V = Matrix::Zero(n, steps + 1);
  Matrix H = Matrix::Zero(steps + 1, steps);
  V.col(0) = Vector::Ones(n) / std::sqrt(static_cast<double>(n));
  Index k = 0;
  for (; k < steps; ++k) {
    Vector w = op(Matrix(V.col(k)));
    if (!w.allFinite())
      throw NumericalError(std::string("low-rank ADI heuristic shifts: Arnoldi on ") + what +
                           " produced a non-finite vector at step " + std::to_string(k + 1));
    // Classical Gram-Schmidt twice: orthogonal to working precision.
    for (int pass = 0; pass < 2; ++pass) {
      const Vector h = V.leftCols(k + 1).transpose() * w;
      w -= V.leftCols(k + 1) * h;
      H.col(k).head(k + 1) += h;
    }
    const double beta = w.norm();
    H(k + 1, k) = beta;
    if (beta <= 1e-14 * H.col(k).norm()) {  // invariant subspace found
      ++k;
      break;
    }
    V.col(k + 1) = w / beta;
  }
  std::vector<RitzPair> out;
  if (k == 0) return out;
  Eigen::EigenSolver<Matrix> es(H.topLeftCorner(k, k), true);
  if (es.info() != Eigen::Success) return out;
  for (Index i = 0; i < k; ++i)
    out.push_back({es.eigenvalues()(i), V.leftCols(k).cast<Complex>() * es.eigenvectors().col(i)});
  return out;
}

}  // namespace

Matrix range_basis(const Matrix& X) {
  if (X.cols() == 0) return Matrix(X.rows(), 0);
  const auto [lambda, V] = gram_eigen(X);
  const double cut =
      static_cast<double>(X.cols()) * std::numeric_limits<double>::epsilon() * lambda(0);
  Index r = 0;
  while (r < lambda.size() && lambda(r) > cut) ++r;
  return X * (V.leftCols(r) * lambda.head(r).cwiseSqrt().cwiseInverse().asDiagonal());
}

std::vector<Complex> select_minmax(const std::vector<Complex>& candidates, Index max_count) {
  std::vector<Complex> all;  // with conjugates, to evaluate the contraction on the whole set
  for (const Complex& c : candidates) {
    all.push_back(c);
    if (c.imag() != 0.0) all.push_back(std::conj(c));
  }
  auto contraction = [](Complex p, Complex x) {
    // |(p - x) / (p + x)| for the pair (p, conj p): the product over both members.
    double v = std::abs((p - x) / (p + x));
    if (p.imag() != 0.0) v *= std::abs((std::conj(p) - x) / (std::conj(p) + x));
    return v;
  };
  std::vector<Complex> chosen;
  std::vector<bool> used(candidates.size(), false);
  Index count = 0;
  if (candidates.empty()) return chosen;
  // First shift: minimise the worst contraction over the whole set.
  std::size_t best = 0;
  double best_value = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    double worst = 0.0;
    for (const Complex& x : all) worst = std::max(worst, contraction(candidates[i], x));
    if (worst < best_value) {
      best_value = worst;
      best = i;
    }
  }
  chosen.push_back(candidates[best]);
  used[best] = true;
  count += candidates[best].imag() != 0.0 ? 2 : 1;
  while (count < max_count) {
    std::optional<std::size_t> next;
    double largest = -1.0;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      if (used[i]) continue;
      double product = 1.0;
      for (const Complex& p : chosen) product *= contraction(p, candidates[i]);
      if (product > largest) {
        largest = product;
        next = i;
      }
    }
    if (!next) break;
    chosen.push_back(candidates[*next]);
    used[*next] = true;
    count += candidates[*next].imag() != 0.0 ? 2 : 1;
  }
  return chosen;
}

AdiShiftSource::AdiShiftSource(FirstOrderView& view, const AdiRealOps& ops,
                               const AdiOptions& options)
    : m_view(view), m_ops(ops), m_options(options) {}

double AdiShiftSource::ritz_residual(const RitzPair& r, bool transposed) const {
  const Matrix ur = r.vector.real(), ui = r.vector.imag();
  Matrix U(ur.rows(), 2);
  U.col(0) = ur;
  U.col(1) = ui;
  const Matrix AU = m_ops.apply_a(U, transposed), EU = m_ops.apply_e(U, transposed);
  const ComplexVector Au = AU.col(0).cast<Complex>() + Complex(0, 1) * AU.col(1).cast<Complex>();
  const ComplexVector Eu = EU.col(0).cast<Complex>() + Complex(0, 1) * EU.col(1).cast<Complex>();
  const double denom = Au.norm() + std::abs(r.value) * Eu.norm();
  return denom > 0.0 ? (Au - r.value * Eu).norm() / denom : 1.0;
}

std::vector<Complex> AdiShiftSource::admissible(const std::vector<RitzPair>& ritz, bool transposed,
                                                const char* where, AdiResult& result) const {
  std::vector<Complex> out;
  for (const RitzPair& r : ritz) {
    Complex theta = r.value;
    if (!std::isfinite(theta.real()) || !std::isfinite(theta.imag()) || theta == Complex(0.0))
      continue;                        // infinite (singular projected E) or zero: no usable shift
    if (theta.imag() < 0.0) continue;  // the conjugate partner carries the pair
    if (theta.real() >= 0.0) {
      const double rho = r.vector.size() > 0 ? ritz_residual(r, transposed) : 1.0;
      // The pair is an exact eigenpair of a pencil within relative distance rho; for a
      // normal pencil the eigenvalue is then within about 2 rho |theta| of theta, so an
      // unstable eigenvalue is certain when Re theta exceeds that.
      if (rho <= m_options.unstable_ritz_residual && theta.real() > 2.0 * rho * std::abs(theta)) {
        throw InputError("low-rank ADI (" + to_string(result.side) +
                         "): the model is not asymptotically stable: the pencil (A, E) has the "
                         "eigenvalue " +
                         number_text(theta) + " with Re >= 0 (" + where +
                         " Ritz value, relative residual " + number_text(rho) +
                         "); the Gramians do not exist");
      }
      ++result.mirrored_ritz_values;
      theta = Complex(-theta.real(), theta.imag());
      if (theta.real() == 0.0) continue;  // on the imaginary axis: cannot be mirrored
    }
    // Real arithmetic rounding leaves tiny imaginary parts on real Ritz values of symmetric
    // problems solved by QZ; a pair that close to the real axis is treated as real.
    if (std::abs(theta.imag()) <= 1e-12 * std::abs(theta)) theta = Complex(theta.real(), 0.0);
    out.push_back(theta);
  }
  return out;
}

std::vector<RitzPair> AdiShiftSource::projected_ritz(const Matrix& X, bool transposed) const {
  const Matrix U = range_basis(X);
  std::vector<RitzPair> out;
  if (U.cols() == 0) return out;
  const Matrix Ar = U.transpose() * m_ops.apply_a(U, transposed);
  const Matrix Er = U.transpose() * m_ops.apply_e(U, transposed);
  const double asym_a = (Ar - Ar.transpose()).norm(), asym_e = (Er - Er.transpose()).norm();
  if (asym_a <= 1e-12 * Ar.norm() && asym_e <= 1e-12 * Er.norm()) {
    // Symmetric A, SPD E (rail): real Ritz values from the symmetric-definite solver.
    const Matrix As = (Ar + Ar.transpose()) / 2, Es = (Er + Er.transpose()) / 2;
    Eigen::LLT<Matrix> llt(Es);
    if (llt.info() == Eigen::Success) {
      Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> ges(As, Es);
      if (ges.info() == Eigen::Success) {
        // The Ritz vector is only needed to judge a Ritz value with Re >= 0 (admissible()).
        for (Index i = 0; i < U.cols(); ++i) {
          const double theta = ges.eigenvalues()(i);
          ComplexVector u;
          if (theta >= 0.0) u = (U * ges.eigenvectors().col(i)).cast<Complex>();
          out.push_back({Complex(theta, 0.0), std::move(u)});
        }
        return out;
      }
    }
  }
  detail::QzSolver qz(Ar, Er, true);
  if (!qz.converged()) return out;
  for (Index i = 0; i < U.cols(); ++i) {
    const Complex alpha = qz.alphas()(i);
    const double beta = qz.betas()(i);
    if (beta == 0.0) continue;
    // The Ritz vector (an N-vector) only where admissible() needs it, Re theta >= 0: forming
    // it for every Ritz value was O(N k^2) complex work per shift set, a third of the ADI time
    // on the triple chain.
    const Complex theta = alpha / beta;
    ComplexVector u;
    if (theta.real() >= 0.0) {
      const ComplexVector y = qz.eigenvectors().col(i);
      u = (U * y.real()).cast<Complex>() + Complex(0.0, 1.0) * (U * y.imag()).cast<Complex>();
    }
    out.push_back({theta, std::move(u)});
  }
  return out;
}

std::vector<Complex> AdiShiftSource::heuristic(const Factorization& e, AdiResult& result) {
  if (m_heuristic) return *m_heuristic;
  // The spectra of (A, E) and (A', E') agree, so one set serves both sides; Arnoldi is run on
  // the non-transposed pencil.
  auto op_plus = [&](const Matrix& x) -> Vector {
    return m_ops.solve_e(e, m_ops.apply_a(x, false), false).col(0);
  };
  std::shared_ptr<const Factorization> p0;
  try {
    p0 = m_view.solver().factorize(Complex(0.0));
  } catch (const NumericalError& err) {
    throw NumericalError(std::string("low-rank ADI heuristic shifts: A is singular (") +
                         err.what() +
                         "): Arnoldi on A^-1 E is impossible; use projection "
                         "shifts");
  }
  auto op_minus = [&](const Matrix& x) -> Vector {
    // A^-1 = -(0 E - A)^-1.
    return (-m_ops.solve(*p0, 0.0, m_ops.apply_e(x, false), false)).col(0);
  };
  std::vector<RitzPair> ritz =
      arnoldi(op_plus, m_ops.state_size(), m_options.arnoldi_steps, "E^-1 A");
  for (RitzPair& r :
       arnoldi(op_minus, m_ops.state_size(), m_options.inverse_arnoldi_steps, "A^-1 E")) {
    if (r.value == Complex(0.0)) continue;
    r.value = 1.0 / r.value;
    ritz.push_back(std::move(r));
  }
  const std::vector<Complex> candidates = admissible(ritz, false, "heuristic (Arnoldi)", result);
  m_heuristic = select_minmax(candidates, m_options.max_shifts);
  return *m_heuristic;
}

std::vector<Complex> AdiShiftSource::projection(const Matrix& X, bool transposed,
                                                AdiResult& result) const {
  const std::vector<RitzPair> ritz = projected_ritz(X, transposed);
  return select_minmax(admissible(ritz, transposed, "projection", result), m_options.max_shifts);
}

}  // namespace ecmor::detail
