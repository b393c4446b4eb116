#pragma once
// power_of_two_scaling.hpp: exact diagonal scaling of dense matrices and pencils. Private to the
// core's sources.
#include <algorithm>
#include <cmath>

#include "ecmor/base/types.hpp"

namespace ecmor::detail {

/// Scales the rows and columns of A (and of E with the same factors, when E is given) by powers
/// of two until the largest entry of each row and column of [A E] is near 1. The scaling is exact
/// in floating point, so it changes neither the rank of A nor the eigenvalues of the pencil
/// (D1 (A - lambda E) D2). Rows or columns that are zero stay as they are. At most `sweeps`
/// alternating row and column sweeps; stops early when one changes nothing.
inline void scale_by_powers_of_two(Matrix& A, Matrix* E = nullptr, int sweeps = 10) {
  auto factor = [](double m) { return m > 0.0 ? std::exp2(-std::round(std::log2(m))) : 1.0; };
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    bool changed = false;
    for (Index i = 0; i < A.rows(); ++i) {
      double m = A.row(i).cwiseAbs().maxCoeff();
      if (E) m = std::max(m, E->row(i).cwiseAbs().maxCoeff());
      const double s = factor(m);
      if (s == 1.0) continue;
      A.row(i) *= s;
      if (E) E->row(i) *= s;
      changed = true;
    }
    for (Index j = 0; j < A.cols(); ++j) {
      double m = A.col(j).cwiseAbs().maxCoeff();
      if (E) m = std::max(m, E->col(j).cwiseAbs().maxCoeff());
      const double s = factor(m);
      if (s == 1.0) continue;
      A.col(j) *= s;
      if (E) E->col(j) *= s;
      changed = true;
    }
    if (!changed) break;
  }
}

}  // namespace ecmor::detail
