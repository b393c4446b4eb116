#pragma once
// Independent references for strategy tests on small SISO models: a Rayleigh-damped spring chain,
// and the supremum of the relative error computed with dense LU solves (Eigen), apart from the
// library's sparse solver, response cache, reduced-response path and estimator sampling.
#include <Eigen/LU>
#include <cmath>
#include <utility>
#include <variant>
#include <vector>

#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::test {

/// n unit masses in a chain of springs of stiffness k (fixed at both ends), D = alpha M + beta K,
/// force on the first mass, displacement of the last one observed.
inline SecondOrderModel spring_chain(Index n, double k, double alpha, double beta) {
  SecondOrderModel m;
  m.M = SparseMatrix(n, n);
  m.K = SparseMatrix(n, n);
  m.D = SparseMatrix(n, n);
  std::vector<Eigen::Triplet<double, int>> tk, td, tm;
  for (int i = 0; i < static_cast<int>(n); ++i) {
    tm.emplace_back(i, i, 1.0);
    tk.emplace_back(i, i, 2.0 * k);
    td.emplace_back(i, i, alpha + 2.0 * beta * k);
    if (i + 1 < static_cast<int>(n)) {
      for (auto [r, c] : {std::pair{i, i + 1}, std::pair{i + 1, i}}) {
        tk.emplace_back(r, c, -k);
        td.emplace_back(r, c, -beta * k);
      }
    }
  }
  m.M.setFromTriplets(tm.begin(), tm.end());
  m.K.setFromTriplets(tk.begin(), tk.end());
  m.D.setFromTriplets(td.begin(), td.end());
  m.B = Matrix::Zero(n, 1);
  m.B(0, 0) = 1.0;
  m.C = Matrix::Zero(1, n);
  m.C(0, n - 1) = 1.0;
  return m;
}

/// Hr(s) of a SISO reduced model of either kind by a dense LU.
inline Complex dense_reduced_h(const ReducedModel& reduced, Complex s) {
  if (const auto* r = std::get_if<ReducedSecondOrderModel>(&reduced)) {
    const ComplexMatrix Pr =
        (s * s) * r->M.cast<Complex>() + s * r->D.cast<Complex>() + r->K.cast<Complex>();
    ComplexMatrix C = r->C.cast<Complex>();
    if (r->has_velocity_output()) C += s * r->Cv.cast<Complex>();
    return (C * Pr.partialPivLu().solve(r->B.cast<Complex>()))(0, 0);
  }
  const auto& r = std::get<ReducedDescriptorModel>(reduced);
  const ComplexMatrix P = s * r.E.cast<Complex>() - r.A.cast<Complex>();
  return (r.C.cast<Complex>() * P.partialPivLu().solve(r.B.cast<Complex>()))(0, 0);
}

/// sup over `samples` log-spaced frequencies of the band of |H - Hr| / |H| (SISO, position
/// output), both by dense LU. Returns {sup, f at sup}; a NaN error is returned at once (it fails
/// any caller's <= check).
inline std::pair<double, double> dense_sup_error(const SecondOrderModel& full,
                                                 const ReducedModel& reduced, const Band& band,
                                                 Index samples) {
  const Matrix M = Matrix(full.M), D = Matrix(full.D), K = Matrix(full.K);
  double sup = 0.0, f_sup = 0.0;
  for (Index i = 0; i < samples; ++i) {
    const double f =
        band.f_min_hz * std::pow(band.f_max_hz / band.f_min_hz,
                                 static_cast<double>(i) / static_cast<double>(samples - 1));
    const Complex s(0.0, kTwoPi * f);
    const ComplexMatrix P = (s * s) * M.cast<Complex>() + s * D.cast<Complex>() + K.cast<Complex>();
    const Complex h =
        (full.C.cast<Complex>() * P.partialPivLu().solve(full.B.cast<Complex>()))(0, 0);
    const double e = std::abs(h - dense_reduced_h(reduced, s)) / std::abs(h);
    if (std::isnan(e)) return {e, f};
    if (e > sup) {
      sup = e;
      f_sup = f;
    }
  }
  return {sup, f_sup};
}

}  // namespace ecmor::test
