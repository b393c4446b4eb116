// modal.cpp: the "modal" reducer: modal truncation with modes selected for the frequency band,
// computed in batches by shift-invert ARPACK ("spectrum slicing"), optionally with a static
// correction (mode acceleration). See README.md for the algorithm, parameters and failure modes.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/linalg/eigensolver.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/linalg/spectrum_slicer.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/plugin/plugin.hpp"

namespace ecmor::modal {
namespace {

constexpr const char* kName = "modal";
constexpr double kInf = std::numeric_limits<double>::infinity();
/// Coefficient matrices with relative asymmetry below this count as exactly symmetric (the
/// shifted solver's own default, so that it uses Cholesky on them).
constexpr double kExactSymmetry = 1e-12;

/// How modes within the band margin are ordered (YAML `mode_ranking`).
enum class ModeRanking {
  Band,       ///< by log distance to the band, ties by ascending f
  Dominance,  ///< by relative dominance at the nearest band frequency, largest first
};

/// The reducer's settings; the initialisers are the defaults, option_specs() the keys, ranges
/// and documentation.
struct Options {
  bool static_correction = true;
  ModeRanking mode_ranking = ModeRanking::Band;
  Index batch_size = 20;
  double tolerance = 0.0;
  double band_margin = 10.0;
  Index max_iterations = 1000;
  double symmetry_tolerance = 1e-6;
  long long seed = 1;
};

const OptionSpecs<Options>& option_specs() {
  static const OptionSpecs<Options> specs({
      option("static_correction", &Options::static_correction,
             "append the M-orthogonalised static response K^-1 B (shifted for singular K); counted "
             "in the order (second-order and symmetric descriptor models)"),
      choice(
          "mode_ranking", &Options::mode_ranking,
          {{"band", ModeRanking::Band}, {"dominance", ModeRanking::Dominance}},
          "order of the modes within the band margin: band (log distance to the band, then "
          "ascending f) or dominance (relative dominance ||c_j b_j'|| / |lambda_j - w^2 + i w d_j| "
          "/ ||H(i w)|| at w = clamp(omega_j, band), largest first; computes every mode within "
          "the margin first; symmetric eigenproblems only)"),
      option("batch_size", &Options::batch_size, "eigenpairs per ARPACK run (one slice)")
          .range(Range::closed(1, 100000)),
      option("tolerance", &Options::tolerance,
             "ARPACK's relative accuracy of the Ritz values; 0 = machine precision")
          .range(Range::closed(0, 1e-2)),
      option(
          "band_margin", &Options::band_margin,
          "factor on f: modes within [f_min / margin, f_max * margin] rank by log distance to the "
          "band, beyond by ascending frequency")
          .range(Range::at_least(1)),
      option("max_iterations", &Options::max_iterations, "ARPACK implicit restarts per run")
          .range(Range::at_least(1)),
      option("symmetry_tolerance", &Options::symmetry_tolerance,
             "relative asymmetry of K up to which its symmetric part is used; above, the general "
             "eigensolver")
          .range(Range::closed(0, 1)),
      option("seed", &Options::seed, "seed of ARPACK's start vectors (reproducible runs)")
          .range(Range::at_least(1)),
  });
  return specs;
}

double asymmetry(const SparseMatrix& A) {
  const double norm = A.norm();
  if (norm == 0.0) return 0.0;
  return SparseMatrix(A - SparseMatrix(A.transpose())).norm() / norm;
}

SparseMatrix symmetric_part(const SparseMatrix& A) {
  return SparseMatrix(0.5 * (A + SparseMatrix(A.transpose())));
}

/// The slicer's eigensolver settings from the reducer's.
SliceOptions slice_options(const Options& o) {
  SliceOptions s;
  s.batch_size = o.batch_size;
  s.tolerance = o.tolerance;
  s.max_iterations = o.max_iterations;
  s.seed = static_cast<std::uint64_t>(o.seed);
  s.caller = kName;
  return s;
}

/// Ranking of modes for a band: rigid modes first (tier 0), then modes whose frequency lies within
/// [f_min / margin, f_max * margin] ("near", tier 1) by distance in log f to the band (0 inside,
/// ties by ascending f), then the remaining ("far") modes by ascending frequency (tier 2): beyond
/// the margin a lower mode has the larger quasi-static contribution in the band.
struct Key {
  int tier = 0;
  double distance = 0.0;
  double f = 0.0;
  friend bool operator<=(const Key& a, const Key& b) {
    return std::tie(a.tier, a.distance, a.f) <= std::tie(b.tier, b.distance, b.f);
  }
  friend bool operator<(const Key& a, const Key& b) {
    return std::tie(a.tier, a.distance, a.f) < std::tie(b.tier, b.distance, b.f);
  }
};

class Ranking {
 public:
  Ranking(const Band& band, double margin) : m_band(band), m_margin(margin) {}
  Key key(double f, bool rigid) const {
    if (rigid) return {0, 0.0, f};
    if (f < m_band.f_min_hz / m_margin || f > m_band.f_max_hz * m_margin) return {2, 0.0, f};
    if (f < m_band.f_min_hz) return {1, std::log(m_band.f_min_hz / f), f};
    if (f > m_band.f_max_hz) return {1, std::log(f / m_band.f_max_hz), f};
    return {1, 0.0, f};
  }
  /// A lower bound of the keys of all modes with frequency > f_front (the uncomputed ones): a
  /// computed mode whose key is <= this bound keeps its rank whatever is computed later.
  Key bound(double f_front) const {
    if (f_front == kInf) return {3, 0.0, kInf};
    if (f_front < m_band.f_max_hz) return {1, 0.0, std::max(f_front, m_band.f_min_hz)};
    if (f_front < m_band.f_max_hz * m_margin) {
      return {1, std::log(f_front / m_band.f_max_hz), f_front};
    }
    return {2, 0.0, f_front};
  }

 private:
  Band m_band;
  double m_margin;
};

/// One computed mode of a general (unsymmetric) pencil: a real eigenvalue or a conjugate pair
/// (stored once, Im > 0).
struct GeneralMode {
  Complex lambda;
  ComplexVector right;
  ComplexVector left;  ///< empty when not needed (Galerkin)
  bool pair = false;
};

/// General pencil A x = lambda E x, all eigenvalues in the disc |lambda - sigma| <= r around one
/// real shift. Growing recomputes ARPACK with a doubled nev on the same factorisation: eigenvalues
/// in the complex plane cannot be sliced with real shifts, and the disc keeps the covered
/// frequencies contiguous (f <= f_front).
class GeneralModes {
 public:
  GeneralModes(const SparseMatrix& E, std::shared_ptr<const Factorization> F, double sigma,
               bool second_order, bool need_left, const Options& options)
      : m_E(E),
        m_F(std::move(F)),
        m_sigma(sigma),
        m_second_order(second_order),
        m_need_left(need_left),
        m_options(options),
        m_n(E.rows()) {}

  double frequency(Complex lambda) const {
    return (m_second_order ? std::sqrt(std::abs(lambda)) : std::abs(lambda)) / kTwoPi;
  }
  double frontier_frequency() const { return m_f_front; }
  bool complete() const { return m_f_front == kInf; }
  const std::vector<GeneralMode>& modes() const { return m_modes; }
  Index runs() const { return m_runs; }
  Index operator_applications() const { return m_applications; }
  double sigma() const { return m_sigma; }

  void grow() {
    if (complete()) return;
    m_nev = m_nev == 0 ? std::min<Index>(m_options.batch_size, m_n - 1)
                       : std::min<Index>(2 * m_nev, m_n - 1);
    EigenOptions eo;
    eo.nev = m_nev;
    eo.tolerance = m_options.tolerance;
    eo.max_iterations = m_options.max_iterations;
    eo.seed = static_cast<std::uint64_t>(m_options.seed);
    const GeneralEigenResult right = general_shift_invert(*m_F, m_E, m_sigma, eo, false);
    m_applications += right.operator_applications;
    ++m_runs;
    std::optional<GeneralEigenResult> left;
    if (m_need_left) {
      left = general_shift_invert(*m_F, m_E, m_sigma, eo, true);
      m_applications += left->operator_applications;
    }
    m_modes.clear();
    const Index count = right.eigenvalues.size();
    double radius = 0.0;
    for (Index j = 0; j < count; ++j) {
      const Complex l = right.eigenvalues[j];
      radius = std::max(radius, std::abs(l - m_sigma));
      if (l.imag() < 0.0) continue;  // the Im > 0 member of the pair represents it
      GeneralMode mode;
      mode.lambda = l;
      mode.right = right.eigenvectors.col(j);
      mode.pair = l.imag() != 0.0;
      if (mode.pair) {
        // The conjugate must be in the set (pairs are never split by general_shift_invert).
        bool found = false;
        for (Index k = 0; k < count && !found; ++k) {
          found = std::abs(right.eigenvalues[k] - std::conj(l)) <= 1e-8 * std::abs(l);
        }
        if (!found) continue;
      }
      if (left) {
        Index best = -1;
        double best_d = kInf;
        for (Index k = 0; k < left->eigenvalues.size(); ++k) {
          const double d = std::abs(left->eigenvalues[k] - l);
          if (d < best_d) best_d = d, best = k;
        }
        if (best < 0 || best_d > 1e-6 * std::max(std::abs(l), 1e-300)) continue;  // unmatched
        mode.left = left->eigenvectors.col(best);
      }
      m_modes.push_back(std::move(mode));
    }
    // Everything with |lambda - sigma| < radius is known: |lambda| < radius - |sigma|.
    const bool all = right.dense_fallback || m_nev >= m_n - 1;
    const double reach = radius - std::abs(m_sigma);
    m_f_front = all ? kInf : (reach > 0.0 ? frequency(Complex(reach, 0.0)) : 0.0);
  }

 private:
  const SparseMatrix& m_E;
  std::shared_ptr<const Factorization> m_F;
  double m_sigma;
  bool m_second_order;
  bool m_need_left;
  Options m_options;
  Index m_n;
  Index m_nev = 0;
  Index m_runs = 0;
  Index m_applications = 0;
  double m_f_front = -kInf;
  std::vector<GeneralMode> m_modes;
};

class ModalReducer final : public Reducer {
 public:
  explicit ModalReducer(const Options& options) : m_options(options) {}

  void setup(const ReductionContext& context) override {
    if (context.model == nullptr || context.solver == nullptr) {
      throw InputError("modal: setup() needs a model and a shifted solver");
    }
    context.band.validate();
    m_context = context;
    m_ranking.emplace(m_context.band, m_options.band_margin);
    m_n = size_of(*m_context.model);
    if (m_n < 2) throw InputError(fmt::format("modal: the model has N = {}: needs N >= 2", m_n));

    if (const auto* so = std::get_if<SecondOrderModel>(m_context.model)) {
      require_spd_mass(*m_context.model, "modal");  // InputError naming M
      const double asym_k = asymmetry(so->K);
      m_asymmetry = asym_k;
      if (asym_k <= kExactSymmetry) {
        m_slicer.emplace(so->K, so->M, *m_context.solver,
                         pencil_factorizer(*m_context.solver, true), true, slice_options(m_options),
                         m_context.band.f_min_hz,
                         rigid_body_modes(*m_context.model, *m_context.solver));
        m_path = "symmetric";
      } else if (asym_k <= m_options.symmetry_tolerance) {
        // Tiny asymmetry (rounding in the source data): the modes of the symmetric part, through a
        // solver on a copy of the model with K symmetrised (the shared solver would factorise the
        // unsymmetric K, and Lanczos needs an M-symmetric operator). The projection uses the
        // original K.
        SecondOrderModel sym = *so;
        sym.K = symmetric_part(so->K);
        m_symmetrised = std::make_unique<Model>(std::move(sym));
        m_own_solver = make_shifted_solver(*m_symmetrised);
        ShiftedSolver& solver = *m_own_solver;
        const auto& sym_model = std::get<SecondOrderModel>(*m_symmetrised);
        m_slicer.emplace(sym_model.K, sym_model.M, solver, pencil_factorizer(solver, true), true,
                         slice_options(m_options), m_context.band.f_min_hz,
                         rigid_body_modes(*m_symmetrised, solver));
        m_path = "symmetric part";
      } else {
        // Clearly unsymmetric K: eigenvectors of the general pencil (K, M), a real basis from their
        // real and imaginary parts, Galerkin (W = V) as the model is second order.
        const double omega_min = kTwoPi * m_context.band.f_min_hz;
        const double sigma = -std::max(omega_min * omega_min, 1e-6 * spectrum_scale(so->K, so->M));
        const Complex w[3] = {1.0, 0.0, -sigma};
        m_general.emplace(so->M, m_context.solver->factorize_combination(w), sigma, true, false,
                          m_options);
        m_path = "general";
      }
    } else {
      const auto& ds = std::get<DescriptorModel>(*m_context.model);
      const bool symmetric = asymmetry(ds.A) <= kExactSymmetry && asymmetry(ds.E) <= kExactSymmetry;
      m_negA = symmetric ? SparseMatrix(-ds.A) : SparseMatrix();
      bool spd_e = false;
      if (symmetric) {
        try {
          require_spd_mass(*m_context.model, "modal");
          spd_e = true;
        } catch (const InputError&) {
        }
      }
      if (symmetric && spd_e) {
        // E SPD, A symmetric (e.g. the rail models): -A phi = mu E phi, poles -mu, W = V.
        m_slicer.emplace(m_negA, ds.E, *m_context.solver,
                         pencil_factorizer(*m_context.solver, false), false,
                         slice_options(m_options), m_context.band.f_min_hz,
                         rigid_body_modes(*m_context.model, *m_context.solver));
        m_path = "symmetric descriptor";
      } else {
        // Poles nearest 0 by |lambda| (= the natural frequency of a pole pair): sigma = 0 unless A
        // is singular (a pole at 0), then a small negative shift.
        double sigma = 0.0;
        std::shared_ptr<const Factorization> F;
        try {
          const Complex w[2] = {-1.0, 0.0};  // A - 0 E
          F = m_context.solver->factorize_combination(w);
        } catch (const NumericalError&) {
          sigma = -kTwoPi * m_context.band.f_min_hz;
          const Complex w[2] = {-1.0, -sigma};  // A - sigma E
          F = m_context.solver->factorize_combination(w);
        }
        m_general.emplace(ds.E, std::move(F), sigma, false, true, m_options);
        m_path = "general descriptor";
      }
    }
    if (m_options.mode_ranking == ModeRanking::Dominance && !m_slicer) {
      throw ConfigError(fmt::format(
          "modal: mode_ranking: dominance needs the symmetric eigenproblem (second-order model "
          "with K symmetric up to symmetry_tolerance, or descriptor model with A symmetric and E "
          "SPD); this model takes the {} path: use mode_ranking: band",
          m_path));
    }
  }

  ReducerResult reduce(const ReductionRequest& request) override {
    if (m_context.model == nullptr) throw InputError("modal: reduce() called before setup()");
    if (!request.points.empty()) return reduce_mixed(request);
    if (request.order < 1) {
      throw InputError(fmt::format("modal: requested order {}: must be >= 1", request.order));
    }
    return reduce_modes(request.order);
  }

  Index max_order() const override { return m_n; }
  Index order_step() const override { return 1; }

 private:
  ReducerResult reduce_modes(Index order) {
    return m_slicer ? reduce_symmetric(order) : reduce_general(order);
  }

  // ---- mixed basis: modal block + Krylov columns at expansion points ---------------------------

  /// The Taylor coefficients X_0..X_{moments-1} of X(s) = P(s)^-1 B at s0 (moment j is the j-th
  /// derivative / j!): P X_0 = B, P X_j = -(P' X_{j-1} + (P''/2) X_{j-2}) with P' = 2 s0 M + D,
  /// P''/2 = M (second order) or P' = E (descriptor). Cached per point; a point asked for more
  /// moments than cached is solved again from its factorisation.
  const std::vector<ComplexMatrix>& krylov_moments(Complex s0, Index moments, Index point) {
    ++m_tick;
    for (PointSolve& c : m_point_solves) {
      if (c.s == s0 && static_cast<Index>(c.X.size()) >= moments) {
        c.last_use = m_tick;
        return c.X;
      }
    }
    std::shared_ptr<const Factorization> F;
    try {
      F = m_context.solver->factorize(s0);
    } catch (const NumericalError& e) {
      throw InputError(fmt::format(
          "modal: expansion point {} (s = {:g}{:+g}i): P(s) is singular, s lies on a pole of the "
          "model: {}",
          point, s0.real(), s0.imag(), e.what()));
    }
    const bool so = std::holds_alternative<SecondOrderModel>(*m_context.model);
    std::vector<ComplexMatrix> X;
    X.push_back(F->solve(ComplexMatrix(input_matrix().cast<Complex>())));
    for (Index j = 1; j < moments; ++j) {
      ComplexMatrix rhs;
      if (so) {
        const Complex d1[3] = {0.0, 1.0, 2.0 * s0};
        rhs = m_context.solver->apply_combination(d1, X[static_cast<std::size_t>(j - 1)]);
        if (j >= 2) {
          const Complex d2[3] = {0.0, 0.0, 1.0};
          rhs += m_context.solver->apply_combination(d2, X[static_cast<std::size_t>(j - 2)]);
        }
      } else {
        const Complex d1[2] = {0.0, 1.0};
        rhs = m_context.solver->apply_combination(d1, X[static_cast<std::size_t>(j - 1)]);
      }
      X.push_back(F->solve(ComplexMatrix(-rhs)));
    }
    for (PointSolve& c : m_point_solves) {
      if (c.s == s0) {
        c.X = std::move(X);
        c.last_use = m_tick;
        return c.X;
      }
    }
    m_point_solves.push_back({s0, std::move(X), m_tick});
    return m_point_solves.back().X;
  }

  /// Bounds the cache of Krylov blocks (N x m complex per moment each): the points of `keep` (the
  /// last request) stay, and of the others the kSpareSolves used last (a strategy's rejected
  /// candidates would otherwise pile up; a dropped point costs one factorisation if asked again).
  void trim_point_solves(const std::vector<ExpansionPoint>& keep) {
    constexpr std::size_t kSpareSolves = 16;
    auto requested = [&](const PointSolve& c) {
      return std::any_of(keep.begin(), keep.end(),
                         [&](const ExpansionPoint& p) { return p.s == c.s; });
    };
    std::stable_sort(m_point_solves.begin(), m_point_solves.end(),
                     [&](const PointSolve& a, const PointSolve& b) {
                       const bool ka = requested(a), kb = requested(b);
                       return ka != kb ? ka : a.last_use > b.last_use;
                     });
    std::size_t kept = 0;
    while (kept < m_point_solves.size() && requested(m_point_solves[kept])) ++kept;
    m_point_solves.resize(std::min(m_point_solves.size(), kept + kSpareSolves));
  }

  /// ReductionRequest with points: the modal block of request.modes (the model of
  /// reduce_modes(modes)), then for each point and moment the real and imaginary parts of its
  /// Krylov block, M-orthonormalised against everything before (Galerkin, W = V: the reduced
  /// model interpolates H and its first `moments` derivatives at each s0 and its conjugate).
  /// order > 0 caps the basis, keeping the first columns.
  ReducerResult reduce_mixed(const ReductionRequest& request) {
    // The general descriptor path's block is Petrov-Galerkin (W spans the left eigenvectors): the
    // Krylov columns, orthonormal in the Euclidean product, join V and W alike.
    const bool petrov = std::holds_alternative<DescriptorModel>(*m_context.model) && !m_slicer;
    for (std::size_t i = 0; i < request.points.size(); ++i) {
      const ExpansionPoint& p = request.points[i];
      if (!std::isfinite(p.s.real()) || !std::isfinite(p.s.imag()) || p.moments < 1) {
        throw InputError(fmt::format(
            "modal: expansion point {} (s = {:g}{:+g}i, {} moments): needs a finite s and "
            "moments >= 1",
            i + 1, p.s.real(), p.s.imag(), p.moments));
      }
    }
    ReducerResult result;
    Matrix V(m_n, 0), W(m_n, 0);
    std::string note;
    if (request.modes > 0) {
      result = reduce_modes(request.modes);
      V = result.V;
      W = result.W;
      note = result.note;
    }
    const Index block = V.cols();
    const InnerProduct ip{petrov ? nullptr : &inner_product_matrix()};
    const SolverCounters before = m_context.solver->counters();
    for (std::size_t i = 0; i < request.points.size(); ++i) {
      const ExpansionPoint& p = request.points[i];
      const std::vector<ComplexMatrix>& X =
          krylov_moments(p.s, p.moments, static_cast<Index>(i + 1));
      for (Index j = 0; j < p.moments; ++j) {
        const ComplexMatrix& Xj = X[static_cast<std::size_t>(j)];
        orthonormalize_append(V, Xj.real(), ip);
        if (p.s.imag() != 0.0) orthonormalize_append(V, Xj.imag(), ip);
      }
    }
    trim_point_solves(request.points);
    const Index krylov = V.cols() - block;
    if (request.order > 0 && V.cols() > request.order) V.conservativeResize(m_n, request.order);
    if (petrov) {
      // W = [W_block, the Krylov columns]: H_r still interpolates H at the points (they lie in
      // span V) while W' E V is invertible, checked here.
      const Index extra = V.cols() - W.cols();
      W.conservativeResize(m_n, V.cols());
      if (extra > 0) W.rightCols(extra) = V.rightCols(extra);
      const Matrix G = W.transpose() * (std::get<DescriptorModel>(*m_context.model).E * V);
      const Eigen::JacobiSVD<Matrix> svd(G);
      const Eigen::Index last = svd.singularValues().size() - 1;
      const double cond = last < 0 ? 1.0 : svd.singularValues()(0) / svd.singularValues()(last);
      if (!(cond < 1e12)) {
        throw NumericalError(fmt::format(
            "modal: W' E V of the modal block and the Krylov columns at {} points is singular "
            "(condition {:g}): the points' columns are (nearly) E-orthogonal to the left "
            "eigenvectors",
            request.points.size(), cond));
      }
      result.diagnostics["biorthogonality_condition"] = cond;
    } else {
      W = V;
    }
    result.V = V;
    result.W = W;
    result.model = project(*m_context.model, V, W);
    result.points = request.points;
    result.diagnostics["block_columns"] = static_cast<double>(block);
    result.diagnostics["krylov_columns"] = static_cast<double>(krylov);
    result.diagnostics["point_factorizations"] =
        static_cast<double>((m_context.solver->counters() - before).factorizations);
    result.diagnostics["orthogonality_loss"] = orthogonality_loss(V, ip);
    const std::string points =
        fmt::format("{} Krylov column{} at {} point{}", krylov, krylov == 1 ? "" : "s",
                    request.points.size(), request.points.size() == 1 ? "" : "s");
    result.note = note.empty() ? points : note + " + " + points;
    if (V.cols() < block + krylov)
      result.note += fmt::format("; capped at order {}", request.order);
    return result;
  }

  // ---- symmetric path --------------------------------------------------------------------------

  const SparseMatrix& inner_product_matrix() const {
    if (const auto* so = std::get_if<SecondOrderModel>(m_context.model)) return so->M;
    return std::get<DescriptorModel>(*m_context.model).E;
  }
  const Matrix& input_matrix() const {
    if (const auto* so = std::get_if<SecondOrderModel>(m_context.model)) return so->B;
    return std::get<DescriptorModel>(*m_context.model).B;
  }

  /// Indices of the computed modes in rank order, only those whose rank is final.
  std::vector<Index> final_ranked() {
    if (m_options.mode_ranking == ModeRanking::Dominance) return final_ranked_by_dominance();
    const SymmetricSlicer& s = *m_slicer;
    const Key bound = m_ranking->bound(s.frontier_frequency());
    std::vector<std::pair<Key, Index>> keyed;
    for (Index j = 0; j < s.known(); ++j) {
      const double l = s.lambda(j);
      const Key k = m_ranking->key(s.is_rigid(l) ? 0.0 : s.frequency(l), s.is_rigid(l));
      if (k <= bound) keyed.emplace_back(k, j);
    }
    std::stable_sort(keyed.begin(), keyed.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<Index> out;
    for (const auto& k : keyed) out.push_back(k.second);
    return out;
  }

  /// mode_ranking: dominance. Rigid modes first; then the modes within the band margin by
  /// descending relative dominance (ties by the band key); then the far modes by ascending f, as
  /// with the band ranking. The dominance of a mode depends on every other mode (through ||H||),
  /// so no near mode is final before the slicing covers [f_min / margin, f_max * margin]; the
  /// scores are then computed once and frozen, which keeps the bases nested: every mode computed
  /// later lies above the margin and ranks after all of them.
  std::vector<Index> final_ranked_by_dominance() {
    const SymmetricSlicer& s = *m_slicer;
    const bool covered = s.frontier_frequency() >= m_context.band.f_max_hz * m_options.band_margin;
    if (covered && m_dominance.empty()) m_dominance = dominance_scores();
    const Key bound = m_ranking->bound(s.frontier_frequency());
    // (tier, -dominance, band key's distance, f, index)
    std::vector<std::tuple<int, double, double, double, Index>> keyed;
    for (Index j = 0; j < s.known(); ++j) {
      const double l = s.lambda(j);
      const bool rigid = s.is_rigid(l);
      const Key k = m_ranking->key(rigid ? 0.0 : s.frequency(l), rigid);
      if (k.tier == 0) {
        keyed.emplace_back(0, 0.0, 0.0, 0.0, j);
      } else if (covered && k.tier == 1) {
        keyed.emplace_back(1, -m_dominance[static_cast<std::size_t>(j)], k.distance, k.f, j);
      } else if (covered && k <= bound) {
        keyed.emplace_back(2, 0.0, k.distance, k.f, j);
      }
    }
    std::stable_sort(keyed.begin(), keyed.end());
    std::vector<Index> out;
    for (const auto& k : keyed) out.push_back(std::get<4>(k));
    return out;
  }

  /// Relative dominance of every computed mode within the band margin (0 for the others):
  ///   ||(c_j + i w cv_j) b_j'|| / |lambda_j - w^2 + i w d_j| / ||H(i w)||,  w = clamp(omega_j,
  ///   band)
  /// with c_j = C phi_j, cv_j = Cv phi_j, b_j = phi_j' B, d_j = phi_j' D phi_j (descriptor:
  /// denominator lambda_j + i w, no Cv). ||H(i w)|| (largest singular value) is estimated without
  /// full solves: the same modal sum over all computed modes (diagonal modal damping) plus the
  /// static residual of the uncomputed ones, (C + i w Cv) (K^-1 B - sum_k phi_k b_k' / lambda_k),
  /// when K is nonsingular. Cost O(n_modes^2 p m) after the projections. Dividing by ||H|| targets
  /// the relative band error: a mode that is large where H is larger still matters less (README
  /// has the measured comparison with absolute dominance).
  std::vector<double> dominance_scores() {
    const SymmetricSlicer& s = *m_slicer;
    const Index n = s.known();
    const Matrix& Phi = s.vectors();
    const auto* so = std::get_if<SecondOrderModel>(m_context.model);
    const Matrix& B = input_matrix();
    const Matrix& C = so ? so->C : std::get<DescriptorModel>(*m_context.model).C;
    const bool velocity = so != nullptr && so->has_velocity_output();
    const Matrix Bm = Phi.transpose() * B;  // n x m, row k = b_k'
    const ComplexMatrix Bc = Bm.cast<Complex>();
    const Matrix Cm = C * Phi;  // p x n
    const Matrix Cvm = velocity ? Matrix(so->Cv * Phi) : Matrix();
    Vector lambda(n), damping = Vector::Zero(n);
    for (Index k = 0; k < n; ++k) {
      lambda[k] = s.is_rigid(s.lambda(k)) ? 0.0 : s.lambda(k);
      if (so) damping[k] = Phi.col(k).dot(so->D * Phi.col(k));
    }
    // Static residual of the modes not computed (K nonsingular only: the shifted block of a
    // singular K is not a static response).
    const Index p = C.rows(), m = B.cols();
    Matrix residual = Matrix::Zero(p, m), residual_v = Matrix::Zero(p, m);
    const Matrix& X = static_block();
    if (m_static_shift == 0.0 && s.rigid().count == 0) {
      Vector inv(n);
      for (Index k = 0; k < n; ++k) inv[k] = lambda[k] > 0.0 ? 1.0 / lambda[k] : 0.0;
      residual = C * X - Cm * inv.asDiagonal() * Bm;
      if (velocity) residual_v = so->Cv * X - Cvm * inv.asDiagonal() * Bm;
    }
    const double omega_lo = kTwoPi * m_context.band.f_min_hz,
                 omega_hi = kTwoPi * m_context.band.f_max_hz;
    std::vector<double> score(static_cast<std::size_t>(n), 0.0);
    ComplexVector alpha(n);
    for (Index j = 0; j < n; ++j) {
      if (m_ranking->key(s.frequency(lambda[j]), s.is_rigid(s.lambda(j))).tier != 1) continue;
      const double w = std::clamp(kTwoPi * s.frequency(lambda[j]), omega_lo, omega_hi);
      for (Index k = 0; k < n; ++k) {
        Complex den = so ? Complex(lambda[k] - w * w, w * damping[k]) : Complex(lambda[k], w);
        // An undamped mode at its own resonance: a finite stand-in that keeps it dominant there.
        const double floor = 1e-12 * std::max(std::abs(lambda[k]), w * w);
        if (std::abs(den) < floor) den = floor;
        alpha[k] = 1.0 / den;
      }
      ComplexMatrix Ccw = Cm.cast<Complex>();
      ComplexMatrix Rw = residual.cast<Complex>();
      if (velocity) {
        Ccw += Complex(0.0, w) * Cvm.cast<Complex>();
        Rw += Complex(0.0, w) * residual_v.cast<Complex>();
      }
      const ComplexMatrix H = Ccw * alpha.asDiagonal() * Bc + Rw;
      const double residue = Ccw.col(j).norm() * Bm.row(j).norm();
      const double h = matrix_norm(H, ErrorNorm::Spectral);
      score[static_cast<std::size_t>(j)] =
          residue == 0.0 ? 0.0 : residue * std::abs(alpha[j]) / std::max(h, 1e-300);
    }
    return score;
  }

  /// The static-correction block X (N x m): K^-1 B, or (K - sigma_0 M)^-1 B when K is singular
  /// (rigid modes present), computed once.
  const Matrix& static_block() {
    if (m_static) return *m_static;
    SymmetricSlicer& s = *m_slicer;
    if (s.batches() == 0) s.next_batch();
    bool rigid = s.rigid().count > 0;
    Matrix X;
    if (!rigid) {
      try {
        const bool so = std::holds_alternative<SecondOrderModel>(*m_context.model);
        std::shared_ptr<const Factorization> F;
        if (so) {
          const Complex w[3] = {1.0, 0.0, 0.0};
          F = (m_own_solver ? m_own_solver.get() : m_context.solver)->factorize_combination(w);
        } else {
          const Complex w[2] = {1.0, 0.0};
          F = m_context.solver->factorize_combination(w);
        }
        X = F->solve(input_matrix());
        m_static_shift = 0.0;
      } catch (const NumericalError&) {
        rigid = true;  // numerically singular although no zero eigenvalue was computed
      }
    }
    if (rigid) {
      // Singular K: the shifted static response (K - sigma_0 M)^-1 B, sigma_0 < 0. Its component
      // along the rigid modes is already in the modal basis; the elastic remainder is the
      // quasi-static response of the flexible modes (inertia-relief-like, see README).
      X = s.first_factorization().solve(input_matrix());
      m_static_shift = s.sigma0();
    }
    m_static = X;
    Matrix Q(m_n, 0);
    m_static_rank = orthonormalize_append(Q, X, InnerProduct{&inner_product_matrix()});
    return *m_static;
  }

  ReducerResult reduce_symmetric(Index order) {
    SymmetricSlicer& s = *m_slicer;
    const Index wanted = std::min(order, m_n);
    Index static_cols = 0;
    if (m_options.static_correction) {
      static_block();
      if (wanted > m_static_rank) static_cols = m_static_rank;
    }
    Index modes_wanted = wanted - static_cols;
    const SparseMatrix& M = inner_product_matrix();
    std::vector<Index> ranked;
    Matrix V;
    Index modes = 0, appended = 0;
    // A static column that deflates against the modes (it lies in their span, e.g. when nearly all
    // modes are taken) is replaced by the next mode, so the order is delivered whenever possible.
    for (;;) {
      ranked = final_ranked();
      while (static_cast<Index>(ranked.size()) < modes_wanted && !s.complete()) {
        s.next_batch();
        ranked = final_ranked();
      }
      modes = std::min<Index>(modes_wanted, static_cast<Index>(ranked.size()));
      V.resize(m_n, modes);
      for (Index k = 0; k < modes; ++k)
        V.col(k) = s.vectors().col(ranked[static_cast<std::size_t>(k)]);
      appended = static_cols > 0 ? orthonormalize_append(V, *m_static, InnerProduct{&M}) : 0;
      if (V.cols() >= wanted || modes < modes_wanted) break;
      modes_wanted += wanted - V.cols();
    }
    Index rigid = 0;
    double f_lo = kInf, f_hi = 0.0;
    for (Index k = 0; k < modes; ++k) {
      const Index j = ranked[static_cast<std::size_t>(k)];
      if (s.is_rigid(s.lambda(j))) {
        ++rigid;
      } else {
        f_lo = std::min(f_lo, s.frequency(s.lambda(j)));
        f_hi = std::max(f_hi, s.frequency(s.lambda(j)));
      }
    }
    ReducerResult result;
    result.V = V;
    result.W = V;
    result.model = project(*m_context.model, V, V);
    result.diagnostics["modes"] = static_cast<double>(modes);
    result.diagnostics["rigid_modes"] = static_cast<double>(rigid);
    result.diagnostics["static_columns"] = static_cast<double>(appended);
    result.diagnostics["computed_modes"] = static_cast<double>(s.known());
    result.diagnostics["batches"] = static_cast<double>(s.batches());
    result.diagnostics["operator_applications"] = static_cast<double>(s.operator_applications());
    result.diagnostics["duplicates_removed"] = static_cast<double>(s.duplicates());
    result.diagnostics["spurious_removed"] = static_cast<double>(s.spurious());
    result.diagnostics["orthogonality_loss"] = orthogonality_loss(V, InnerProduct{&M});
    if (modes > 0 && f_hi > 0.0) {
      result.diagnostics["f_lowest_hz"] = f_lo;
      result.diagnostics["f_highest_hz"] = f_hi;
    }
    result.diagnostics["max_eigen_residual"] = max_residual(ranked, modes);
    std::string note = fmt::format("{} modes", modes);
    if (rigid > 0) note += fmt::format(" ({} rigid)", rigid);
    if (appended > 0) {
      note += fmt::format(" + {} static correction{}", appended, appended > 1 ? "s" : "");
      if (m_static_shift != 0.0) note += fmt::format(" (shifted, sigma = {:g})", m_static_shift);
    }
    if (modes > 0 && f_hi > 0.0)
      note += fmt::format("; elastic modes {:.4g} .. {:.4g} Hz", f_lo, f_hi);
    if (m_path != "symmetric") note += "; " + m_path + " eigenproblem";
    if (s.eigensolver() == "slepc") note += "; eigenpairs by SLEPc Krylov-Schur";
    if (V.cols() < order) {
      note += fmt::format("; order {} requested, {} available", order, V.cols());
      if (s.exhausted()) {
        note += fmt::format(
            " (spectrum slicing found {} of {} eigenpairs and then nothing new in "
            "3 slices: ARPACK misses copies of an eigenvalue of high multiplicity"
            "{})",
            s.known(), m_n,
            s.spurious() > 0 ? fmt::format("; {} spurious Ritz pairs dropped", s.spurious())
                             : std::string());
      }
    } else if (m_options.static_correction && static_cols == 0 && m_static_rank > 0) {
      note += fmt::format("; static correction omitted (needs order > {})", m_static_rank);
    }
    result.note = note;
    return result;
  }

  /// max_j ||K phi_j - lambda_j M phi_j|| / (||K||_F ||phi_j||) over the selected modes.
  double max_residual(const std::vector<Index>& ranked, Index modes) const {
    const SymmetricSlicer& s = *m_slicer;
    const SparseMatrix& M = inner_product_matrix();
    const SparseMatrix& K = m_symmetrised ? std::get<SecondOrderModel>(*m_symmetrised).K
                            : std::holds_alternative<SecondOrderModel>(*m_context.model)
                                ? std::get<SecondOrderModel>(*m_context.model).K
                                : m_negA;
    const double k_norm = K.norm();
    double worst = 0.0;
    for (Index k = 0; k < modes; ++k) {
      const Index j = ranked[static_cast<std::size_t>(k)];
      const Vector phi = s.vectors().col(j);
      const double res = (K * phi - s.lambda(j) * (M * phi)).norm() / (k_norm * phi.norm());
      worst = std::max(worst, res);
    }
    return worst;
  }

  // ---- general path ----------------------------------------------------------------------------

  ReducerResult reduce_general(Index order) {
    GeneralModes& g = *m_general;
    const Index wanted = std::min(order, m_n);
    // Rank the modes; a pair occupies two columns and is never split, so the result may have one
    // column less than requested (nested all the same).
    auto ranked = [&]() {
      const Key bound = m_ranking->bound(g.frontier_frequency());
      std::vector<std::pair<Key, Index>> keyed;
      for (Index j = 0; j < static_cast<Index>(g.modes().size()); ++j) {
        const Complex l = g.modes()[static_cast<std::size_t>(j)].lambda;
        const bool rigid = std::abs(l) == 0.0;
        const Key k = m_ranking->key(g.frequency(l), rigid);
        if (k <= bound) keyed.emplace_back(k, j);
      }
      std::stable_sort(keyed.begin(), keyed.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
      return keyed;
    };
    auto columns_final = [&](const std::vector<std::pair<Key, Index>>& keyed) {
      Index cols = 0;
      for (const auto& k : keyed)
        cols += g.modes()[static_cast<std::size_t>(k.second)].pair ? 2 : 1;
      return cols;
    };
    if (g.runs() == 0) g.grow();
    auto keyed = ranked();
    while (columns_final(keyed) < wanted && !g.complete()) {
      g.grow();
      keyed = ranked();
    }
    std::vector<Vector> vcols, wcols;
    Index pairs = 0;
    for (const auto& k : keyed) {
      const GeneralMode& mode = g.modes()[static_cast<std::size_t>(k.second)];
      const Index need = mode.pair ? 2 : 1;
      if (static_cast<Index>(vcols.size()) + need > wanted) break;
      vcols.push_back(mode.right.real());
      if (mode.left.size() > 0) wcols.push_back(mode.left.real());
      if (mode.pair) {
        ++pairs;
        vcols.push_back(mode.right.imag());
        if (mode.left.size() > 0) wcols.push_back(mode.left.imag());
      }
    }
    const auto n = static_cast<Index>(vcols.size());
    Matrix Vraw(m_n, n), Wraw(m_n, static_cast<Index>(wcols.size()));
    for (Index j = 0; j < n; ++j) Vraw.col(j) = vcols[static_cast<std::size_t>(j)];
    for (Index j = 0; j < Wraw.cols(); ++j) Wraw.col(j) = wcols[static_cast<std::size_t>(j)];

    ReducerResult result;
    if (const auto* so = std::get_if<SecondOrderModel>(m_context.model)) {
      // Galerkin with an M-orthonormal basis of span{Re x, Im x}: Mr = I.
      Matrix V(m_n, 0);
      orthonormalize_append(V, Vraw, InnerProduct{&so->M});
      result.V = V;
      result.W = V;
      result.diagnostics["orthogonality_loss"] = orthogonality_loss(V, InnerProduct{&so->M});
    } else {
      // Petrov-Galerkin: orthonormal bases of the right and left eigenspaces, then W scaled so that
      // W' E V = I (eigenspaces of distinct eigenvalues are E-biorthogonal, so W' E V is block
      // diagonal and invertible unless an eigenvalue is defective).
      const auto& ds = std::get<DescriptorModel>(*m_context.model);
      Matrix V(m_n, 0), W(m_n, 0);
      orthonormalize_append(V, Vraw);
      orthonormalize_append(W, Wraw);
      if (V.cols() != W.cols()) {
        throw NumericalError(fmt::format(
            "modal: right ({}) and left ({}) eigenbases differ in rank", V.cols(), W.cols()));
      }
      const Matrix G = W.transpose() * (ds.E * V);
      const Eigen::JacobiSVD<Matrix> svd(G);
      const double cond = G.size() == 0 ? 1.0
                                        : svd.singularValues()(0) /
                                              svd.singularValues()(svd.singularValues().size() - 1);
      if (!(cond < 1e12)) {
        throw NumericalError(fmt::format(
            "modal: W' E V of the left and right eigenvectors is singular (condition {:g}): a "
            "defective or nearly defective eigenvalue",
            cond));
      }
      W = W * G.transpose().partialPivLu().inverse();
      result.V = V;
      result.W = W;
      result.diagnostics["biorthogonality_condition"] = cond;
    }
    result.model = project(*m_context.model, result.V, result.W);
    result.diagnostics["modes"] = static_cast<double>(n - pairs);
    result.diagnostics["complex_pairs"] = static_cast<double>(pairs);
    result.diagnostics["arpack_runs"] = static_cast<double>(g.runs());
    result.diagnostics["operator_applications"] = static_cast<double>(g.operator_applications());
    std::string note = fmt::format("{} modes ({} complex pairs as Re/Im columns); {} eigenproblem",
                                   n - pairs, pairs, m_path);
    if (m_options.static_correction && std::holds_alternative<DescriptorModel>(*m_context.model)) {
      note += "; no static correction for unsymmetric descriptor models";
    } else if (m_options.static_correction) {
      note += "; no static correction on the general path";
    }
    if (result.V.cols() < order) {
      note += fmt::format("; order {} requested, {} delivered", order, result.V.cols());
    }
    result.note = note;
    return result;
  }

  Options m_options;
  ReductionContext m_context;  // the model, solver and band of setup()
  std::optional<Ranking> m_ranking;
  Index m_n = 0;
  double m_asymmetry = 0.0;
  std::string m_path;
  // Declared before the engines that hold factorisations from it (destroyed after them).
  std::unique_ptr<Model> m_symmetrised;
  std::unique_ptr<ShiftedSolver> m_own_solver;
  SparseMatrix m_negA;
  std::optional<SymmetricSlicer> m_slicer;
  std::optional<GeneralModes> m_general;
  std::optional<Matrix> m_static;
  /// Relative dominance per computed mode (mode_ranking: dominance), frozen once computed.
  std::vector<double> m_dominance;
  Index m_static_rank = 0;
  double m_static_shift = 0.0;
  /// Krylov blocks of the expansion points asked for so far (reduce_mixed).
  struct PointSolve {
    Complex s;
    std::vector<ComplexMatrix> X;
    std::uint64_t last_use = 0;
  };
  std::vector<PointSolve> m_point_solves;
  std::uint64_t m_tick = 0;
};

ReducerInfo modal_info() {
  return reducer_info(
      kName,
      "modal truncation: eigenmodes nearest the band by shift-invert ARPACK in slices, rigid-body "
      "modes first, optional static correction; with expansion points, a mixed basis of a modal "
      "block and Krylov columns",
      "0.2.0", option_specs(),
      {.second_order = true,
       .descriptor = true,
       .uses_expansion_points = true,
       .modal_block = true});
}

std::unique_ptr<Reducer> create_modal(const ParameterMap& params) {
  const Options o = option_specs().read(params);
  // A removed key, refused with the reason (not an option, so not in option_specs()).
  if (params.has("rigid_tolerance")) {
    // Removed: a relative eigenvalue threshold mislabels the soft modes of long structures.
    throw ConfigError(
        "modal: rigid_tolerance is no longer a parameter: rigid-body modes are the null space of "
        "K (a successful Cholesky factorisation of K means there is none, else a gap in the "
        "eigenvalues near 0 decides; see rigid_body.hpp); remove the key");
  }
  return std::make_unique<ModalReducer>(o);
}

void register_reducers(Registry& registry) { registry.add({modal_info(), create_modal}); }

}  // namespace
}  // namespace ecmor::modal

ECMOR_PLUGIN(ecmor::modal::register_reducers)
