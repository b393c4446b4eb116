#include "ecmor/model/dense_model.hpp"

#include <string>
#include <variant>

#include "ecmor/base/error.hpp"

namespace ecmor {

ReducedDescriptorModel first_order_realization(const ReducedModel& model) {
  if (const auto* d = std::get_if<ReducedDescriptorModel>(&model)) return *d;
  const auto& s = std::get<ReducedSecondOrderModel>(model);
  const Index n = s.size(), m = s.inputs(), p = s.outputs();
  ReducedDescriptorModel r;
  r.E = Matrix::Zero(2 * n, 2 * n);
  r.E.topLeftCorner(n, n).setIdentity();
  r.E.bottomRightCorner(n, n) = s.M;
  r.A = Matrix::Zero(2 * n, 2 * n);
  r.A.topRightCorner(n, n).setIdentity();
  r.A.bottomLeftCorner(n, n) = -s.K;
  r.A.bottomRightCorner(n, n) = -s.D;
  r.B = Matrix::Zero(2 * n, m);
  r.B.bottomRows(n) = s.B;
  r.C = Matrix::Zero(p, 2 * n);
  r.C.leftCols(n) = s.C;
  if (s.has_velocity_output()) r.C.rightCols(n) = s.Cv;
  return r;
}

ReducedModel densify(const Model& model) {
  const Index states =
      kind_of(model) == ModelKind::SecondOrder ? 2 * size_of(model) : size_of(model);
  if (states > kMaxDenseStates)
    throw InputError(
        "densify: the model has " + std::to_string(states) +
        " first-order states: at most kMaxDenseStates = " + std::to_string(kMaxDenseStates) +
        " are converted to dense matrices (use h2_error_quadrature for large models)");
  if (const auto* s = std::get_if<SecondOrderModel>(&model)) {
    ReducedSecondOrderModel r;
    r.M = Matrix(s->M);
    r.D = Matrix(s->D);
    r.K = Matrix(s->K);
    r.B = s->B;
    r.C = s->C;
    r.Cv = s->Cv;
    return r;
  }
  const auto& d = std::get<DescriptorModel>(model);
  ReducedDescriptorModel r;
  r.E = Matrix(d.E);
  r.A = Matrix(d.A);
  r.B = d.B;
  r.C = d.C;
  return r;
}

}  // namespace ecmor
