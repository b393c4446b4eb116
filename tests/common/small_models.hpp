#pragma once
// Tiny dense models with closed-form norms, shared by the H2 and H-infinity tests.
#include "ecmor/model.hpp"

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

}  // namespace ecmor::test
