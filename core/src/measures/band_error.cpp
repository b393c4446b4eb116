#include "ecmor/measures/band_error.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <numeric>
#include <sstream>

#include "base/parallel_for.hpp"
#include "base/wall_timer.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/threads.hpp"
#include "ecmor/linalg/parallel.hpp"
#include "ecmor/response/reduced_response.hpp"
#include "measures/band_error_estimate.hpp"
#include "measures/band_error_sampling.hpp"

namespace ecmor {

double matrix_norm(const ComplexMatrix& A, ErrorNorm norm) {
  if (A.size() == 0) return 0.0;
  if (norm == ErrorNorm::Frobenius || A.rows() == 1 || A.cols() == 1) {
    // For a single row or column the spectral norm is the Euclidean norm.
    return A.norm();
  }
  Eigen::JacobiSVD<ComplexMatrix> svd(A);
  return svd.singularValues()(0);
}

std::string BandError::sampling() const {
  std::ostringstream os;
  os << grid_samples << " grid";
  if (pole_samples > 0) os << " + " << pole_samples << " pole";
  if (refinement_samples > 0) os << " + " << refinement_samples << " refinement";
  if (!undefined_f_hz.empty()) os << "; H vanishes at " << undefined_f_hz.size() << " samples";
  if (reference_order > 0) {
    os << "; estimate (reference order " << reference_order << "), " << checked_samples
       << " checked by full solves";
    if (new_full_solves > 0) os << " (" << new_full_solves << " new)";
  }
  return os.str();
}

bool BandError::within(double tolerance) const {
  return sup_relative <= tolerance && !(estimate_sup > tolerance);
}

namespace {

// Error measures at one frequency.
struct Sample {
  double f_hz = 0.0;
  double abs2 = 0.0;      // ||H - Hr||_2
  double absF = 0.0;      // ||H - Hr||_F
  double ref2 = 0.0;      // ||H||_2
  double refF = 0.0;      // ||H||_F
  bool singular = false;  // Hr has a pole exactly here
  bool exact = true;      // H is the full model's own (not a reference model's estimate)
  ComplexMatrix H;        // the reference side (empty where the full model is singular)
};

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Samples the error at the given frequencies (the reference side from `source`, the reduced
// model's and the error norms in parallel with `threads`).
std::vector<Sample> sample(const detail::ReferenceSource& source,
                           detail::CandidateResponse& candidate, const std::vector<double>& f_hz,
                           int threads_wanted) {
  std::vector<Sample> out(f_hz.size());
  if (f_hz.empty()) return out;
  detail::ReferenceValues ref;
  std::vector<bool> full_singular(f_hz.size(), false);
  try {
    ref = source(f_hz);
  } catch (const NumericalError&) {
    // Some frequency is (numerically) a pole of the full model on the imaginary axis (an undamped
    // mode): evaluate one by one and mark those samples, instead of failing the whole batch.
    ref.H.assign(f_hz.size(), ComplexMatrix());
    ref.exact.assign(f_hz.size(), 1);
    for (std::size_t k = 0; k < f_hz.size(); ++k) {
      try {
        detail::ReferenceValues one = source({f_hz[k]});
        ref.H[k] = std::move(one.H[0]);
        ref.exact[k] = one.exact[0];
      } catch (const NumericalError&) {
        full_singular[k] = true;
      }
    }
  }
  // The candidate's values computed before in this evaluation are reused; the others are computed
  // below (in parallel) and kept afterwards (serially: the cache is not thread-safe).
  const ReducedResponse& reduced = candidate.response();
  std::vector<std::optional<ComplexMatrix>> known(f_hz.size());
  std::vector<char> was_known(f_hz.size(), 0);
  for (std::size_t k = 0; k < f_hz.size(); ++k) {
    if (const auto* v = candidate.find(f_hz[k])) {
      known[k] = *v;
      was_known[k] = 1;
    }
  }
  auto evaluate = [&](std::size_t k) {
    Sample& s = out[k];
    s.f_hz = f_hz[k];
    s.exact = ref.exact[k] != 0;
    if (full_singular[k]) {
      // |H| is unbounded here: the relative error is undefined (reported as such).
      s.ref2 = s.refF = kInf;
      s.abs2 = s.absF = kNaN;
      return;
    }
    s.H = std::move(ref.H[k]);
    s.ref2 = matrix_norm(s.H, ErrorNorm::Spectral);
    s.refF = s.H.norm();
    try {
      if (!was_known[k]) {
        try {
          known[k] = reduced(s_from_hz(f_hz[k]));
        } catch (const NumericalError&) {
          known[k].reset();  // a pole of the reduced model: kept as such
        }
      }
      if (!known[k]) throw NumericalError("reduced model: a pole");
      const ComplexMatrix E = s.H - *known[k];
      if (!E.allFinite()) throw NumericalError("non-finite reduced response");
      s.abs2 = matrix_norm(E, ErrorNorm::Spectral);
      s.absF = E.norm();
    } catch (const NumericalError&) {
      // f is (numerically) a pole of the reduced model on the imaginary axis: the error is
      // unbounded there, which is what the supremum must report.
      s.singular = true;
      s.abs2 = s.absF = kInf;
    }
  };
  // The reduced evaluations are independent across frequencies, like the full model's: the same
  // threads share them (each sample is computed by one thread with the same code, so the result
  // does not depend on the thread count, bitwise). A parallel region costs more (thread wake-up,
  // then spinning at the barrier) than a few reduced evaluations: measured on cdplayer in estimate
  // mode, where the refinement samples a handful of frequencies per round, 65 % of the run was
  // OpenMP spinning with regions for as few as 4 samples. Below 32 samples the loop is serial.
  // Anything but the NumericalError handled per sample (say, bad_alloc) leaves through
  // parallel_for, which carries it out of the parallel region.
  const auto count = static_cast<Index>(f_hz.size());
  detail::parallel_for(count, count < 32 ? 1 : threads_wanted,
                       [&](Index k) { evaluate(static_cast<std::size_t>(k)); });
  for (std::size_t k = 0; k < f_hz.size(); ++k)
    if (!was_known[k]) candidate.keep(f_hz[k], std::move(known[k]));
  return out;
}

double relative_of(const Sample& s, ErrorNorm norm, double zero_level2, double zero_levelF) {
  if (norm == ErrorNorm::Spectral) {
    return (s.ref2 <= zero_level2 || std::isinf(s.ref2)) ? kNaN : s.abs2 / s.ref2;
  }
  return (s.refF <= zero_levelF || std::isinf(s.refF)) ? kNaN : s.absF / s.refF;
}

}  // namespace

std::vector<double> largest_local_maxima_hz(const BandError& error, Index count, double above) {
  const std::vector<double>& r = error.relative;
  auto val = [&](std::size_t i) { return std::isnan(r[i]) ? -1.0 : r[i]; };
  std::vector<std::size_t> peaks;
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (val(i) < 0.0 || !(val(i) > above)) continue;
    const bool left = i == 0 || val(i - 1) <= val(i);
    const bool right = i + 1 == r.size() || val(i + 1) < val(i);
    if (left && right) peaks.push_back(i);
  }
  std::stable_sort(peaks.begin(), peaks.end(),
                   [&](std::size_t a, std::size_t b) { return val(a) > val(b); });
  std::vector<double> f;
  for (std::size_t j = 0; j < peaks.size() && static_cast<Index>(j) < count; ++j)
    f.push_back(error.f_hz[peaks[j]]);
  return f;
}

namespace detail {

std::vector<std::pair<double, double>> pole_frequencies(const ComplexVector& p, const Band& band,
                                                        Index max) {
  std::vector<std::pair<double, double>> candidates;  // (damping ratio, f)
  for (Index i = 0; i < p.size(); ++i) {
    const double im = p(i).imag();
    if (!(im > 0.0) || !std::isfinite(im)) continue;
    const double fp = im / kTwoPi;
    if (fp < band.f_min_hz || fp > band.f_max_hz) continue;
    const double zeta = std::abs(p(i).real()) / std::abs(p(i));
    // A (numerically) undamped pole: Hr, and near it H, are singular to working precision at
    // Im(p); a sample there measures round-off, not the error. The grid and the refinement
    // still see the resonance.
    if (zeta < 1e-8) continue;
    candidates.emplace_back(zeta, fp);
  }
  std::sort(candidates.begin(), candidates.end());
  if (static_cast<Index>(candidates.size()) > max) candidates.resize(static_cast<std::size_t>(max));
  return candidates;
}

Index unstable_count(const ComplexVector& p) {
  Index unstable = 0;
  for (Index i = 0; i < p.size(); ++i) unstable += p(i).real() < 0.0 ? 0 : 1;
  return unstable;
}

const ComplexVector& CandidateResponse::poles() {
  if (!m_poles) m_poles = ecmor::poles(m_model);
  return *m_poles;
}

namespace {

// The relative error of a sample in the options' norm as the refinement and the re-check rank
// samples: where it is undefined (H vanishes), below every number.
struct Ranking {
  ErrorNorm norm = ErrorNorm::Spectral;
  double zero2 = 0.0;  // ||H||_2 at or below which H counts as vanishing
  double zeroF = 0.0;  // the same for ||H||_F
  double operator()(const Sample& s) const {
    const double r = relative_of(s, norm, zero2, zeroF);
    return std::isnan(r) ? -1.0 : r;
  }
};

// A peak's golden-section search in log f.
struct Bracket {
  double a, c, b;  // log f; c is the best point so far
  Sample best;
  Index stalled = 0;  // consecutive steps without a relative gain above 1e-4
};

// The brackets around the largest finite local maxima of the relative error on the sorted
// samples, at most max_peaks of them, largest first.
std::vector<Bracket> peak_brackets(const std::vector<Sample>& samples, const Ranking& rel,
                                   Index max_peaks) {
  std::vector<std::size_t> peaks;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double r = rel(samples[i]);
    if (r < 0.0 || std::isinf(r)) continue;
    const bool left_ok = (i == 0) || rel(samples[i - 1]) <= r;
    const bool right_ok = (i + 1 == samples.size()) || rel(samples[i + 1]) < r;
    if (left_ok && right_ok) peaks.push_back(i);
  }
  std::sort(peaks.begin(), peaks.end(),
            [&](std::size_t a, std::size_t b) { return rel(samples[a]) > rel(samples[b]); });
  if (static_cast<Index>(peaks.size()) > max_peaks) {
    peaks.resize(static_cast<std::size_t>(max_peaks));
  }
  std::vector<Bracket> brackets;
  for (std::size_t i : peaks) {
    const double c = std::log(samples[i].f_hz);
    const double a = i == 0 ? c : std::log(samples[i - 1].f_hz);
    const double b = i + 1 == samples.size() ? c : std::log(samples[i + 1].f_hz);
    if (b - a > 0.0) brackets.push_back({a, c, b, samples[i], 0});
  }
  return brackets;
}

// One golden-section step of a bracket with the sample `got` at x = log f. Returns false when the
// peak is done: the bracket is below 1e-9 relative in f (far below any resonance width) or its
// value has stopped rising for 6 steps; one still rising near a zero of H or an undamped pole goes
// on to the budget, so that a sharp peak is not under-reported.
bool golden_step(Bracket& br, double x, const Sample& got, const Ranking& rel) {
  const double before = rel(br.best);
  br.stalled = rel(got) > before * (1.0 + 1e-4) ? 0 : br.stalled + 1;
  if (rel(got) > before) {
    // New best: the old centre becomes a bracket end.
    if (x > br.c)
      br.a = br.c;
    else
      br.b = br.c;
    br.c = x;
    br.best = got;
  } else {
    if (x > br.c)
      br.b = x;
    else
      br.a = x;
  }
  return br.b - br.a > 1e-9 && br.stalled < 6;
}

// Refines the largest local maxima of the relative error by golden-section search in log f, all
// peaks advanced together so that each round's new full-model frequencies are evaluated in one
// parallel batch. The new samples join `samples` (sorted by frequency again); returns their count.
Index refine_peaks(std::vector<Sample>& samples, CandidateResponse& candidate,
                   const Comparison& with, const Ranking& rel) {
  std::vector<Bracket> brackets = peak_brackets(samples, rel, with.options.refine_peaks);
  constexpr double kGolden = 0.3819660112501051;  // 2 - golden ratio
  std::vector<Sample> added;
  for (Index round = 0; round < with.options.refine_evaluations && !brackets.empty(); ++round) {
    std::vector<double> trial(brackets.size());
    for (std::size_t j = 0; j < brackets.size(); ++j) {
      Bracket& br = brackets[j];
      // Probe the larger side of c.
      trial[j] = (br.b - br.c > br.c - br.a) ? br.c + kGolden * (br.b - br.c)
                                             : br.c - kGolden * (br.c - br.a);
    }
    std::vector<double> trial_f(trial.size());
    std::transform(trial.begin(), trial.end(), trial_f.begin(),
                   [](double x) { return std::exp(x); });
    const std::vector<Sample> got = sample(with.source, candidate, trial_f, with.threads);
    std::vector<Bracket> next;
    for (std::size_t j = 0; j < brackets.size(); ++j) {
      Bracket br = brackets[j];
      added.push_back(got[j]);
      if (golden_step(br, trial[j], got[j], rel)) next.push_back(br);
    }
    brackets = std::move(next);
  }
  samples.insert(samples.end(), added.begin(), added.end());
  std::sort(samples.begin(), samples.end(),
            [](const Sample& x, const Sample& y) { return x.f_hz < y.f_hz; });
  return static_cast<Index>(added.size());
}

// The re-check must not rest on the fast path alone: the ten largest errors are evaluated again
// with a dense LU of P_r(s) (transfer_function), an independent computation of Hr, and the larger
// of the two kept.
void recheck_largest_by_dense_lu(std::vector<Sample>& samples, const ReducedModel& reduced,
                                 const Ranking& rel) {
  std::vector<std::size_t> order(samples.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const std::size_t top = std::min<std::size_t>(samples.size(), 10);
  std::partial_sort(
      order.begin(), order.begin() + static_cast<std::ptrdiff_t>(top), order.end(),
      [&](std::size_t a, std::size_t b) { return rel(samples[a]) > rel(samples[b]); });
  for (std::size_t j = 0; j < top; ++j) {
    Sample& s = samples[order[j]];
    if (s.singular || std::isinf(s.ref2) || s.H.size() == 0) continue;
    try {
      const ComplexMatrix E = s.H - transfer_function(reduced, s_from_hz(s.f_hz));
      s.abs2 = std::max(s.abs2, matrix_norm(E, ErrorNorm::Spectral));
      s.absF = std::max(s.absF, E.norm());
    } catch (const NumericalError&) {
      s.singular = true;
      s.abs2 = s.absF = kInf;
    }
  }
}

// The band H2 norm of the error, sqrt(2 * integral_{f_min}^{f_max} ||H - Hr||_F^2 df) (both signs
// of omega: twice the integral over positive f), by the trapezoidal rule in f on the samples
// (sorted by frequency). It costs no evaluation beyond the samples the supremum needs;
// h2_error_quadrature (h2_norm.hpp) computes the same norm to a tolerance with full solves of its
// own.
double band_h2_by_trapezoid(const std::vector<Sample>& samples) {
  double h2sq = 0.0;
  for (std::size_t k = 1; k < samples.size(); ++k) {
    const double a = samples[k - 1].absF, b = samples[k].absF;
    if (!std::isnan(a) && !std::isnan(b)) {
      h2sq += 0.5 * (a * a + b * b) * (samples[k].f_hz - samples[k - 1].f_hz);
    }
  }
  return std::sqrt(2.0 * h2sq);
}

// The BandError of the samples (sorted by frequency): the errors at each, the supremum of the
// relative error and the band H-infinity norm of the error with where they are, the band H2 norm.
// \throws NumericalError when H vanishes at every sample.
BandError assembled(const std::vector<Sample>& samples, const Ranking& rel, const Band& band) {
  BandError out;
  out.norm = rel.norm;
  const std::size_t n = samples.size();
  out.f_hz.resize(n);
  out.relative.resize(n);
  out.relative_spectral.resize(n);
  out.relative_frobenius.resize(n);
  out.absolute.resize(n);
  out.reference.resize(n);
  out.exact.resize(n);
  double sup = -1.0, hinf = -1.0;
  for (std::size_t k = 0; k < n; ++k) {
    const Sample& s = samples[k];
    out.f_hz[k] = s.f_hz;
    out.relative_spectral[k] = relative_of(s, ErrorNorm::Spectral, rel.zero2, rel.zeroF);
    out.relative_frobenius[k] = relative_of(s, ErrorNorm::Frobenius, rel.zero2, rel.zeroF);
    out.relative[k] =
        rel.norm == ErrorNorm::Spectral ? out.relative_spectral[k] : out.relative_frobenius[k];
    out.absolute[k] = s.abs2;
    out.reference[k] = s.ref2;
    out.exact[k] = s.exact ? 1 : 0;
    out.reduced_singular = out.reduced_singular || s.singular;
    if (std::isnan(out.relative[k])) {
      out.undefined_f_hz.push_back(s.f_hz);
    } else if (out.relative[k] > sup) {
      sup = out.relative[k];
      out.f_peak_hz = s.f_hz;
    }
    if (!std::isnan(s.abs2) && s.abs2 > hinf) {
      hinf = s.abs2;
      out.f_hinf_hz = s.f_hz;
    }
  }
  if (sup < 0.0) {
    throw NumericalError("band error: H vanishes at every sampled frequency of the band [" +
                         std::to_string(band.f_min_hz) + ", " + std::to_string(band.f_max_hz) +
                         "] Hz: the relative error is undefined");
  }
  out.sup_relative = sup;
  out.hinf_absolute = hinf;
  out.h2_absolute = band_h2_by_trapezoid(samples);
  return out;
}

}  // namespace

BandError assemble_band_error(CandidateResponse& candidate, std::vector<double> f_hz,
                              const SamplingPlan& plan, const Comparison& with) {
  std::sort(f_hz.begin(), f_hz.end());
  f_hz.erase(std::unique(f_hz.begin(), f_hz.end()), f_hz.end());
  std::vector<Sample> samples = sample(with.source, candidate, f_hz, with.threads);
  const BandErrorOptions& options = with.options;
  const Ranking rel{options.norm, options.zero_threshold * with.scale2,
                    options.zero_threshold * with.scaleF};
  Index refinement_count = 0;
  if (plan.refine && options.refine_peaks > 0 && options.refine_evaluations > 0 &&
      samples.size() >= 3) {
    refinement_count = refine_peaks(samples, candidate, with, rel);
  }
  if (plan.dense_peaks && !samples.empty()) {
    recheck_largest_by_dense_lu(samples, candidate.model(), rel);
  }
  BandError out = assembled(samples, rel, with.band);
  out.grid_samples = plan.grid;
  out.pole_samples = plan.poles;
  out.refinement_samples = refinement_count;
  return out;
}

}  // namespace detail

BandErrorEstimator::BandErrorEstimator(ResponseCache& full, Band band, BandErrorOptions options)
    : m_full(full), m_band(band), m_options(options) {
  const detail::WallTimer timer(m_seconds, m_timing);
  m_band.validate();
  m_options.validate();
  m_grid = log_grid(m_band.f_min_hz, m_band.f_max_hz, m_options.grid_points);
  const bool estimate =
      m_options.verify == ErrorVerify::Estimate ||
      (m_options.verify == ErrorVerify::Auto && size_of(full.model()) > m_options.dense_max_states);
  if (estimate) {
    m_engine = std::make_unique<detail::EstimateEngine>(m_full, m_band, m_options);
    return;
  }
  start_dense();
}

void BandErrorEstimator::start_dense() {
  m_scale2 = 0.0;
  m_scaleF = 0.0;
  for (const ComplexMatrix& H : m_full.evaluate(m_grid)) {
    m_scale2 = std::max(m_scale2, matrix_norm(H, ErrorNorm::Spectral));
    m_scaleF = std::max(m_scaleF, H.norm());
  }
}

double BandErrorEstimator::cost_per_full_solve() const {
  if (m_full.size() == 0 || !(m_full.flops() > 0.0)) return 0.0;
  // A sparse factorisation costs more than its flops: per column, a pivot search and memory
  // management that the flop counts leave out (perf on triplechain_saak09_n451, dense mode:
  // UMFPACK's assembly, pivot search, kernel set-up and page faults). Measured on the shipped
  // chains (N = 451..1 501), a full solve took 0.7-2.2 us per unknown beyond its flops, while the
  // reference model's dense kernels ran at 2-14 GFlop/s: about 10 000 flops of reference work
  // per unknown. On 3-D solids the flops dominate by orders of magnitude.
  constexpr double kFlopsPerUnknown = 1.0e4;
  return m_full.flops() / static_cast<double>(m_full.size()) +
         kFlopsPerUnknown * static_cast<double>(size_of(m_full.model()));
}

double BandErrorEstimator::dense_purchase(double per_solve, Index verify_factor) const {
  // The dense mode's one-off cost: its grid and a re-check grid `verify_factor` times denser.
  return static_cast<double>(m_options.grid_points + verify_factor * (m_options.grid_points - 1) +
                             2) *
         per_solve;
}

void BandErrorEstimator::consider_switch(Index verify_factor) {
  ++m_evaluations;
  if (!m_engine || m_options.verify != ErrorVerify::Auto) return;
  // Ski rental. Per evaluation the estimate pays its reference model (its reduced forms, poles
  // and values: the overhead) and the dense mode would pay full solves at the candidate's pole
  // and refinement samples; the dense mode also pays its grid and a re-check grid once. The
  // estimate's excess over the dense mode's per-evaluation cost accumulates as "rent"; when it
  // reaches the one-off "purchase" the run switches. That costs at most about twice the better
  // of the two choices made in hindsight, whatever the length of the run. A full solve of a large
  // model costs seconds and its reference milliseconds: such runs never switch; small models of
  // high order, whose reference costs more than their full solves, do.
  //
  // Both sides are counted in floating-point operations, not timed: the solver's own counts for
  // the full solves (with a per-unknown overhead, cost_per_full_solve), the operation counts of
  // the dense kernels for the reference. Times would
  // make the choice, and with it the run's samples and counts, depend on what else the machine
  // is doing (measured: the same portfolio run switched on a loaded CI machine and not on an idle
  // one). A backend that reports no counts never switches.
  const double per_solve = cost_per_full_solve();
  if (!(per_solve > 0.0)) return;
  const double buy = dense_purchase(per_solve, verify_factor);
  const double dense_samples = buy / per_solve;
  // Collective: under MPI every rank must take the same mode (the full solves are collective).
  if (!any_process(m_rent_flops > buy)) return;
  use_dense(fmt::format(
      "estimate, then dense from evaluation {}: the reference model had cost {:.3g} flops more "
      "than the dense mode's full solves at the same samples, over the {:.3g} predicted for its "
      "grids ({:.0f} full solves at {:.3g} flops)",
      m_evaluations, m_rent_flops, buy, dense_samples, per_solve));
}

bool BandErrorEstimator::escalate(const std::string& why) {
  if (!m_engine) return false;
  const detail::WallTimer timer(m_seconds, m_timing);
  const double per_solve = cost_per_full_solve();
  const double buy = dense_purchase(per_solve, 4);
  const double spent = static_cast<double>(m_full.size()) * per_solve + m_engine->overhead_flops();
  // Affordable: no more than the run has spent so far, or a few seconds of work (1e10 flops at the
  // 2-14 GFlop/s of cost_per_full_solve's measurement) whatever it spent: a small model's run.
  constexpr double kAffordableFlops = 1e10;
  const double affordable = std::max(spent, kAffordableFlops);
  const bool counted = m_options.verify == ErrorVerify::Auto && per_solve > 0.0;
  if (counted && any_process(buy <= affordable)) {
    use_dense(
        fmt::format("estimate, then dense from evaluation {}: {} in the estimate mode, and "
                    "the dense mode's grids ({:.3g} flops) cost no more than {:.3g} (the "
                    "run had spent {:.3g})",
                    m_evaluations, why, buy, affordable, spent));
    return true;
  }
  const Index probes = m_engine->probe_solves();
  if (probes == 0 || !m_escalation_note.empty()) return false;
  m_engine->set_probe_solves(probes + kEscalatedProbes);
  m_escalation_note = fmt::format(
      "from evaluation {}: {}; probe_solves {} -> {}{}", m_evaluations, why, probes,
      probes + kEscalatedProbes,
      counted ? fmt::format(" (the dense mode's grids, {:.3g} flops, cost more than {:.3g})", buy,
                            affordable)
              : std::string());
  return true;
}

void BandErrorEstimator::use_dense(std::string reason) {
  if (!m_engine) return;
  const detail::WallTimer timer(m_seconds, m_timing);
  m_switch_note = std::move(reason);
  m_reference_seconds_before = m_engine->reference_seconds();
  m_full.keep_solutions(false);
  (void)m_full.take_solutions();  // the reference model's food; without it, memory
  m_engine.reset();
  start_dense();
}

BandError BandErrorEstimator::rented(BandError e, double overhead_before) {
  const double dense = static_cast<double>(e.pole_samples + e.refinement_samples);
  m_rent_flops += (m_engine->overhead_flops() - overhead_before) - dense * cost_per_full_solve();
  return e;
}

BandErrorEstimator::~BandErrorEstimator() = default;

void BandErrorEstimator::offer_basis(const Matrix& basis) {
  const detail::WallTimer timer(m_seconds, m_timing);
  if (m_engine) m_engine->offer_basis(basis);
}

double BandErrorEstimator::reference_seconds() const {
  return m_reference_seconds_before + (m_engine ? m_engine->reference_seconds() : 0.0);
}

Index BandErrorEstimator::reference_order() const {
  return m_engine ? m_engine->reference().order() : 0;
}

detail::ReferenceSource BandErrorEstimator::full_source() {
  return [this](const std::vector<double>& f) {
    detail::ReferenceValues v;
    v.H = m_full.evaluate(f);
    v.exact.assign(f.size(), 1);
    return v;
  };
}

BandError BandErrorEstimator::assemble(const ReducedModel& reduced, std::vector<double> f_hz,
                                       Index grid, Index pole_count, bool refine,
                                       bool dense_peaks) {
  const Index before = m_full.size();
  detail::CandidateResponse candidate(reduced);
  BandError out = detail::assemble_band_error(
      candidate, std::move(f_hz), detail::SamplingPlan{grid, pole_count, refine, dense_peaks},
      {full_source(), m_options, m_band, m_scale2, m_scaleF, m_full.threads()});
  out.checked_samples = static_cast<Index>(out.f_hz.size());
  out.new_full_solves = m_full.size() - before;
  return out;
}

BandError BandErrorEstimator::evaluate(const ReducedModel& reduced) {
  const detail::WallTimer timer(m_seconds, m_timing);
  consider_switch(4);
  if (m_engine) {
    const double overhead = m_engine->overhead_flops();
    return rented(m_engine->evaluate(reduced), overhead);
  }
  std::vector<double> f = m_grid;
  Index pole_count = 0;
  Index unstable = -1;
  if (m_options.pole_samples && m_options.max_pole_samples > 0) {
    // Resonances of lightly damped structures are narrower than any affordable grid spacing; the
    // reduced poles locate them (and the full model's nearby ones) at no full-model cost.
    const ComplexVector p = poles(reduced);
    unstable = detail::unstable_count(p);
    // Successive reduced models of one run (a grown model, a pruned one, an optimiser's next
    // trial) approximate the same resonances, but their poles agree only to the accuracy of the
    // approximation, often 1e-4 relative: sampled exactly at Im(p), every model would cost its own
    // full-model factorisations. So a pole sample reuses a frequency already in the response cache
    // when one lies within zeta / 32 (relative) of Im(p), a small fraction of the resonance's
    // relative width 2 zeta: there |H| near an isolated resonance is within 0.05 % of its value at
    // Im(p) (1 / sqrt(1 + (1/32)^2)), and the refinement of the error's local maxima runs on top.
    // Otherwise the sample is taken exactly at Im(p) (and cached for the next model).
    for (const auto& [zeta, f_pole] :
         detail::pole_frequencies(p, m_band, m_options.max_pole_samples)) {
      double fp = f_pole;
      if (const auto near = m_full.nearest_cached(fp, zeta / 32.0)) fp = *near;
      f.push_back(fp);
      ++pole_count;
    }
  }
  BandError out =
      assemble(reduced, std::move(f), static_cast<Index>(m_grid.size()), pole_count, true, false);
  out.unstable_poles = unstable;
  return out;
}

BandError BandErrorEstimator::evaluate_on(const ReducedModel& reduced,
                                          const std::vector<double>& f_hz) {
  const detail::WallTimer timer(m_seconds, m_timing);
  consider_switch(4);
  if (m_engine) {
    const double overhead = m_engine->overhead_flops();
    return rented(m_engine->evaluate_on(reduced, f_hz), overhead);
  }
  return assemble(reduced, f_hz, static_cast<Index>(f_hz.size()), 0, false, false);
}

std::vector<double> BandErrorEstimator::verify_grid(Index factor) const {
  // Midpoints (in log f) of a grid `factor` times finer than the estimator's: with
  // M = factor (G - 1) intervals, (k + 1/2)/M = j/(G - 1) would need an odd number to equal an even
  // one, so no point coincides with the estimator's grid. The band edges are added: the supremum
  // may sit there.
  const Index G = m_options.grid_points;
  const Index M = factor * (G - 1);
  const double x0 = std::log(m_band.f_min_hz), x1 = std::log(m_band.f_max_hz);
  std::vector<double> f;
  f.reserve(static_cast<std::size_t>(M + 2));
  f.push_back(m_band.f_min_hz);
  for (Index k = 0; k < M; ++k) {
    f.push_back(std::exp(x0 + (static_cast<double>(k) + 0.5) * (x1 - x0) / static_cast<double>(M)));
  }
  f.push_back(m_band.f_max_hz);
  return f;
}

BandError BandErrorEstimator::verify(const ReducedModel& reduced, Index factor) {
  if (factor < 1) throw ConfigError("verify factor = " + std::to_string(factor) + ": must be >= 1");
  const detail::WallTimer timer(m_seconds, m_timing);
  consider_switch(factor);
  if (m_engine) {
    const double overhead = m_engine->overhead_flops();
    return rented(m_engine->verify(reduced), overhead);
  }
  std::vector<double> f = verify_grid(factor);
  const auto grid = static_cast<Index>(f.size());
  return assemble(reduced, std::move(f), grid, 0, true, true);
}

BandError BandErrorEstimator::verify_near(const ReducedModel& reduced,
                                          const ReducedModel& neighbour, double neighbour_error,
                                          double tolerance, Index factor, Index max_new_solves) {
  if (factor < 1) throw ConfigError("verify factor = " + std::to_string(factor) + ": must be >= 1");
  if (max_new_solves < 0)
    throw ConfigError("max_new_solves = " + std::to_string(max_new_solves) + ": must be >= 0");
  if (!(tolerance > 0.0))
    throw ConfigError("tolerance = " + std::to_string(tolerance) + ": must be > 0");
  const detail::WallTimer timer(m_seconds, m_timing);
  consider_switch(factor);
  std::vector<double> f = verify_grid(factor);
  const auto grid = static_cast<Index>(f.size());

  // The departure from the neighbour, at the reduced level only: the neighbour stands where the
  // full model stands in verify(), refinement included. Its local maxima sit at the two models'
  // resonances: the options' grid and both models' pole frequencies in the band locate them.
  std::vector<double> near_f = m_grid;
  for (const ReducedModel* m : {&reduced, &neighbour}) {
    try {
      for (const auto& [zeta, fp] :
           detail::pole_frequencies(poles(*m), m_band, m_options.max_pole_samples))
        near_f.push_back(fp);
    } catch (const NumericalError&) {
      // Its poles unknown: the grid and the refinement still see its resonances.
    }
  }
  const ReducedResponse near(neighbour);
  const detail::ReferenceSource source = [&near](const std::vector<double>& fs) {
    detail::ReferenceValues v;
    v.H.reserve(fs.size());
    for (double fk : fs) v.H.push_back(near(s_from_hz(fk)));
    v.exact.assign(fs.size(), 1);
    return v;
  };
  detail::CandidateResponse candidate(reduced);
  const auto near_grid = static_cast<Index>(m_grid.size());
  const BandError departure = detail::assemble_band_error(
      candidate, std::move(near_f), detail::SamplingPlan{near_grid, 0, true, false},
      {source, m_options, m_band, 0.0, 0.0, m_full.threads()});
  const double settled = (tolerance - std::max(neighbour_error, 0.0)) / (1.0 + neighbour_error);
  std::vector<double> solve;
  for (double fp :
       largest_local_maxima_hz(departure, static_cast<Index>(departure.f_hz.size()), settled)) {
    if (static_cast<Index>(solve.size()) >= max_new_solves) break;
    if (!m_full.contains(fp)) solve.push_back(fp);
  }
  if (m_engine) {
    const double overhead = m_engine->overhead_flops();
    return rented(m_engine->verify_at(reduced, solve), overhead);
  }
  for (double fc : m_full.frequencies())
    if (fc >= m_band.f_min_hz && fc <= m_band.f_max_hz) f.push_back(fc);
  f.insert(f.end(), solve.begin(), solve.end());
  return assemble(reduced, std::move(f), grid, 0, false, true);
}

}  // namespace ecmor
