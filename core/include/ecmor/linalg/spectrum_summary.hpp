#pragma once
/// \file spectrum_summary.hpp
/// The lowest part of a model's spectrum, as `ecmor info --eigenfrequencies` lists it: the
/// undamped eigenfrequencies of a second-order model with its rigid-body modes marked (by the
/// modal reducer's certified spectrum slicing, spectrum_slicer.hpp, so both call the same modes
/// rigid), or the eigenvalues of a descriptor model nearest 0 with their damping ratios (ARPACK
/// shift-invert, eigensolver.hpp).

#include <optional>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// One mode of spectrum_summary().
struct SpectrumMode {
  /// Second order: f = sqrt(lambda) / 2pi [Hz] of K phi = lambda M phi (D ignored: undamped).
  /// Descriptor: |lambda| / 2pi [Hz] of A x = lambda E x.
  double frequency_hz = 0.0;
  /// Descriptor only: zeta = -Re(lambda) / |lambda| (> 0: the mode decays). None for the
  /// undamped eigenproblem of a second-order model.
  std::optional<double> damping_ratio;
  /// Second order only: a rigid-body mode (K phi = 0, rigid_body.hpp), f = 0 up to rounding.
  bool rigid = false;
};

/// What spectrum_summary() found.
struct SpectrumSummary {
  /// true: the undamped eigenproblem (K, M) of a second-order model; false: the pencil (A, E) of a
  /// descriptor model.
  bool undamped = true;
  /// Second order: the rigid-body analysis (RigidBodyModes::describe(), e.g. "6 rigid-body modes
  /// (...)"); empty for a descriptor model.
  std::string rigid_body;
  /// Second order: the lowest eigenfrequencies, ascending, rigid-body modes first. Descriptor: the
  /// eigenvalues nearest 0, nearest first (ARPACK's order; a complex conjugate pair is never
  /// split, so there may be one more than asked for).
  std::vector<SpectrumMode> modes;
};

/// The lowest `count` modes of `model` (fewer when N is small: at most max(1, N - 2), ARPACK's
/// limit), factorising with `solver` (make_shifted_solver(model); it must belong to `model`).
/// \throws ConfigError "spectrum_summary: count = 0: must be >= 1"; InputError when a second-order
///         model's K or M is not symmetric (relative asymmetry > 1e-12, naming both values: the
///         undamped eigenproblem needs them symmetric) or K is indefinite; NumericalError from the
///         eigensolvers (ARPACK's failures, a singular A at the shift 0).
ECMOR_API SpectrumSummary spectrum_summary(const Model& model, ShiftedSolver& solver, Index count);

}  // namespace ecmor
