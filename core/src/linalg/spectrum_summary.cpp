// spectrum_summary.cpp: the lowest modes of a model for `ecmor info` (see spectrum_summary.hpp),
// computed here so that the command only formats them.
#include "ecmor/linalg/spectrum_summary.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/eigensolver.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/linalg/spectrum_slicer.hpp"

namespace ecmor {
namespace {

// K and M must be symmetric to rounding for the undamped eigenproblem (symmetric Lanczos).
constexpr double kSymmetryTol = 1e-12;

SpectrumSummary undamped_spectrum(const Model& model, const SecondOrderModel& so,
                                  ShiftedSolver& solver, Index nev) {
  const double asymmetry_k = relative_asymmetry(so.K), asymmetry_m = relative_asymmetry(so.M);
  if (!(asymmetry_k <= kSymmetryTol) || !(asymmetry_m <= kSymmetryTol)) {
    throw InputError(fmt::format(
        "K and M must be symmetric for the undamped eigenproblem (relative asymmetry of K {:.1e}, "
        "of M {:.1e}; at most {:.0e})",
        asymmetry_k, asymmetry_m, kSymmetryTol));
  }
  SpectrumSummary s;
  const RigidBodyModes rigid = rigid_body_modes(model, solver);
  s.rigid_body = rigid.describe();
  SliceOptions options;
  options.batch_size = std::max<Index>(nev, 20);
  options.caller = "spectrum_summary";
  SymmetricSlicer slicer(so.K, so.M, solver, pencil_factorizer(solver, true), true, options, 0.0,
                         rigid);
  while (slicer.known() < nev && !slicer.complete()) slicer.next_batch();
  std::vector<double> lambda;
  for (Index j = 0; j < slicer.known(); ++j) lambda.push_back(slicer.lambda(j));
  std::sort(lambda.begin(), lambda.end());
  lambda.resize(std::min<std::size_t>(lambda.size(), static_cast<std::size_t>(nev)));
  for (const double l : lambda) s.modes.push_back({slicer.frequency(l), {}, slicer.is_rigid(l)});
  return s;
}

SpectrumSummary spectrum_nearest_zero(const DescriptorModel& ds, ShiftedSolver& solver, Index nev) {
  EigenOptions options;
  options.nev = nev;
  const std::vector<Complex> w{-1.0, 0.0};  // A - 0 E
  const auto f = solver.factorize_combination(w);
  const GeneralEigenResult r = general_shift_invert(*f, ds.E, 0.0, options);
  SpectrumSummary s;
  s.undamped = false;
  for (Index i = 0; i < r.eigenvalues.size(); ++i) {
    const Complex l = r.eigenvalues(i);
    s.modes.push_back({std::abs(l) / kTwoPi, -l.real() / std::abs(l), false});
  }
  return s;
}

}  // namespace

SpectrumSummary spectrum_summary(const Model& model, ShiftedSolver& solver, Index count) {
  if (count < 1)
    throw ConfigError(fmt::format("spectrum_summary: count = {}: must be >= 1", count));
  // ARPACK computes at most N - 2 eigenvalues of an N x N problem.
  const Index nev = std::min<Index>(count, std::max<Index>(1, size_of(model) - 2));
  if (const auto* so = std::get_if<SecondOrderModel>(&model))
    return undamped_spectrum(model, *so, solver, nev);
  return spectrum_nearest_zero(std::get<DescriptorModel>(model), solver, nev);
}

}  // namespace ecmor
