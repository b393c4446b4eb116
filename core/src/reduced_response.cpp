#include "ecmor/reduced_response.hpp"

#include <cmath>
#include <limits>
#include <sstream>

#include "ecmor/error.hpp"
#include "ecmor/frequency_response.hpp"

namespace ecmor {
namespace {

// Forming Mr^-1 [Kr Dr] loses about log10(1/rcond) digits: accept at most 8 of 16, far below any
// tolerance a user sets; worse-conditioned mass matrices take the dense LU per frequency.
constexpr double kMinRcond = 1e-8;

// Solves X = A^-1 B with a pivoted LU if A is well conditioned; returns false otherwise.
bool solve_if_well_conditioned(const Matrix& A, const Matrix& B, Matrix& X) {
  if (A.rows() == 0) return false;
  Eigen::PartialPivLU<Matrix> lu(A);
  const double rcond = lu.rcond();
  if (!(rcond > kMinRcond)) return false;
  X = lu.solve(B);
  return X.allFinite();
}

}  // namespace

ReducedResponse::ReducedResponse(const ReducedModel& model) : m_model(model) {
  Matrix F, G, L;
  bool ok = false;
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model)) {
    const Index n = so->size();
    Matrix MinvKD, MinvB;
    Matrix KD(n, 2 * n);
    KD << so->K, so->D;
    if (solve_if_well_conditioned(so->M, KD, MinvKD) &&
        solve_if_well_conditioned(so->M, so->B, MinvB)) {
      F = Matrix::Zero(2 * n, 2 * n);
      F.topRightCorner(n, n).setIdentity();
      F.bottomRows(n) = -MinvKD;
      G = Matrix::Zero(2 * n, so->inputs());
      G.bottomRows(n) = MinvB;
      L = Matrix::Zero(so->outputs(), 2 * n);
      L.leftCols(n) = so->C;
      if (so->has_velocity_output()) L.rightCols(n) = so->Cv;
      ok = true;
    }
  } else {
    const auto& ds = std::get<ReducedDescriptorModel>(model);
    Matrix AB(ds.size(), ds.size() + ds.inputs());
    AB << ds.A, ds.B;
    Matrix X;
    if (solve_if_well_conditioned(ds.E, AB, X)) {
      F = X.leftCols(ds.size());
      G = X.rightCols(ds.inputs());
      L = ds.C;
      ok = true;
    }
  }
  if (!ok || F.rows() == 0) return;
  Eigen::HessenbergDecomposition<Matrix> hess(F);
  const Matrix Q = hess.matrixQ();
  m_H = hess.matrixH();
  m_G = Q.transpose() * G;
  m_L = L * Q;
  m_scale = m_H.size() > 0 ? m_H.cwiseAbs().maxCoeff() : 0.0;
  m_hessenberg = m_H.allFinite() && m_G.allFinite() && m_L.allFinite();
}

ComplexMatrix ReducedResponse::operator()(Complex s) const {
  if (!m_hessenberg) return transfer_function(m_model, s);
  const Index n = m_H.rows();
  // T = s I - H is upper Hessenberg: eliminate the single subdiagonal entry of each column with
  // partial pivoting between rows k and k + 1 (growth bounded by n), then back-substitute.
  ComplexMatrix T = (-m_H).cast<Complex>();
  T.diagonal().array() += s;
  ComplexMatrix X = m_G.cast<Complex>();
  const double scale = m_scale + std::abs(s);  // bounds max |T_ij| without a pass over T
  const double tiny = scale * static_cast<double>(n) * std::numeric_limits<double>::epsilon();
  for (Index k = 0; k + 1 < n; ++k) {
    if (std::abs(T(k + 1, k)) > std::abs(T(k, k))) {
      T.row(k).segment(k, n - k).swap(T.row(k + 1).segment(k, n - k));
      X.row(k).swap(X.row(k + 1));
    }
    if (T(k + 1, k) == Complex(0.0)) continue;
    const Complex l = T(k + 1, k) / T(k, k);
    T.row(k + 1).segment(k + 1, n - k - 1) -= l * T.row(k).segment(k + 1, n - k - 1);
    T(k + 1, k) = 0.0;
    X.row(k + 1) -= l * X.row(k);
  }
  for (Index k = 0; k < n; ++k) {
    if (!(std::abs(T(k, k)) > tiny)) {
      std::ostringstream os;
      os << "reduced model: s = " << s.real() << (s.imag() < 0 ? "-" : "+") << std::abs(s.imag())
         << "i is (numerically) a pole";
      throw NumericalError(os.str());
    }
  }
  T.triangularView<Eigen::Upper>().solveInPlace(X);
  return m_L.cast<Complex>() * X;
}

}  // namespace ecmor
