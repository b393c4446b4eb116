// compression.cpp: see compression.hpp.
#include "compression.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <vector>

#include "ecmor/measures/stability.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::driver {
namespace {

// Symmetry a Galerkin projection of symmetric matrices keeps up to rounding.
constexpr double kSymmetric = 1e-10;

// The accepted model as a symmetric pencil: second order M q'' + D q' + K q = B u, y = C q + Cv q'
// (mass Mr, stiffness Kr), or first order E x' = A x + B u, y = C x read as mass E and stiffness
// -A (a stable symmetric model has -A positive semidefinite), so that one modal path serves both.
struct Pencil {
  bool second_order = true;
  Matrix mass, stiffness, damping;  // damping: second order only
  Matrix B, C, Cv;                  // Cv: second order only (may be empty)
};

Pencil pencil_of(const ReducedModel& model) {
  Pencil p;
  if (const auto* r = std::get_if<ReducedSecondOrderModel>(&model)) {
    p = {true, r->M, r->K, r->D, r->B, r->C, r->Cv};
  } else {
    const auto& d = std::get<ReducedDescriptorModel>(model);
    p = {false, d.E, -d.A, Matrix(), d.B, d.C, Matrix()};
  }
  return p;
}

struct Modes {
  Pencil pencil;
  Matrix phi;  // n x n, mass-orthonormal columns
  std::vector<double>
      lambda;                // ascending: K phi = lambda M phi (first order: -A phi = lambda E phi)
  std::vector<Index> order;  // columns by rank: the rigid ones first, then by band contribution
  Index rigid = 0;           // leading entries of `order` that are always kept
};

// A mode's term of the response at w: c_i(w) b_i' / den_i(w), den = lambda - w^2 + i w d_i (second
// order) or lambda + i w (first order: i w - a_i with a_i = -lambda).
Complex denominator(const Modes& m, Index i, double w, double d) {
  const double l = m.lambda[static_cast<std::size_t>(i)];
  return m.pencil.second_order ? Complex(l - w * w, w * d) : Complex(l, w);
}

// The largest contribution of each mode to the response over the band, relative to the
// response there (the error measure is relative: near an antiresonance a small term matters):
// max over the samples and the modes' own resonances in the band of
// |c_i(w)| |b_i| / |den_i(w)| / ||Hr(w)||_F, Hr the sum of the modal terms.
std::vector<double> band_contributions(const Modes& m, std::vector<double> f_hz) {
  const Pencil& p = m.pencil;
  const Index n = m.phi.cols();
  const double f_lo = f_hz.front(), f_hi = f_hz.back();
  if (p.second_order) {
    for (double l : m.lambda) {
      const double f = l > 0.0 ? std::sqrt(l) / kTwoPi : -1.0;
      if (f >= f_lo && f <= f_hi) f_hz.push_back(f);
    }
  }
  const Matrix b = m.phi.transpose() * p.B;  // row i: b_i
  const Matrix c = p.C * m.phi;              // column i: c_i
  const Matrix cv = p.Cv.size() > 0 ? Matrix(p.Cv * m.phi) : Matrix::Zero(c.rows(), n);
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
  if (p.second_order)
    for (Index i = 0; i < n; ++i) d(i) = m.phi.col(i).dot(p.damping * m.phi.col(i));
  std::vector<double> score(static_cast<std::size_t>(n), 0.0);
  ComplexMatrix H(c.rows(), b.cols());
  std::vector<double> term(static_cast<std::size_t>(n));
  for (double f : f_hz) {
    const double w = kTwoPi * f;
    H.setZero();
    for (Index i = 0; i < n; ++i) {
      const Complex den = denominator(m, i, w, d(i));
      const Eigen::VectorXcd ci = c.col(i).cast<Complex>() + Complex(0.0, w) * cv.col(i);
      H += ci * b.row(i).cast<Complex>() / den;
      term[static_cast<std::size_t>(i)] = ci.norm() * b.row(i).norm() / std::abs(den);
    }
    const double scale = H.norm();
    if (!(scale > 0.0)) continue;
    for (Index i = 0; i < n; ++i) {
      double& s = score[static_cast<std::size_t>(i)];
      s = std::max(s, term[static_cast<std::size_t>(i)] / scale);
    }
  }
  return score;
}

// The accepted model's modes, ranked; std::nullopt with `why` when the model is not of the kind
// this compression keeps the structure of.
std::optional<Modes> ranked_modes(const ReducerResult& accepted, const RigidBodyModes& rigid,
                                  const std::vector<double>& f_hz, std::string& why) {
  if (accepted.W.size() != 0 && accepted.W != accepted.V) {
    why = "a Petrov-Galerkin model, W != V (compressed so far: W = V)";
    return std::nullopt;
  }
  Modes m;
  m.pencil = pencil_of(accepted.model);
  const Pencil& p = m.pencil;
  if (relative_asymmetry(p.mass) > kSymmetric || relative_asymmetry(p.stiffness) > kSymmetric ||
      (p.second_order && relative_asymmetry(p.damping) > kSymmetric)) {
    why = p.second_order
              ? "Mr, Dr or Kr is not symmetric (a reduced modal truncation needs symmetric "
                "matrices)"
              : "Er or Ar is not symmetric (a reduced modal truncation needs symmetric matrices)";
    return std::nullopt;
  }
  const Matrix Ms = 0.5 * (p.mass + p.mass.transpose());
  const Matrix Ks = 0.5 * (p.stiffness + p.stiffness.transpose());
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> eig(Ks, Ms);
  if (eig.info() != Eigen::Success) {
    why = p.second_order ? "Mr is not positive definite" : "Er is not positive definite";
    return std::nullopt;
  }
  m.phi = eig.eigenvectors();
  const Index n = m.phi.cols();
  for (Index i = 0; i < n; ++i) m.lambda.push_back(eig.eigenvalues()(i));
  // A free body's reduced model keeps its rigid-body modes: the lowest rigid.count eigenvalues.
  m.rigid = p.second_order && rigid.count > 0 ? std::min<Index>(rigid.count, n) : 0;
  const std::vector<double> score = band_contributions(m, f_hz);
  std::vector<Index> rest(static_cast<std::size_t>(n - m.rigid));
  std::iota(rest.begin(), rest.end(), m.rigid);
  std::stable_sort(rest.begin(), rest.end(), [&](Index a, Index b) {
    return score[static_cast<std::size_t>(a)] > score[static_cast<std::size_t>(b)];
  });
  for (Index i = 0; i < m.rigid; ++i) m.order.push_back(i);
  m.order.insert(m.order.end(), rest.begin(), rest.end());
  return m;
}

// The Galerkin projection of the accepted model onto its leading `count` ranked modes (in
// ascending eigenvalue order) and, with `residual`, the static response of the modes left out to
// the inputs, R = sum_j phi_j phi_j' Br / lambda_j over them (at most m columns, orthonormalised
// in the Mr inner product; they lie in the span of the modes left out, so they are Mr-orthogonal
// to the modes kept): modal truncation with static correction, at the reduced level. The reduced
// matrices come from the accepted ones, V' = V S.
ReducerResult truncated(const ReducerResult& accepted, const Modes& m, Index count, bool residual) {
  const Pencil& p = m.pencil;
  std::vector<Index> keep(m.order.begin(), m.order.begin() + count);
  std::sort(keep.begin(), keep.end());
  Matrix S(m.phi.rows(), count);
  for (Index j = 0; j < count; ++j) S.col(j) = m.phi.col(keep[static_cast<std::size_t>(j)]);
  if (residual && count < m.phi.cols()) {
    Matrix R = Matrix::Zero(m.phi.rows(), p.B.cols());
    for (auto it = m.order.begin() + count; it != m.order.end(); ++it) {
      const double l = m.lambda[static_cast<std::size_t>(*it)];
      if (l > 0.0) R += m.phi.col(*it) * (m.phi.col(*it).transpose() * p.B) / l;
    }
    // Mass-orthonormal columns from the eigenvectors of R' M R, with rank truncation.
    const Matrix G = R.transpose() * p.mass * R;
    Eigen::SelfAdjointEigenSolver<Matrix> eig(0.5 * (G + G.transpose()));
    const double top = eig.eigenvalues().size() > 0 ? eig.eigenvalues().maxCoeff() : 0.0;
    std::vector<Index> cols;
    for (Index i = 0; i < eig.eigenvalues().size(); ++i)
      if (eig.eigenvalues()(i) > 1e-12 * top && top > 0.0) cols.push_back(i);
    if (!cols.empty()) {
      Matrix Q(R.rows(), static_cast<Index>(cols.size()));
      for (std::size_t k = 0; k < cols.size(); ++k)
        Q.col(static_cast<Index>(k)) =
            R * eig.eigenvectors().col(cols[k]) / std::sqrt(eig.eigenvalues()(cols[k]));
      Matrix T(S.rows(), S.cols() + Q.cols());
      T << S, Q;
      S = std::move(T);
    }
  }
  ReducedModel c;
  if (const auto* r = std::get_if<ReducedSecondOrderModel>(&accepted.model)) {
    ReducedSecondOrderModel so;
    so.M = S.transpose() * r->M * S;
    so.D = S.transpose() * r->D * S;
    so.K = S.transpose() * r->K * S;
    so.B = S.transpose() * r->B;
    so.C = r->C * S;
    if (r->has_velocity_output()) so.Cv = r->Cv * S;
    c = std::move(so);
  } else {
    const auto& ds = std::get<ReducedDescriptorModel>(accepted.model);
    ReducedDescriptorModel d;
    d.E = S.transpose() * ds.E * S;
    d.A = S.transpose() * ds.A * S;
    d.B = S.transpose() * ds.B;
    d.C = ds.C * S;
    c = std::move(d);
  }
  ReducerResult out;
  out.model = std::move(c);
  out.V = accepted.V * S;
  out.W = accepted.W.size() == 0 ? Matrix() : Matrix(out.V);
  out.points = accepted.points;
  out.diagnostics = accepted.diagnostics;
  out.note = accepted.note;
  return out;
}

}  // namespace

std::optional<ReducerResult> compress_accepted(const ReducerResult& accepted,
                                               BandErrorEstimator& estimator,
                                               const ResponseCache& cache, double tolerance,
                                               Index verify_factor, const RigidBodyModes& rigid,
                                               CompressionReport& report, BandError& verified) {
  const auto start = std::chrono::steady_clock::now();
  const std::int64_t factorizations_before = static_cast<std::int64_t>(cache.size());
  auto finish = [&] {
    report.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    report.factorizations = static_cast<std::int64_t>(cache.size()) - factorizations_before;
  };
  report.attempted = true;
  report.method = "reduced modal truncation";
  const Index n = accepted.V.cols();
  report.order_before = report.order_after = n;
  const Band& band = estimator.band();
  // Where the band error of a candidate is known without new full solves: the estimator's grid
  // (dense mode: solved there; estimate mode: the reference's values) and, in estimate mode, the
  // frequencies where the full model was solved. (Dense mode has solved many more, the re-check
  // grid among them; the grid is enough to rank candidates, and the re-check sees the rest.)
  std::vector<double> f_hz = estimator.grid();
  if (estimator.mode() == ErrorVerify::Estimate)
    for (double f : cache.frequencies())
      if (f >= band.f_min_hz && f <= band.f_max_hz) f_hz.push_back(f);
  std::sort(f_hz.begin(), f_hz.end());
  f_hz.erase(std::unique(f_hz.begin(), f_hz.end()), f_hz.end());
  if (f_hz.size() < 2) f_hz = log_grid(band.f_min_hz, band.f_max_hz, 2);

  std::string why;
  const std::optional<Modes> modes = ranked_modes(accepted, rigid, f_hz, why);
  if (!modes) {
    report.note = "kept the accepted model: " + why;
    finish();
    return std::nullopt;
  }
  const Index keep_min = std::max<Index>(1, modes->rigid);
  auto meets = [&](Index count, bool residual) {
    ++report.candidates;
    return estimator.evaluate_on(truncated(accepted, *modes, count, residual).model, f_hz)
        .within(tolerance);
  };
  // The smallest leading set meeting the target on f_hz, by bisection (all n modes meet it),
  // without and with the static correction of the modes left out; the smaller model is tried.
  auto smallest = [&](bool residual) {
    Index lo = keep_min, hi = n;
    while (lo < hi) {
      const Index mid = lo + (hi - lo) / 2;
      if (meets(mid, residual))
        hi = mid;
      else
        lo = mid + 1;
    }
    return lo;
  };
  const Index plain = smallest(false);
  const Index corrected = smallest(true);
  const bool residual =
      corrected < n && truncated(accepted, *modes, corrected, true).V.cols() < plain;
  const Index lo = residual ? corrected : plain;
  // Before a re-check (which costs full solves), every frequency already solved in the band
  // screens the candidate (dense mode: the re-check grids of earlier models among them); a
  // candidate failing there moves up by an eighth of the distance to n, without a re-check.
  std::vector<double> solved;
  for (double f : cache.frequencies())
    if (f >= band.f_min_hz && f <= band.f_max_hz) solved.push_back(f);
  auto screened = [&](Index count) {
    if (solved.size() < 2) return true;
    ++report.candidates;
    return estimator.evaluate_on(truncated(accepted, *modes, count, residual).model, solved)
        .within(tolerance);
  };
  // The re-check against the full model; on failure, step halfway back to n (three at most).
  for (Index count = lo, attempt = 0; count < n && attempt < 3; ++attempt) {
    while (count < n && !screened(count)) count += std::max<Index>(1, (n - count) / 8);
    if (count >= n) break;
    ReducerResult candidate = truncated(accepted, *modes, count, residual);
    if (candidate.V.cols() >= n) break;
    ++report.verifications;
    BandError check = estimator.verify(candidate.model, verify_factor);
    const bool stable = reduced_model_stability(candidate.model, rigid).accepted();
    if (check.within(tolerance) && stable) {
      const Index order = candidate.V.cols();
      report.applied = true;
      report.order_after = order;
      report.error_after = check.sup_relative;
      if (residual) report.method = "reduced modal truncation with static correction";
      report.note = fmt::format(
          "{} -> {}: {} of {} modes of the accepted model kept{}{} (re-checked: {:.3e} at {:.4g} "
          "Hz)",
          n, order, count, n,
          modes->rigid > 0 ? fmt::format(", its {} rigid-body modes among them", modes->rigid)
                           : std::string(),
          residual ? fmt::format(", and {} static correction vector(s) for the rest", order - count)
                   : std::string(),
          check.sup_relative, check.f_peak_hz);
      candidate.note = accepted.note.empty() ? "compressed: " + report.note
                                             : accepted.note + "; compressed " + report.note;
      verified = std::move(check);
      finish();
      return candidate;
    }
    count += std::max<Index>(1, (n - count + 1) / 2);
  }
  report.note = lo >= n ? "kept the accepted model: no smaller set of its modes meets the target"
                        : fmt::format(
                              "kept the accepted model: the re-check refused the "
                              "{} compressed model(s) tried",
                              report.verifications);
  finish();
  return std::nullopt;
}

}  // namespace ecmor::driver
