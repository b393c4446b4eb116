// eigensolver.cpp: ARPACK-ng shift-invert drivers (reverse communication) and dense fallbacks.
#include "ecmor/linalg/eigensolver.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <mutex>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "linalg/petsc_solver.hpp"
#include "linalg/qz_solver.hpp"

// The ISO_C_BINDING entry points of ARPACK-ng (arpack/arpack.h) take scalars by value and no
// hidden Fortran string lengths, which removes the gfortran calling-convention guesswork.
#include <arpack/arpack.h>

namespace ecmor {
namespace {

// ARPACK's routines keep SAVEd Fortran state between reverse-communication calls: two runs
// interleaved in different threads would corrupt each other. One run at a time.
std::mutex g_arpack_mutex;

// The codes the four ARPACK routines (dsaupd, dseupd, dnaupd, dneupd) share, with their
// meaning in all of them; the routine-specific ones are in each routine's table below.
std::string arpack_common_info(int info) {
  switch (info) {
    case -1:
      return "N must be positive";
    case -2:
      return "nev must be positive";
    case -4:
      return "the maximum number of restarts must be positive";
    case -5:
      return "invalid 'which'";
    case -6:
      return "invalid 'bmat'";
    case -7:
      return "workl too short";
    case -9:
      return "the starting vector is zero";
    case -10:
      return "invalid mode iparam(7)";
    case -11:
      return "mode 1 with bmat = 'G' is incompatible";
    case -12:
      return "iparam(1) must be 0 or 1";
    default:
      return fmt::format("unknown ARPACK error (info = {})", info);
  }
}

// The codes the two iteration routines (dsaupd, dnaupd) share beyond arpack_common_info.
std::string aupd_common_info(int info, const int* iparam) {
  switch (info) {
    case 1:
      return fmt::format("maximum number of restarts reached: {} converged", iparam[4]);
    case 3:
      return "no shifts could be applied during an implicit restart (increase ncv)";
    default:
      return arpack_common_info(info);
  }
}

std::string saupd_info(int info, const int* iparam) {
  switch (info) {
    case -3:
      return "ncv must satisfy nev < ncv <= N";
    case -8:
      return "the tridiagonal eigenvalue computation (LAPACK dsteqr) failed";
    case -13:
      return "nev and which = 'BE' are incompatible";
    case -9999:
      return fmt::format(
          "could not build a Lanczos factorization (size {} reached): the operator may not be "
          "symmetric in the M inner product (M indefinite or K, M unsymmetric?)",
          iparam[4]);
    default:
      return aupd_common_info(info, iparam);
  }
}

std::string seupd_info(int info) {
  switch (info) {
    case -3:
      return "ncv must satisfy nev < ncv <= N";
    case -8:
      return "the tridiagonal eigenvalue computation (LAPACK dsteqr) failed";
    case -14:
      return "dsaupd found no eigenvalue to sufficient accuracy";
    case -15:
      return "howmny must be 'A' or 'S'";
    case -16:
      return "howmny = 'S' is not implemented";
    case -17:
      return "dseupd counted a different number of converged Ritz values than dsaupd (the "
             "operator is probably not symmetric in the M inner product)";
    default:
      return arpack_common_info(info);
  }
}

std::string naupd_info(int info, const int* iparam) {
  switch (info) {
    case -3:
      return "ncv must satisfy nev + 2 <= ncv <= N";
    case -8:
      return "the Hessenberg eigenvalue computation (LAPACK dlahqr) failed";
    case -9999:
      return fmt::format("could not build an Arnoldi factorization (size {} reached)", iparam[4]);
    default:
      return aupd_common_info(info, iparam);
  }
}

std::string neupd_info(int info) {
  switch (info) {
    case -3:
      return "ncv must satisfy nev + 2 <= ncv <= N";
    case -8:
      return "the Schur form computation (LAPACK dlahqr) failed";
    case -9:
      return "the eigenvector computation (LAPACK dtrevc) failed";
    case -13:
      return "howmny must be 'A' or 'P' when eigenvectors are asked for";
    case -14:
      return "dnaupd found no eigenvalue to sufficient accuracy";
    case -15:
      return "dneupd counted a different number of converged Ritz values than dnaupd";
    default:
      return arpack_common_info(info);
  }
}

Index default_ncv(Index n, Index nev) { return std::min(n, std::max<Index>(2 * nev + 1, 20)); }

void check_operands(const char* function, const Factorization& factorization, const SparseMatrix& B,
                    const char* b_name) {
  if (B.rows() != B.cols()) {
    throw InputError(
        fmt::format("{}: {} is {} x {}: must be square", function, b_name, B.rows(), B.cols()));
  }
  if (factorization.size() != B.rows()) {
    throw InputError(fmt::format(
        "{}: the factorisation is {} x {} but {} is {} x {}: sizes must "
        "agree",
        function, factorization.size(), factorization.size(), b_name, B.rows(), B.cols()));
  }
  if (factorization.is_complex()) {
    throw InputError(
        fmt::format("{}: the factorisation ({}) is complex: shift-invert needs a "
                    "real shift",
                    function, factorization.method()));
  }
}

// A start vector: ARPACK's own (info = 0) or a seeded uniform one (info = 1).
int start_vector(std::uint64_t seed, Vector& resid) {
  if (seed == 0) {
    resid.setZero();
    return 0;
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (Index i = 0; i < resid.size(); ++i) resid[i] = uniform(rng);
  return 1;
}

// --- dense fallbacks -------------------------------------------------------------------------

// OP = F^-1 M is M-self-adjoint; with M = L L' the matrix L' F^-1 L is symmetric and has the same
// eigenvalues nu = 1/(lambda - sigma); eigenvectors phi = L^-T y are M-orthonormal when y is
// orthonormal. This is the exact dense analogue of ARPACK's mode 3.
SymmetricEigenResult dense_symmetric(const Factorization& factorization, const SparseMatrix& M,
                                     double sigma, Index nev) {
  const Index n = M.rows();
  const Matrix Md = Matrix(M);
  Eigen::LLT<Matrix> llt(0.5 * (Md + Md.transpose()));
  if (llt.info() != Eigen::Success) {
    throw InputError("symmetric_shift_invert: M is not positive definite (dense Cholesky failed)");
  }
  const Matrix L = llt.matrixL();
  Matrix inv = factorization.solve(Matrix(Matrix::Identity(n, n)));
  inv = 0.5 * (inv + inv.transpose());  // symmetric in exact arithmetic
  const Matrix S = L.transpose() * inv * L;
  Eigen::SelfAdjointEigenSolver<Matrix> es(S);
  if (es.info() != Eigen::Success) {
    throw NumericalError("symmetric_shift_invert: the dense symmetric eigensolver failed");
  }
  // The nev largest |nu| are the eigenvalues nearest sigma.
  std::vector<Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Index{0});
  const Vector& nu = es.eigenvalues();
  std::stable_sort(order.begin(), order.end(),
                   [&](Index a, Index b) { return std::abs(nu[a]) > std::abs(nu[b]); });
  std::vector<std::pair<double, Index>> picked;
  for (Index k = 0; k < nev; ++k) {
    const Index j = order[static_cast<std::size_t>(k)];
    if (nu[j] == 0.0) break;  // cannot happen for a non-singular factorisation
    picked.emplace_back(sigma + 1.0 / nu[j], j);
  }
  std::sort(picked.begin(), picked.end());
  SymmetricEigenResult result;
  result.eigenvalues.resize(static_cast<Index>(picked.size()));
  result.eigenvectors.resize(n, static_cast<Index>(picked.size()));
  const auto Lt = L.transpose().triangularView<Eigen::Upper>();
  for (std::size_t k = 0; k < picked.size(); ++k) {
    const auto kk = static_cast<Index>(k);
    result.eigenvalues[kk] = picked[k].first;
    result.eigenvectors.col(kk) = Lt.solve(es.eigenvectors().col(picked[k].second));
  }
  result.operator_applications = n;
  result.dense_fallback = true;
  result.method = "dense";
  return result;
}

// Sorts eigenpairs by |lambda - sigma| (pairs stay adjacent since they have equal distance) and
// keeps nev of them without splitting a conjugate pair.
GeneralEigenResult finish_general(std::vector<Complex>& lambda, ComplexMatrix& X, double sigma,
                                  Index nev) {
  const auto count = static_cast<Index>(lambda.size());
  std::vector<Index> order(static_cast<std::size_t>(count));
  std::iota(order.begin(), order.end(), Index{0});
  std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) {
    const double da = std::abs(lambda[static_cast<std::size_t>(a)] - sigma);
    const double db = std::abs(lambda[static_cast<std::size_t>(b)] - sigma);
    if (da != db) return da < db;
    // Conjugates: positive imaginary part first.
    return lambda[static_cast<std::size_t>(a)].imag() > lambda[static_cast<std::size_t>(b)].imag();
  });
  Index keep = std::min(nev, count);
  if (keep < count && keep > 0) {
    const Complex last =
        lambda[static_cast<std::size_t>(order[static_cast<std::size_t>(keep - 1)])];
    const Complex next = lambda[static_cast<std::size_t>(order[static_cast<std::size_t>(keep)])];
    if (last.imag() != 0.0 && std::abs(next - std::conj(last)) <= 1e-12 * std::abs(last)) ++keep;
  }
  GeneralEigenResult result;
  result.eigenvalues.resize(keep);
  result.eigenvectors.resize(X.rows(), keep);
  for (Index k = 0; k < keep; ++k) {
    const Index j = order[static_cast<std::size_t>(k)];
    result.eigenvalues[k] = lambda[static_cast<std::size_t>(j)];
    const double norm = X.col(j).norm();
    result.eigenvectors.col(k) =
        norm > 0.0 ? ComplexVector(X.col(j) / norm) : ComplexVector(X.col(j));
  }
  return result;
}

// Relative size of nu below which an eigenvalue of OP counts as zero, i.e. lambda as infinite.
constexpr double kInfiniteNuTol = 1e-12;

GeneralEigenResult dense_general(const Factorization& factorization, const SparseMatrix& E,
                                 double sigma, Index nev, bool left) {
  const Index n = E.rows();
  const Matrix Ed = Matrix(E);
  const Matrix op =
      left ? factorization.solve_transposed(Matrix(Ed.transpose())) : factorization.solve(Ed);
  Eigen::EigenSolver<Matrix> es(op, true);
  if (es.info() != Eigen::Success) {
    throw NumericalError("general_shift_invert: the dense nonsymmetric eigensolver failed");
  }
  const ComplexVector nu = es.eigenvalues();
  const double nu_max = nu.cwiseAbs().maxCoeff();
  std::vector<Complex> lambda;
  std::vector<Index> cols;
  for (Index j = 0; j < n; ++j) {
    if (std::abs(nu[j]) <= kInfiniteNuTol * nu_max) continue;  // infinite eigenvalue
    lambda.push_back(sigma + 1.0 / nu[j]);
    cols.push_back(j);
  }
  const ComplexMatrix all = es.eigenvectors();
  ComplexMatrix X(n, static_cast<Index>(cols.size()));
  for (std::size_t k = 0; k < cols.size(); ++k) X.col(static_cast<Index>(k)) = all.col(cols[k]);
  GeneralEigenResult result = finish_general(lambda, X, sigma, nev);
  result.operator_applications = n;
  result.dense_fallback = true;
  return result;
}

}  // namespace

void EigenOptions::validate(Index n) const {
  if (nev < 1) throw ConfigError(fmt::format("EigenOptions::nev = {}: must be >= 1", nev));
  if (nev >= n) {
    throw ConfigError(fmt::format("EigenOptions::nev = {}: must be < N = {}", nev, n));
  }
  if (ncv != 0 && (ncv <= nev || ncv > n)) {
    throw ConfigError(
        fmt::format("EigenOptions::ncv = {}: must be 0 (automatic) or in (nev, N] "
                    "= ({}, {}]",
                    ncv, nev, n));
  }
  if (!(tolerance >= 0.0) || !std::isfinite(tolerance)) {
    throw ConfigError(
        fmt::format("EigenOptions::tolerance = {}: must be finite and >= 0", tolerance));
  }
  if (max_iterations < 1) {
    throw ConfigError(
        fmt::format("EigenOptions::max_iterations = {}: must be >= 1", max_iterations));
  }
}

SymmetricEigenResult symmetric_shift_invert(const Factorization& factorization,
                                            const SparseMatrix& M, double sigma,
                                            const EigenOptions& options) {
  check_operands("symmetric_shift_invert", factorization, M, "M");
  const Index n = M.rows();
  options.validate(n);
  if (n <= kDenseEigenThreshold || options.nev >= n - 1) {
    return dense_symmetric(factorization, M, sigma, options.nev);
  }
  // A distributed factorisation: SLEPc works on the distributed vectors (and its own start
  // vector), through the same factorisation.
  if (detail::petsc_has_eigensolver(factorization))
    return detail::petsc_symmetric_eigs(factorization, M, sigma, options);

  const int N = static_cast<int>(n);
  const int nev = static_cast<int>(options.nev);
  const int ncv = static_cast<int>(options.ncv > 0 ? options.ncv : default_ncv(n, options.nev));
  const int lworkl = ncv * (ncv + 8);
  Vector resid(n);
  Matrix V(n, ncv);
  std::vector<double> workd(static_cast<std::size_t>(3 * n));
  std::vector<double> workl(static_cast<std::size_t>(lworkl));
  int iparam[11] = {0};
  int ipntr[11] = {0};
  iparam[0] = 1;  // exact shifts
  iparam[2] = static_cast<int>(options.max_iterations);
  iparam[6] = 3;  // shift-invert mode
  int info = start_vector(options.seed, resid);
  int ido = 0;
  SymmetricEigenResult result;

  const std::string where =
      fmt::format("ARPACK dsaupd (sigma = {:g}, nev = {}, ncv = {})", sigma, nev, ncv);
  std::lock_guard<std::mutex> lock(g_arpack_mutex);
  Matrix x(n, 1);
  for (;;) {
    dsaupd_c(&ido, "G", N, "LM", nev, options.tolerance, resid.data(), ncv, V.data(), N, iparam,
             ipntr, workd.data(), workl.data(), lworkl, &info);
    if (ido == 99) break;
    check_interrupt(where);  // the run's time limit or a signal, between operator applications
    Eigen::Map<Vector> in(workd.data() + ipntr[0] - 1, n);
    Eigen::Map<Vector> out(workd.data() + ipntr[1] - 1, n);
    if (ido == -1) {
      // First application: y = (K - sigma M)^-1 M x.
      x.col(0) = M * in;
      out = factorization.solve(x).col(0);
      ++result.operator_applications;
    } else if (ido == 1) {
      // M x is already in workd(ipntr(3)).
      x.col(0) = Eigen::Map<Vector>(workd.data() + ipntr[2] - 1, n);
      out = factorization.solve(x).col(0);
      ++result.operator_applications;
    } else if (ido == 2) {
      out = M * in;
    } else {
      throw NumericalError(
          fmt::format("symmetric_shift_invert: dsaupd asked for ido = {}, which "
                      "mode 3 never requests",
                      ido));
    }
  }
  result.iterations = iparam[2];
  if (info < 0 || info == 3) {
    throw NumericalError(
        fmt::format("symmetric_shift_invert (sigma = {:g}, nev = {}, ncv = {}): "
                    "ARPACK dsaupd info = {}: {}",
                    sigma, nev, ncv, info, saupd_info(info, iparam)));
  }
  const int converged_aupd = iparam[4];
  if (info == 1 || converged_aupd < nev) {
    throw NumericalError(fmt::format(
        "symmetric_shift_invert (sigma = {:g}, nev = {}, ncv = {}): ARPACK dsaupd info = {}: "
        "maximum number of restarts reached: {} of {} eigenpairs converged after {} restarts "
        "(increase max_iterations or ncv)",
        sigma, nev, ncv, info, converged_aupd, nev, iparam[2]));
  }

  std::vector<int> select(static_cast<std::size_t>(ncv), 0);
  Vector d(nev);
  Matrix Z(n, nev);
  dseupd_c(1, "A", select.data(), d.data(), Z.data(), N, sigma, "G", N, "LM", nev,
           options.tolerance, resid.data(), ncv, V.data(), N, iparam, ipntr, workd.data(),
           workl.data(), lworkl, &info);
  if (info != 0) {
    throw NumericalError(
        fmt::format("symmetric_shift_invert (sigma = {:g}, nev = {}): ARPACK "
                    "dseupd info = {}: {}",
                    sigma, nev, info, seupd_info(info)));
  }
  const int nconv = std::min(iparam[4], nev);
  std::vector<Index> order(static_cast<std::size_t>(nconv));
  std::iota(order.begin(), order.end(), Index{0});
  std::sort(order.begin(), order.end(), [&](Index a, Index b) { return d[a] < d[b]; });
  result.eigenvalues.resize(nconv);
  result.eigenvectors.resize(n, nconv);
  for (int k = 0; k < nconv; ++k) {
    result.eigenvalues[k] = d[order[static_cast<std::size_t>(k)]];
    result.eigenvectors.col(k) = Z.col(order[static_cast<std::size_t>(k)]);
  }
  return result;
}

GeneralEigenResult general_shift_invert(const Factorization& factorization, const SparseMatrix& E,
                                        double sigma, const EigenOptions& options, bool left) {
  check_operands("general_shift_invert", factorization, E, "E");
  const Index n = E.rows();
  options.validate(n);
  // dnaupd needs ncv >= nev + 2 <= N.
  if (n <= kDenseEigenThreshold || options.nev >= n - 2) {
    return dense_general(factorization, E, sigma, options.nev, left);
  }
  const int N = static_cast<int>(n);
  const int nev = static_cast<int>(options.nev);
  int ncv = static_cast<int>(options.ncv > 0 ? options.ncv : default_ncv(n, options.nev));
  if (ncv < nev + 2) ncv = nev + 2;  // the symmetric rule nev < ncv is one short for dnaupd
  const int lworkl = 3 * ncv * ncv + 6 * ncv;
  Vector resid(n);
  Matrix V(n, ncv);
  std::vector<double> workd(static_cast<std::size_t>(3 * n));
  std::vector<double> workl(static_cast<std::size_t>(lworkl));
  int iparam[14] = {0};
  int ipntr[14] = {0};
  iparam[0] = 1;
  iparam[2] = static_cast<int>(options.max_iterations);
  iparam[6] = 1;  // regular mode on the already inverted operator
  int info = start_vector(options.seed, resid);
  int ido = 0;
  GeneralEigenResult result;
  const SparseMatrix Et = left ? SparseMatrix(E.transpose()) : SparseMatrix();

  const std::string where = fmt::format("ARPACK dnaupd (sigma = {:g}, nev = {}, ncv = {}{})", sigma,
                                        nev, ncv, left ? ", left eigenvectors" : "");
  std::lock_guard<std::mutex> lock(g_arpack_mutex);
  Matrix x(n, 1);
  for (;;) {
    dnaupd_c(&ido, "I", N, "LM", nev, options.tolerance, resid.data(), ncv, V.data(), N, iparam,
             ipntr, workd.data(), workl.data(), lworkl, &info);
    if (ido == 99) break;
    check_interrupt(where);
    if (ido != -1 && ido != 1) {
      throw NumericalError(
          fmt::format("general_shift_invert: dnaupd asked for ido = {}, which "
                      "mode 1 never requests",
                      ido));
    }
    Eigen::Map<Vector> in(workd.data() + ipntr[0] - 1, n);
    Eigen::Map<Vector> out(workd.data() + ipntr[1] - 1, n);
    if (left) {
      x.col(0) = Et * in;
      out = factorization.solve_transposed(x).col(0);
    } else {
      x.col(0) = E * in;
      out = factorization.solve(x).col(0);
    }
    ++result.operator_applications;
  }
  result.iterations = iparam[2];
  if (info < 0 || info == 3) {
    throw NumericalError(
        fmt::format("general_shift_invert (sigma = {:g}, nev = {}, ncv = {}): "
                    "ARPACK dnaupd info = {}: {}",
                    sigma, nev, ncv, info, naupd_info(info, iparam)));
  }
  if (info == 1 || iparam[4] < nev) {
    throw NumericalError(fmt::format(
        "general_shift_invert (sigma = {:g}, nev = {}, ncv = {}): ARPACK dnaupd info = {}: "
        "maximum number of restarts reached: {} of {} eigenpairs converged after {} restarts "
        "(increase max_iterations or ncv)",
        sigma, nev, ncv, info, iparam[4], nev, iparam[2]));
  }

  std::vector<int> select(static_cast<std::size_t>(ncv), 0);
  Vector dr = Vector::Zero(nev + 1);
  Vector di = Vector::Zero(nev + 1);
  Matrix Z = Matrix::Zero(n, nev + 1);
  std::vector<double> workev(static_cast<std::size_t>(3 * ncv));
  dneupd_c(1, "A", select.data(), dr.data(), di.data(), Z.data(), N, 0.0, 0.0, workev.data(), "I",
           N, "LM", nev, options.tolerance, resid.data(), ncv, V.data(), N, iparam, ipntr,
           workd.data(), workl.data(), lworkl, &info);
  if (info != 0) {
    throw NumericalError(
        fmt::format("general_shift_invert (sigma = {:g}, nev = {}): ARPACK "
                    "dneupd info = {}: {}",
                    sigma, nev, info, neupd_info(info)));
  }
  const int nconv = std::min(iparam[4], nev + 1);
  // dneupd's real storage: a real Ritz value has its vector in one column; a pair nu, conj(nu)
  // (di > 0 first) has Re in column j and Im in column j + 1.
  std::vector<Complex> lambda;
  std::vector<ComplexVector> vectors;
  const double nu_max =
      std::sqrt((dr.head(nconv).array().square() + di.head(nconv).array().square()).maxCoeff());
  for (int j = 0; j < nconv; ++j) {
    const Complex nu(dr[j], di[j]);
    const bool infinite = std::abs(nu) <= kInfiniteNuTol * nu_max;
    if (di[j] == 0.0) {
      if (!infinite) {
        lambda.push_back(sigma + 1.0 / nu);
        vectors.emplace_back(Z.col(j).cast<Complex>());
      }
      continue;
    }
    if (j + 1 >= nconv) break;  // half a pair at the end: its partner was not delivered
    const ComplexVector z =
        Z.col(j).cast<Complex>() + Complex(0.0, 1.0) * Z.col(j + 1).cast<Complex>();
    if (!infinite) {
      lambda.push_back(sigma + 1.0 / nu);
      vectors.push_back(z);
      lambda.push_back(sigma + 1.0 / std::conj(nu));
      vectors.push_back(z.conjugate());
    }
    ++j;
  }
  ComplexMatrix X(n, static_cast<Index>(vectors.size()));
  for (std::size_t k = 0; k < vectors.size(); ++k) X.col(static_cast<Index>(k)) = vectors[k];
  GeneralEigenResult sorted = finish_general(lambda, X, sigma, options.nev);
  sorted.iterations = result.iterations;
  sorted.operator_applications = result.operator_applications;
  return sorted;
}

Vector dense_generalized_eigenvalues(const Matrix& K, const Matrix& M) {
  if (K.rows() != K.cols() || M.rows() != M.cols() || K.rows() != M.rows()) {
    throw InputError(
        fmt::format("dense_generalized_eigenvalues: K is {} x {} and M is {} x {}: "
                    "both must be square of one size",
                    K.rows(), K.cols(), M.rows(), M.cols()));
  }
  if (K.rows() > 5000) {
    throw InputError(
        fmt::format("dense_generalized_eigenvalues: N = {} > 5000: too large for a "
                    "dense eigensolver",
                    K.rows()));
  }
  const auto asym = [](const Matrix& A) {
    const double norm = A.norm();
    return norm == 0.0 ? 0.0 : (A - A.transpose()).norm() / norm;
  };
  if (asym(K) <= 1e-10 && asym(M) <= 1e-10) {
    const Matrix Ms = 0.5 * (M + M.transpose());
    Eigen::LLT<Matrix> llt(Ms);
    if (llt.info() == Eigen::Success) {
      Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> es(0.5 * (K + K.transpose()), Ms,
                                                          Eigen::EigenvaluesOnly);
      if (es.info() != Eigen::Success) {
        throw NumericalError("dense_generalized_eigenvalues: the symmetric eigensolver failed");
      }
      return es.eigenvalues();  // ascending
    }
  }
  detail::QzSolver ges(K, M, false);
  if (!ges.converged()) {
    throw NumericalError("dense_generalized_eigenvalues: the QZ eigensolver failed");
  }
  const Eigen::VectorXcd alpha = ges.alphas();
  const Vector beta = ges.betas();
  Vector lambda(K.rows());
  for (Index j = 0; j < K.rows(); ++j) {
    const double scale = std::abs(alpha[j]) + std::abs(beta[j]);
    if (std::abs(beta[j]) <= 1e-14 * scale) {
      throw NumericalError(
          fmt::format("dense_generalized_eigenvalues: the pencil has an infinite "
                      "eigenvalue (M singular, beta[{}] = {:g})",
                      j, beta[j]));
    }
    const Complex l = alpha[j] / beta[j];
    if (std::abs(l.imag()) > 1e-8 * std::abs(l)) {
      throw NumericalError(
          fmt::format("dense_generalized_eigenvalues: complex eigenvalue {:g}{:+g}i "
                      "(the result type holds real eigenvalues only)",
                      l.real(), l.imag()));
    }
    lambda[j] = l.real();
  }
  std::sort(lambda.data(), lambda.data() + lambda.size());
  return lambda;
}

}  // namespace ecmor
