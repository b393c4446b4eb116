// band_error_estimate.cpp: the estimate mode of the band error (band_error.hpp).
//
// Why a reference model and not the residual alone: the seed's residual E_r(s) = B - P(s) V Qbar(s)
// (Eqs. 9-10) costs O(r^2) per frequency after an offline split, but turning it into an output
// error needs ||C P(s)^-1||, which is large exactly where it matters (near resonances) and unknown
// without a full solve; the dual correction needs a dual space richer than the candidate's. The
// full solves a run makes anyway span such a space: projected together with the candidate's own
// basis, they give a reference model that is exact wherever the full model was solved, at least
// as rich as the candidate, and only improves as the run solves more. The estimate of the error
// is then ||H_ref - H_r|| / ||H_ref||, at reduced cost on thousands of frequencies, and every full
// solve the checks make is fed back into the reference.
#include "measures/band_error_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <numeric>

#include "base/parallel_for.hpp"
#include "base/wall_timer.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace ecmor::detail {

namespace {

// Index of the sample at exactly f in the ascending e.f_hz, or -1.
std::ptrdiff_t index_of(const BandError& e, double f) {
  const auto it = std::lower_bound(e.f_hz.begin(), e.f_hz.end(), f);
  if (it == e.f_hz.end() || *it != f) return -1;
  return it - e.f_hz.begin();
}

double value_or_minus_one(double r) { return std::isnan(r) ? -1.0 : r; }

// The band edges and, between them, points of the golden-ratio sequence in log f: spread over the
// band, but off the "round" positions (log-uniform grids, the band centre) where reducers put
// their own expansion points. A reference seeded exactly where the candidate interpolates adds
// nothing to it: measured on an RC ladder whose Krylov candidate used the same log-uniform points
// as the seeds, the estimate was 1.8e-14 against a true error of 2.6e-4.
std::vector<double> seed_frequencies(const Band& band, Index count) {
  const double x0 = std::log(band.f_min_hz), x1 = std::log(band.f_max_hz);
  std::vector<double> f = {band.f_min_hz, band.f_max_hz};
  constexpr double kGoldenFraction = 0.6180339887498949;
  for (Index k = 1; k + 1 < count; ++k) {
    const double u = std::fmod(0.5 + static_cast<double>(k) * kGoldenFraction, 1.0);
    f.push_back(std::exp(x0 + u * (x1 - x0)));
  }
  std::sort(f.begin(), f.end());
  return f;
}

// Modelled floating-point operations of the reference model's own work, the work the dense mode
// does not do (the operation counts of Golub & Van Loan, "Matrix Computations", 4th ed.). Counted,
// not timed, so that the choice between estimate and dense mode (verify: auto) is the same on
// every run and every machine, whatever else the machine is doing.
struct ReferenceCost {
  double n = 0.0;  // first-order size of the Hessenberg form (2 r for a second-order reference)
  double r = 0.0;  // order of the reference
  double m = 0.0, p = 0.0;

  explicit ReferenceCost(const ReducedModel& reference) {
    std::visit(
        [&](const auto& sys) {
          r = static_cast<double>(sys.size());
          m = static_cast<double>(sys.inputs());
          p = static_cast<double>(sys.outputs());
        },
        reference);
    n = std::holds_alternative<ReducedSecondOrderModel>(reference) ? 2.0 * r : r;
  }
  // ReducedResponse's set-up: the LU of M_r (E_r) and its solves, the Hessenberg reduction
  // (10/3 n^3) and the reflectors applied to G and L.
  double setup() const {
    return (2.0 / 3.0) * r * r * r + 2.0 * r * r * (n + m) + (10.0 / 3.0) * n * n * n +
           4.0 * n * n * (m + p);
  }
  // One frequency: the Hessenberg path's elimination (n^2 (1 + min(m, p)) / 2 complex
  // multiply-adds, 8 flops each), or the dense LU of P_r(s) (8/3 r^3 for a complex LU) and its
  // solves.
  double per_frequency(bool hessenberg) const {
    if (hessenberg) return 4.0 * n * n * (1.0 + std::min(m, p));
    return (8.0 / 3.0) * r * r * r + 8.0 * r * r * m + 8.0 * p * r * m;
  }
  // The reference's poles: the eigenvalues of its n x n pencil by the QZ algorithm.
  double poles() const { return 30.0 * n * n * n; }
};

}  // namespace

EstimateEngine::EstimateEngine(ResponseCache& full, const Band& band,
                               const BandErrorOptions& options)
    : m_full(full), m_band(band), m_options(options), m_reference(full.model()) {
  m_full.keep_solutions(true);
  m_grid = log_grid(band.f_min_hz, band.f_max_hz, options.estimate_points);
  solve_full(seed_frequencies(band, options.reference_points));
  if (m_reference.order() == 0)
    throw NumericalError("band error estimate: the full model could not be solved at any of the " +
                         std::to_string(options.reference_points) +
                         " seed frequencies of the band");
  // The scale of "H vanishes": the largest ||H|| over the estimate's grid. A frequency where the
  // reference model has a pole on the axis (an unstable or undamped model) is left out here; the
  // samples mark it as undefined.
  for (double f : m_grid) {
    try {
      const ComplexMatrix H = values({f}).H.front();
      m_scale2 = std::max(m_scale2, matrix_norm(H, ErrorNorm::Spectral));
      m_scaleF = std::max(m_scaleF, H.norm());
    } catch (const NumericalError&) {
    }
  }
}

Index EstimateEngine::solve_full(const std::vector<double>& f_hz) {
  std::vector<double> missing;
  for (double f : f_hz)
    if (!m_full.contains(f)) missing.push_back(f);
  const Index before = m_full.size();
  try {
    m_full.evaluate(missing);
  } catch (const NumericalError&) {
    // A frequency at (numerically) an undamped pole of the full model: solve the others.
    for (double f : missing) {
      try {
        m_full.evaluate(f);
      } catch (const NumericalError&) {
      }
    }
  }
  refresh();
  return m_full.size() - before;
}

void EstimateEngine::refresh() {
  const WallTimer timer(m_reference_seconds, m_reference_timing);
  // Every full solve made through the cache, by anyone, enriches the reference.
  m_reference.add(m_full.take_solutions());
  if (m_reference.version() == m_version) return;
  const ReferenceCost cost(m_reference.reduced());
  m_response = std::make_unique<ReducedResponse>(m_reference.reduced());
  m_overhead_flops += cost.setup();
  m_values.clear();
  m_version = m_reference.version();
  choose_evaluation();
  // The reference's resonances only say where to sample; they converge to the full model's as the
  // reference grows, so they are recomputed when it has grown by a quarter since the last time:
  // the eigenvalues cost ~10x the Hessenberg form above, and the reference changes with almost
  // every candidate (its basis, a probe solve).
  const Index order = m_reference.order();
  if (m_pole_order > 0 && 4 * order < 5 * m_pole_order) return;
  m_pole_order = order;
  m_pole_f.clear();
  m_overhead_flops += cost.poles();
  try {
    for (const auto& [zeta, f] :
         pole_frequencies(poles(m_reference.reduced()), m_band, m_options.max_pole_samples))
      m_pole_f.push_back(f);
  } catch (const NumericalError&) {
    // No reference resonances this time: the grid and the refinement still sample the band.
  }
}

double EstimateEngine::floor_of(bool dense_lu) const {
  // In exact arithmetic the reference interpolates H wherever the full model was solved, so the
  // difference there is the rounding of the reference's own evaluation: the floor below which its
  // estimate means nothing. Measured at up to 8 solved frequencies spread over the band.
  std::vector<double> solved;
  for (double f : m_full.frequencies())
    if (f >= m_band.f_min_hz && f <= m_band.f_max_hz) solved.push_back(f);
  const std::size_t step = std::max<std::size_t>(1, solved.size() / 8);
  double floor = 0.0;
  for (std::size_t k = 0; k < solved.size(); k += step) {
    const ComplexMatrix H = m_full.evaluate(solved[k]);
    const Complex s = s_from_hz(solved[k]);
    try {
      const ComplexMatrix Href =
          dense_lu ? transfer_function(m_reference.reduced(), s) : (*m_response)(s);
      floor = std::max(
          floor, matrix_norm(Href - H, ErrorNorm::Spectral) / matrix_norm(H, ErrorNorm::Spectral));
    } catch (const NumericalError&) {
      return std::numeric_limits<double>::infinity();
    }
  }
  return floor;
}

void EstimateEngine::choose_evaluation() {
  // The O(r^2) Hessenberg path works on E_r^-1 A_r (M_r^-1 K_r): with a Euclidean-orthonormal
  // basis of a badly scaled model that loses digits. Measured on lf10 (M spanning six decades):
  // the reference at full order N = 18 differed from H by 4e-6 relative, 9 500 times the true
  // error of the candidates, and kept a 1e-6 target from being met. There the dense LU of
  // P_r(s) per frequency (O(r^3)) is used instead, when it is the more accurate of the two.
  m_dense_lu = false;
  const ReferenceCost cost(m_reference.reduced());
  const double solved = static_cast<double>(std::min<Index>(8, m_full.size()));
  m_floor = floor_of(false);
  m_overhead_flops += solved * cost.per_frequency(m_response->hessenberg());
  if (m_floor > 1e-10) {
    const double lu = floor_of(true);
    m_overhead_flops += solved * cost.per_frequency(false);
    if (lu < m_floor) {
      m_dense_lu = true;
      m_floor = lu;
    }
  }
}

void EstimateEngine::offer_basis(const Matrix& basis) {
  if (basis.rows() != m_reference.full_size() || basis.cols() == 0) return;
  const WallTimer timer(m_reference_seconds, m_reference_timing);
  m_reference.add(basis);
}

ReferenceValues EstimateEngine::values(const std::vector<double>& f_hz) {
  refresh();
  ReferenceValues out;
  out.H.resize(f_hz.size());
  out.exact.assign(f_hz.size(), 0);
  std::vector<double> exact_f;
  std::vector<std::size_t> exact_at, missing_at;
  for (std::size_t k = 0; k < f_hz.size(); ++k) {
    if (m_full.contains(f_hz[k])) {
      exact_f.push_back(f_hz[k]);
      exact_at.push_back(k);
    } else if (auto it = m_values.find(f_hz[k]); it != m_values.end()) {
      out.H[k] = it->second;
    } else {
      missing_at.push_back(k);
    }
  }
  if (!exact_f.empty()) {
    // Cached: no factorisation.
    std::vector<ComplexMatrix> H = m_full.evaluate(exact_f);
    for (std::size_t j = 0; j < exact_at.size(); ++j) {
      out.H[exact_at[j]] = std::move(H[j]);
      out.exact[exact_at[j]] = 1;
    }
  }
  m_overhead_flops +=
      static_cast<double>(missing_at.size()) *
      ReferenceCost(m_reference.reduced()).per_frequency(!m_dense_lu && m_response->hessenberg());
  const WallTimer timer(m_reference_seconds, m_reference_timing);
  const ReducedResponse& response = *m_response;
  const ReducedModel& reference = m_reference.reduced();
  // Serial for a few frequencies (the refinement's rounds): see sample() in band_error.cpp.
  const int threads = missing_at.size() < 32 ? 1 : m_full.threads();
  parallel_for(static_cast<Index>(missing_at.size()), threads, [&](Index j) {
    const std::size_t k = missing_at[static_cast<std::size_t>(j)];
    const Complex s = s_from_hz(f_hz[k]);
    try {
      out.H[k] = m_dense_lu ? transfer_function(reference, s) : response(s);
    } catch (const NumericalError&) {
      // Near a pole of the reference one path may give up where the other does not; if both
      // do, the sample is undefined (sample() in band_error.cpp marks it).
      out.H[k] = m_dense_lu ? response(s) : transfer_function(reference, s);
    }
  });
  for (std::size_t k : missing_at) m_values.emplace(f_hz[k], out.H[k]);
  return out;
}

std::vector<double> EstimateEngine::sample_set(CandidateResponse& reduced, Index* pole_count,
                                               Index* unstable) {
  refresh();
  std::vector<double> f = m_grid;
  f.insert(f.end(), m_pole_f.begin(), m_pole_f.end());
  *pole_count = static_cast<Index>(m_pole_f.size());
  *unstable = -1;
  if (m_options.pole_samples) {
    try {
      const ComplexVector& p = reduced.poles();
      *unstable = unstable_count(p);
      for (const auto& [zeta, fp] : pole_frequencies(p, m_band, m_options.max_pole_samples)) {
        f.push_back(fp);
        ++*pole_count;
      }
    } catch (const NumericalError&) {
      // The candidate's poles are unknown: its resonances are still found by the refinement.
    }
  }
  for (double fc : m_full.frequencies())
    if (fc >= m_band.f_min_hz && fc <= m_band.f_max_hz) f.push_back(fc);
  return f;
}

BandError EstimateEngine::assemble(CandidateResponse& reduced, std::vector<double> f_hz, Index grid,
                                   Index poles, bool refine, bool dense_peaks) {
  const ReferenceSource source = [this](const std::vector<double>& f) { return values(f); };
  BandError e =
      assemble_band_error(reduced, std::move(f_hz), SamplingPlan{grid, poles, refine, dense_peaks},
                          {source, m_options, m_band, m_scale2, m_scaleF, m_full.threads()});
  e.reference_order = m_reference.order();
  return e;
}

void EstimateEngine::finish(BandError& e, bool certify,
                            const std::map<double, double>& estimate_before,
                            Index new_solves) const {
  double sup_exact = -1.0, sup_estimate = -1.0, f_exact = 0.0;
  Index checked = 0;
  for (std::size_t k = 0; k < e.f_hz.size(); ++k) {
    const double r = value_or_minus_one(e.relative[k]);
    if (e.exact[k]) {
      ++checked;
      if (r > sup_exact) {
        sup_exact = r;
        f_exact = e.f_hz[k];
      }
    } else {
      sup_estimate = std::max(sup_estimate, r);
    }
  }
  e.checked_samples = checked;
  e.reference_floor = m_floor;
  e.new_full_solves = new_solves;
  e.estimate_sup = sup_estimate >= 0.0 ? sup_estimate : std::numeric_limits<double>::quiet_NaN();
  if (certify && sup_exact >= 0.0) {
    // Reported: the largest error against the full model's own H, never an estimate.
    e.sup_relative = sup_exact;
    e.f_peak_hz = f_exact;
    e.estimated = false;
  } else {
    e.estimated = sup_estimate > sup_exact;
  }
  std::vector<double> ratios;
  for (const auto& [f, estimate] : estimate_before) {
    const std::ptrdiff_t i = index_of(e, f);
    if (i < 0 || !e.exact[static_cast<std::size_t>(i)]) continue;
    const double truth = e.relative[static_cast<std::size_t>(i)];
    if (truth > 0.0 && std::isfinite(truth) && std::isfinite(estimate))
      ratios.push_back(estimate / truth);
  }
  e.effectivity_count = static_cast<Index>(ratios.size());
  if (!ratios.empty()) {
    std::sort(ratios.begin(), ratios.end());
    e.effectivity_min = ratios.front();
    e.effectivity_max = ratios.back();
    e.effectivity_median = ratios[ratios.size() / 2];
  }
}

BandError EstimateEngine::evaluate(const ReducedModel& model) {
  CandidateResponse reduced(model);
  std::map<double, double> before;
  Index solves = 0;
  Index pole_count = 0, unstable = -1;
  BandError e;
  for (Index round = 0;; ++round) {
    std::vector<double> f = sample_set(reduced, &pole_count, &unstable);
    e = assemble(reduced, std::move(f), static_cast<Index>(m_grid.size()), pole_count, true, false);
    if (round >= m_options.probe_solves) break;
    const std::ptrdiff_t i = index_of(e, e.f_peak_hz);
    if (i < 0 || e.exact[static_cast<std::size_t>(i)] || !std::isfinite(e.sup_relative)) break;
    before[e.f_peak_hz] = e.sup_relative;
    const Index added = solve_full({e.f_peak_hz});
    if (added == 0) break;
    solves += added;
  }
  finish(e, false, before, solves);
  e.unstable_poles = unstable;
  return e;
}

BandError EstimateEngine::evaluate_on(const ReducedModel& model, const std::vector<double>& f_hz) {
  CandidateResponse reduced(model);
  BandError e = assemble(reduced, f_hz, static_cast<Index>(f_hz.size()), 0, false, false);
  finish(e, false, {}, 0);
  return e;
}

BandError EstimateEngine::verify(const ReducedModel& model) {
  CandidateResponse reduced(model);
  std::map<double, double> before;
  Index solves = 0;
  Index pole_count = 0, unstable = -1;
  // A few log-uniform random frequencies per re-check: checks the estimate where nothing points.
  std::vector<double> random;
  std::uniform_real_distribution<double> uniform(std::log(m_band.f_min_hz),
                                                 std::log(m_band.f_max_hz));
  for (Index k = 0; k < m_options.random_checks; ++k) random.push_back(std::exp(uniform(m_rng)));
  for (Index round = 0; round < m_options.check_rounds; ++round) {
    std::vector<double> f = sample_set(reduced, &pole_count, &unstable);
    if (round == 0) f.insert(f.end(), random.begin(), random.end());
    const BandError e =
        assemble(reduced, std::move(f), static_cast<Index>(m_grid.size()), pole_count, true, false);
    std::vector<double> check;
    auto consider = [&](double fc) {
      const std::ptrdiff_t i = index_of(e, fc);
      if (i < 0 || e.exact[static_cast<std::size_t>(i)]) return;
      if (before.count(fc)) return;
      before[fc] = e.relative[static_cast<std::size_t>(i)];
      check.push_back(fc);
    };
    // Round 0 solves the random set and the largest local maxima whatever their values; later
    // rounds (the estimate has changed with the solves) only maxima above the largest error
    // already measured against the full model: only they could change the reported value.
    double measured = -1.0;
    for (std::size_t k = 0; k < e.f_hz.size(); ++k)
      if (e.exact[k]) measured = std::max(measured, value_or_minus_one(e.relative[k]));
    if (round == 0)
      for (double fc : random) consider(fc);
    for (double fc : largest_local_maxima_hz(e, m_options.check_peaks)) {
      const std::ptrdiff_t i = index_of(e, fc);
      if (round == 0 || (i >= 0 && e.relative[static_cast<std::size_t>(i)] > measured))
        consider(fc);
    }
    if (check.empty()) break;
    solves += solve_full(check);
  }
  std::vector<double> f = sample_set(reduced, &pole_count, &unstable);
  BandError e =
      assemble(reduced, std::move(f), static_cast<Index>(m_grid.size()), pole_count, true, true);
  finish(e, true, before, solves);
  e.unstable_poles = unstable;
  return e;
}

BandError EstimateEngine::verify_at(const ReducedModel& model, const std::vector<double>& solve) {
  CandidateResponse reduced(model);
  const Index solves = solve_full(solve);
  Index pole_count = 0, unstable = -1;
  std::vector<double> f = sample_set(reduced, &pole_count, &unstable);
  BandError e =
      assemble(reduced, std::move(f), static_cast<Index>(m_grid.size()), pole_count, true, true);
  finish(e, true, {}, solves);
  e.unstable_poles = unstable;
  return e;
}

}  // namespace ecmor::detail
