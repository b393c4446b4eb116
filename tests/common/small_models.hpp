#pragma once
// Tiny dense models with closed-form norms, shared by the H2 and H-infinity tests, and a sparse
// spring-mass chain whose poles lie left of, on, or right of the imaginary axis by construction.
#include <cmath>
#include <vector>

#include "ecmor/model/model.hpp"

namespace ecmor::test {

/// E x' = A x + B u, y = C x with scalars: G(s) = c b / (e s - a).
inline ReducedDescriptorModel first_order(double e, double a, double b, double c) {
  ReducedDescriptorModel m;
  m.E = Matrix::Constant(1, 1, e);
  m.A = Matrix::Constant(1, 1, a);
  m.B = Matrix::Constant(1, 1, b);
  m.C = Matrix::Constant(1, 1, c);
  return m;
}

/// One degree of freedom, force in, displacement out: G(s) = 1 / (m s^2 + d s + k).
inline ReducedSecondOrderModel oscillator(double m, double d, double k) {
  ReducedSecondOrderModel s;
  s.M = Matrix::Constant(1, 1, m);
  s.D = Matrix::Constant(1, 1, d);
  s.K = Matrix::Constant(1, 1, k);
  s.B = Matrix::Ones(1, 1);
  s.C = Matrix::Ones(1, 1);
  return s;
}

// n masses 1 + 0.2 sin(i), springs 50 between neighbours, `ground` from mass 0 to the ground;
// `middle` replaces the spring before mass n/2 (negative: an unstable pole); D = alpha M + beta K.
inline SecondOrderModel spring_chain(Index n, double ground, double middle, double alpha,
                                     double beta) {
  std::vector<Eigen::Triplet<double>> m, k;
  for (Index i = 0; i < n; ++i) {
    m.emplace_back(i, i, 1.0 + 0.2 * std::sin(static_cast<double>(i)));
    if (i == 0) {
      if (ground != 0.0) k.emplace_back(0, 0, ground);
      continue;
    }
    const double s = i == n / 2 ? middle : 50.0;
    k.emplace_back(i, i, s);
    k.emplace_back(i - 1, i - 1, s);
    k.emplace_back(i, i - 1, -s);
    k.emplace_back(i - 1, i, -s);
  }
  SecondOrderModel sys;
  sys.M.resize(n, n);
  sys.M.setFromTriplets(m.begin(), m.end());
  sys.K.resize(n, n);
  sys.K.setFromTriplets(k.begin(), k.end());
  sys.D = (alpha * sys.M + beta * sys.K).pruned();
  sys.B = Matrix::Zero(n, 1);
  sys.B(n - 1, 0) = 1.0;
  sys.C = Matrix::Zero(1, n);
  sys.C(0, n - 1) = 1.0;
  return sys;
}

}  // namespace ecmor::test
