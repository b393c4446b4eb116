// start_shifts.cpp: IRKA's starting data (start_shifts.hpp).
#include "start_shifts.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/eigensolver.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/model/model.hpp"
#include "next_shifts.hpp"

namespace ecmor::irka {

namespace {

/// Second order: mirror images of the pole pairs of the floor(r/2) undamped modes nearest wc
/// (modal damping), completed by band shifts when too few modes are usable.
Interpolation modal_shifts_second_order(const StartSetting& s, const SecondOrderModel* so, Index r,
                                        double wc) {
  FirstOrderView& view = *s.view;
  std::vector<Complex> shifts;
  const Index pairs = r / 2;
  if (pairs > 0) {
    if (relative_asymmetry(so->K) > 1e-10 || !is_positive_definite(so->M)) {
      throw InputError(
          "irka: initial_shifts = modal needs symmetric K and a symmetric positive definite M "
          "for a second-order model; use initial_shifts: band");
    }
    const double sigma = wc * wc;
    const std::vector<Complex> w{Complex(1.0), Complex(0.0), Complex(-sigma)};
    const auto F = view.solver().factorize_combination(w);
    EigenOptions eo;
    eo.nev = std::min<Index>(pairs, view.size() - 1);
    const SymmetricEigenResult modes = symmetric_shift_invert(*F, so->M, sigma, eo);
    ComplexMatrix b(view.inputs(), 2 * modes.eigenvalues.size());
    ComplexMatrix c(view.outputs(), 2 * modes.eigenvalues.size());
    Index k = 0;
    for (Index j = 0; j < modes.eigenvalues.size(); ++j) {
      const Vector phi = modes.eigenvectors.col(j);
      const double w2 = std::max(modes.eigenvalues(j), 0.0);
      const double a = 0.5 * phi.dot(so->D * phi);
      // Poles: lambda^2 + 2 a lambda + w^2 = 0, lambda = -a -+ sqrt(a^2 - w^2); shifts -lambda.
      const Complex root = std::sqrt(Complex(a * a - w2, 0.0));
      if (std::abs(Complex(a, 0.0) - root) == 0.0) continue;  // rigid-body mode: a shift at 0
      const ComplexVector bj = (so->B.transpose() * phi).cast<Complex>();
      for (const Complex z : {Complex(a, 0.0) + root, Complex(a, 0.0) - root}) {
        // Residue direction at the pole -z: (C + (-z) Cv) phi.
        ComplexVector cj = (so->C * phi).cast<Complex>();
        if (so->has_velocity_output()) cj -= z * (so->Cv * phi).cast<Complex>();
        shifts.push_back(z);
        b.col(k) = bj;
        c.col(k) = cj;
        ++k;
      }
    }
    while (static_cast<Index>(shifts.size()) < 2 * pairs) {
      // Too few usable modes: complete with band shifts.
      const Interpolation band = band_shifts(s, 2 * pairs - static_cast<Index>(shifts.size()), 0);
      b.conservativeResize(Eigen::NoChange, k + band.size());
      c.conservativeResize(Eigen::NoChange, k + band.size());
      for (Index j = 0; j < band.size(); ++j, ++k) {
        shifts.push_back(band.shifts[static_cast<std::size_t>(j)]);
        b.col(k) = band.b.col(j);
        c.col(k) = band.c.col(j);
      }
    }
    if (r % 2 == 1) {
      shifts.emplace_back(wc, 0.0);
      b.conservativeResize(Eigen::NoChange, k + 1);
      c.conservativeResize(Eigen::NoChange, k + 1);
      b.col(k).setConstant(1.0);
      c.col(k).setConstant(1.0);
    }
    for (Index j = 0; j < b.cols(); ++j) {
      if (b.col(j).norm() > 0.0) b.col(j).normalize();
      if (c.col(j).norm() > 0.0) c.col(j).normalize();
    }
    return canonical(shifts, b, c);
  }
  return band_shifts(s, r, 0);
}

/// Descriptor: the mirror images of the dominant poles of (A, E) nearest -wc.
Interpolation modal_shifts_descriptor(const StartSetting& s, Index r, double wc) {
  FirstOrderView& view = *s.view;
  // Descriptor: dominant poles. 3r eigenvalues nearest -w_c with right (A x = l E x) and left
  // (y' A = l y' E) eigenvectors give the residues c b' with c = C x, b = B' y / (y' E x); the
  // r of largest H2 weight are mirrored (as IRKA mirrors its reduced poles, next_shifts()).
  const auto& ds = std::get<DescriptorModel>(*s.model);
  const double sigma = -wc;
  const std::vector<Complex> w{Complex(-1.0), Complex(-sigma)};  // A - sigma E
  const auto F = view.solver().factorize_combination(w);
  EigenOptions eo;
  eo.nev = std::max<Index>(1, std::min<Index>(3 * r, view.size() - 3));
  const GeneralEigenResult right = general_shift_invert(*F, ds.E, sigma, eo, false);
  const GeneralEigenResult left = general_shift_invert(*F, ds.E, sigma, eo, true);
  const Index k = right.eigenvalues.size();
  PoleResidues pr;
  pr.poles = right.eigenvalues;
  pr.b.resize(view.inputs(), k);
  pr.c.resize(view.outputs(), k);
  const ComplexMatrix EX = ds.E.cast<Complex>() * right.eigenvectors;
  for (Index i = 0; i < k; ++i) {
    Index j = 0;
    double nearest = std::numeric_limits<double>::infinity();
    for (Index l = 0; l < left.eigenvalues.size(); ++l) {
      const double d = std::abs(left.eigenvalues(l) - right.eigenvalues(i));
      if (d < nearest) {
        nearest = d;
        j = l;
      }
    }
    const ComplexVector y = left.eigenvectors.col(j);
    const Complex scale = y.transpose() * EX.col(i);
    pr.c.col(i) = ds.C.cast<Complex>() * right.eigenvectors.col(i);
    pr.b.col(i) = ds.B.transpose().cast<Complex>() * y / scale;
  }
  if (k < r) {
    throw NumericalError(fmt::format(
        "irka: initial_shifts = modal found {} eigenvalues near the band, fewer than r = {}", k,
        r));
  }
  Index reflected = 0;
  return next_shifts(pr, r, reflected);
}

}  // namespace

Interpolation band_shifts(const StartSetting& s, Index r, Index attempt) {
  const Index pairs = r / 2;
  const double lo = std::log(s.band.f_min_hz), hi = std::log(s.band.f_max_hz);
  const double offset = std::fmod(0.5 + 0.381966 * static_cast<double>(attempt), 1.0);
  if (s.real_poles) {
    // Real shifts 2 pi f at r log-spaced band frequencies.
    std::vector<Complex> real;
    for (Index k = 0; k < r; ++k) {
      const double t = (static_cast<double>(k) + offset) / static_cast<double>(r);
      real.emplace_back(kTwoPi * std::exp(lo + t * (hi - lo)), 0.0);
    }
    return with_uniform_directions(s, real);
  }
  const double zeta =
      attempt == 0 ? s.damping : std::max(s.damping, 1e-2 * std::pow(10.0, attempt - 1));
  std::vector<Complex> shifts;
  for (Index k = 0; k < pairs; ++k) {
    const double t = (static_cast<double>(k) + offset) / static_cast<double>(pairs);
    const double w = kTwoPi * std::exp(lo + t * (hi - lo));
    shifts.emplace_back(zeta * w, w);
    shifts.emplace_back(zeta * w, -w);
  }
  if (r % 2 == 1) shifts.emplace_back(kTwoPi * std::exp(0.5 * (lo + hi)), 0.0);
  return with_uniform_directions(s, shifts);
}

Interpolation with_uniform_directions(const StartSetting& s, const std::vector<Complex>& shifts) {
  const Index r = static_cast<Index>(shifts.size());
  const Index m = s.view->inputs(), p = s.view->outputs();
  const ComplexMatrix b = ComplexMatrix::Constant(m, r, 1.0 / std::sqrt(static_cast<double>(m)));
  const ComplexMatrix c = ComplexMatrix::Constant(p, r, 1.0 / std::sqrt(static_cast<double>(p)));
  return canonical(shifts, b, c);
}

Interpolation balanced_shifts(const StartSetting& s, std::optional<DenseBalancing>& balancing,
                              Index r) {
  const Index dim = s.view->state_size();
  if (dim > s.dense_check_limit) {
    throw ConfigError(fmt::format(
        "reducer 'irka': initial_shifts = balanced needs dense Gramians: the first-order state "
        "has {} > dense_check_limit = {} entries; use band or modal",
        dim, s.dense_check_limit));
  }
  // Once per setup: every order's balanced truncation is a prefix of the same SVD.
  if (!balancing) balancing.emplace(densify(*s.model));
  const Index k = std::min<Index>(r, balancing->positive_count());
  if (k < 1)
    throw NumericalError(
        "reducer 'irka': initial_shifts = balanced: every Hankel singular value "
        "of the model is zero");
  const ReducedDescriptorModel bt = balancing->truncate(k);
  const PoleResidues pr = pole_residues(bt.E, bt.A, bt.B, bt.C);
  Index reflected = 0;
  return next_shifts(pr, r, reflected);
}

Interpolation modal_shifts(const StartSetting& s, Index r) {
  const double wc = kTwoPi * std::sqrt(s.band.f_min_hz * s.band.f_max_hz);
  if (const SecondOrderModel* so = s.view->so()) return modal_shifts_second_order(s, so, r, wc);
  return modal_shifts_descriptor(s, r, wc);
}

Interpolation completed_shifts(const StartSetting& s, const Interpolation& previous, Index r) {
  std::vector<Complex> shifts = previous.shifts;
  ComplexMatrix b = previous.b, c = previous.c;
  const Index add = r - previous.size();
  const Index m = b.rows(), p = c.rows();
  std::vector<double> logs{std::log(s.band.f_min_hz), std::log(s.band.f_max_hz)};
  for (const Complex& z : shifts) {
    const double f = (s.one_sided ? std::abs(z) : std::abs(z.imag())) / kTwoPi;
    if (f > s.band.f_min_hz && f < s.band.f_max_hz) logs.push_back(std::log(f));
  }
  auto widest_gap_midpoint = [&]() {
    std::sort(logs.begin(), logs.end());
    double best = -1.0, mid = logs.front();
    for (std::size_t i = 0; i + 1 < logs.size(); ++i) {
      if (logs[i + 1] - logs[i] > best) {
        best = logs[i + 1] - logs[i];
        mid = 0.5 * (logs[i] + logs[i + 1]);
      }
    }
    logs.push_back(mid);
    return kTwoPi * std::exp(mid);
  };
  std::vector<Complex> added;
  if (s.one_sided) {
    // Real shifts 2 pi f, as band_shifts() starts a model with real poles.
    while (static_cast<Index>(added.size()) < add) added.emplace_back(widest_gap_midpoint(), 0.0);
  } else {
    for (Index k = 0; k + 1 < add; k += 2) {
      const double w = widest_gap_midpoint();
      added.emplace_back(s.damping * w, w);
      added.emplace_back(s.damping * w, -w);
    }
    if (add % 2 == 1) added.emplace_back(widest_gap_midpoint(), 0.0);
  }
  const Index old = previous.size();
  b.conservativeResize(m, r);
  c.conservativeResize(p, r);
  for (Index k = 0; k < add; ++k) {
    shifts.push_back(added[static_cast<std::size_t>(k)]);
    b.col(old + k).setConstant(1.0 / std::sqrt(static_cast<double>(m)));
    c.col(old + k).setConstant(1.0 / std::sqrt(static_cast<double>(p)));
  }
  return canonical(shifts, b, c);
}

}  // namespace ecmor::irka
