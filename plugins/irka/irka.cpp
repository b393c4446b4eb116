// irka.cpp: the "irka" reducer: the iterative rational Krylov algorithm for H2-optimal reduction
// (Gugercin, Antoulas, Beattie 2008), MIMO with tangential directions, for descriptor models and
// for second-order models through their first-order realisation (solves on s^2 M + s D + K), plus
// a structure-preserving second-order variant, with safeguards (convergence, cycling, stagnation,
// restarts, reflected poles) reported in the history. See README.md.
#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/gramians/balancing.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/gramians/quadrature.hpp"
#include "ecmor/linalg/eigensolver.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/plugin/plugin.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "interpolation.hpp"
#include "next_shifts.hpp"
#include "start_shifts.hpp"

namespace ecmor::irka {
namespace {

constexpr const char* kName = "irka";

enum class Structure { FirstOrder, SecondOrder };
enum class SecondOrderShifts { Iterate, FromFirstOrder };
enum class Projection { TwoSided, OneSided };

/// The reducer's settings; the initialisers are the defaults, option_specs() the keys, ranges
/// and documentation.
struct Options {
  Structure structure = Structure::FirstOrder;
  SecondOrderShifts second_order_shifts = SecondOrderShifts::Iterate;
  Projection projection = Projection::TwoSided;
  enum class Start { Band, Modal, Balanced, Best };
  Start start = Start::Band;  // initial_shifts
  double initial_damping = 0.0;
  double relaxation = 1.0;  // fraction of the step towards the mirrored poles (1: plain IRKA)
  Index max_iterations = 50;
  double tolerance = 1e-6;
  double model_tolerance = 0.0;        // on the relative H2 change of the reduced model; 0: off
  bool model_tolerance_given = false;  // false: symmetric_defaults() may change it
  Index stagnation_window = 10;
  Index restarts = 2;
  bool restarts_given = false;  // false: symmetric_defaults() may change it
  bool warm_start = true;
  bool surrogate = true;  // symmetric definite descriptor models only (surrogate_active())
  bool surrogate_given = false;
  bool check_stability = true;
  Index dense_check_limit = 2000;
  bool frequency_limited = false;  // band-limited H2 objective (FL-IRKA)
  AdaptiveQuadratureOptions quadrature = band_quadrature_defaults();  // frequency_limited only
};

const OptionSpecs<Options>& option_specs() {
  auto frequency_limited = [](const Options& o) { return o.frequency_limited; };
  static const OptionSpecs<Options> specs(
      {
          choice("structure", &Options::structure,
                 {{"first_order", Structure::FirstOrder}, {"second_order", Structure::SecondOrder}},
                 "first_order: IRKA on the (first-order realisation of the) model, returns E, A, "
                 "B, C of order r (H2-optimal); second_order: returns Mr, Dr, Kr, Br, Cr of size "
                 "r (2r states), second-order models only"),
          choice("second_order_shifts", &Options::second_order_shifts,
                 {{"iterate", SecondOrderShifts::Iterate},
                  {"first_order", SecondOrderShifts::FromFirstOrder}},
                 "iterate (SO-IRKA: the next shifts are the mirror images of r of the 2r reduced "
                 "poles, largest H2 weight first) or first_order (the converged shifts of "
                 "first-order IRKA at order r, then one second-order projection)")
              .only_if([](const Options& o) { return o.structure == Structure::SecondOrder; },
                       "applies to structure: second_order only"),
          choice("projection", &Options::projection,
                 {{"two_sided", Projection::TwoSided}, {"one_sided", Projection::OneSided}},
                 "two_sided (Hermite interpolation at the shifts) or one_sided (W = V: keeps "
                 "symmetric positive definite matrices so, hence every reduced model stable; "
                 "structure first_order needs E symmetric positive definite and A symmetric "
                 "negative definite, and then needs larger orders than two_sided when B != C')"),
          choice("initial_shifts", &Options::start,
                 {{"band", Options::Start::Band},
                  {"modal", Options::Start::Modal},
                  {"balanced", Options::Start::Balanced},
                  {"best", Options::Start::Best}},
                 "band: log-spaced band frequencies (real ones for models with real poles); "
                 "modal: mirror images of dominant poles near the band centre (second order: "
                 "undamped modes with modal damping; descriptor: the r of largest H2 weight among "
                 "3r shift-invert eigenvalues); balanced: poles of the dense balanced truncation "
                 "(at most dense_check_limit states); best: each of these, keeping the converged "
                 "model of largest H2 norm (smallest error)"),
          option("relaxation", &Options::relaxation,
                 "fraction alpha of each step from the old shifts to the mirrored poles (1: plain "
                 "IRKA); restarts halve it (down to 1/4)")
              .range(Range::closed(1e-3, 1)),
          option("initial_damping", &Options::initial_damping,
                 "starting shifts omega (zeta + i) at log-spaced band frequencies: zeta (at least "
                 "0.01 with frequency_limited, whose vectors need Re s > 0)")
              .range(Range::closed(0, 10)),
          option("max_iterations", &Options::max_iterations,
                 "IRKA iterations per reduce(), all restarts together")
              .range(Range::closed(1, 100000)),
          option("tolerance", &Options::tolerance,
                 "converged when the shifts change by at most this (relative, matched pairwise)")
              .range(Range::closed(1e-14, 1e-1)),
          option("model_tolerance", &Options::model_tolerance,
                 "also converged when the reduced model changes by at most this in the relative "
                 "H2 norm between iterations (scaled by 1/relaxation); 0 = off, else >= 1e-7; "
                 "default 1e-3 for E SPD, A symmetric negative definite, and with the surrogate "
                 "for M, D, K SPD; computed from the "
                 "pole-residue forms, whose cancellation puts its floor near 1e-8")
              .range(Range::closed(0, 1e-1))
              .given(&Options::model_tolerance_given),
          option("stagnation_window", &Options::stagnation_window,
                 "restart when the shift change has not fallen 10% below its best within this "
                 "many iterations")
              .range(Range::closed(2, 100000)),
          option("restarts", &Options::restarts,
                 "restarts from other band shifts after cycling, stagnation or a breakdown "
                 "(default 0 for E SPD, A symmetric negative definite, and with the surrogate for "
                 "M, D, K SPD); one more when no attempt "
                 "built a model")
              .range(Range::closed(0, 100))
              .given(&Options::restarts_given),
          option("warm_start", &Options::warm_start,
                 "start order r from the final shifts of the largest smaller order run before "
                 "(plus new shifts in the widest frequency gaps); false: always from the band"),
          option("surrogate", &Options::surrogate,
                 "symmetric definite models (E SPD and A symmetric negative definite, or M, D, K "
                 "SPD), two-sided first order: between true builds, iterate IRKA on the Galerkin "
                 "projection onto every vector computed so far (cheap, dense) and build at its "
                 "fixed point; convergence is still judged on the full model; false: plain IRKA "
                 "steps. Ignored elsewhere unless set true (refused)")
              .given(&Options::surrogate_given),
          option("check_stability", &Options::check_stability,
                 "refuse a model that is not asymptotically stable (symmetric definite matrices "
                 "certify it; otherwise dense eigenvalues up to dense_check_limit states)"),
          option("dense_check_limit", &Options::dense_check_limit,
                 "largest first-order state size whose poles are computed densely for the "
                 "stability check")
              .range(Range::closed(0, 20000)),
          option("frequency_limited", &Options::frequency_limited,
                 "true: the band-limited H2 objective (FL-IRKA): interpolation vectors are the "
                 "columns of the band-limited cross Gramians, (sE - A)^-1 (B beta(s) + E L_B) b "
                 "with L_B the band integral of the resolvent (computed once in setup by adaptive "
                 "quadrature; see README)"),
          band_quadrature_specs()
              .at("band_quadrature_tolerance")
              .nested(&Options::quadrature)
              .only_if(frequency_limited, "applies to frequency_limited: true only"),
          band_quadrature_specs()
              .at("band_quadrature_budget")
              .nested(&Options::quadrature)
              .only_if(frequency_limited, "applies to frequency_limited: true only"),
      },
      {[](const Options& o, const OptionCheck<Options>& c) {
        if (o.model_tolerance > 0.0 && o.model_tolerance < 1e-7) {
          c.fail(o.model_tolerance,
                 "must be 0 (off) or >= 1e-7 (the relative H2 change is computed from "
                 "pole-residue forms and is rounding below about 1e-8)");
        }
      }});
  return specs;
}

/// A stable model in real block-diagonal modal form, x' = A x + B u, y = C x, built from its
/// pole-residue form G(s) = sum_i c_i b_i^T / (s - lambda_i): a real pole is a 1 x 1 block
/// [lambda] with B row Re b', C column Re c; a pair lambda = a + i w, conj(lambda) (w > 0) is the
/// 2 x 2 block [a -w; w a] with B rows Re b', Im b' and C columns 2 Re c, -2 Im c (the complex
/// state z = x1 + i x2 of the pair has z' = lambda z + b' u, and its output c z + conj(c z)).
/// Solves with s I - A are divisions by blocks: the IRKA surrogate's steps are O(k r).
struct RealModal {
  Vector diagonal;         ///< a (block diagonal)
  Vector coupling;         ///< w at the first row of a pair, 0 elsewhere
  std::vector<bool> pair;  ///< true at the first row of a 2 x 2 block
  Matrix B, C;

  /// \throws NumericalError when the poles are not closed under conjugation.
  explicit RealModal(const PoleResidues& g) {
    const Index n = g.poles.size();
    Index upper = 0, lower = 0;
    for (const Complex& z : g.poles) {
      upper += z.imag() > 0.0 ? 1 : 0;
      lower += z.imag() < 0.0 ? 1 : 0;
    }
    if (upper != lower) {
      throw NumericalError(fmt::format(
          "{} poles with Im > 0 but {} with Im < 0: not a real model's poles", upper, lower));
    }
    diagonal.resize(n);
    coupling = Vector::Zero(n);
    pair.assign(static_cast<std::size_t>(n), false);
    B.resize(n, g.b.rows());
    C.resize(g.c.rows(), n);
    Index k = 0;
    for (Index i = 0; i < n; ++i) {
      const Complex z = g.poles(i);
      if (z.imag() < 0.0) continue;  // the conjugate of a pair taken with its partner
      diagonal(k) = z.real();
      B.row(k) = g.b.col(i).real().transpose();
      if (z.imag() == 0.0) {
        C.col(k) = g.c.col(i).real();
        k += 1;
        continue;
      }
      pair[static_cast<std::size_t>(k)] = true;
      coupling(k) = z.imag();
      diagonal(k + 1) = z.real();
      B.row(k + 1) = g.b.col(i).imag().transpose();
      C.col(k) = 2.0 * g.c.col(i).real();
      C.col(k + 1) = -2.0 * g.c.col(i).imag();
      k += 2;
    }
  }

  Index size() const { return diagonal.size(); }

  /// (s I - A)^-1 x, or (s I - A)^-T x when `transposed`.
  ComplexVector solve(Complex s, const ComplexVector& x, bool transposed) const {
    ComplexVector y(x.size());
    for (Index k = 0; k < size(); ++k) {
      const Complex d = s - diagonal(k);
      if (!pair[static_cast<std::size_t>(k)]) {
        y(k) = x(k) / d;
        continue;
      }
      // s I - [a -w; w a] = [d w; -w d], inverse [d -w; w d] / (d^2 + w^2).
      const double w = transposed ? -coupling(k) : coupling(k);
      const Complex det = d * d + w * w;
      y(k) = (d * x(k) - w * x(k + 1)) / det;
      y(k + 1) = (w * x(k) + d * x(k + 1)) / det;
      ++k;
    }
    return y;
  }

  /// A X.
  Matrix apply(const Matrix& X) const {
    Matrix Y(X.rows(), X.cols());
    for (Index k = 0; k < size(); ++k) {
      if (!pair[static_cast<std::size_t>(k)]) {
        Y.row(k) = diagonal(k) * X.row(k);
        continue;
      }
      Y.row(k) = diagonal(k) * X.row(k) - coupling(k) * X.row(k + 1);
      Y.row(k + 1) = coupling(k) * X.row(k) + diagonal(k + 1) * X.row(k + 1);
      ++k;
    }
    return Y;
  }
};

/// A reduced model built from one interpolation data set, with its bases and the pole-residue
/// form of its (first-order realisation's) transfer function.
struct Built {
  ReducedModel model;
  Matrix V, W;
  PoleResidues poles;
};

/// What one IRKA run at a fixed order ends with.
struct Outcome {
  Built built;
  Interpolation data;  // the shifts and directions `built` interpolates at
  bool converged = false;
  std::string reason;
  Index iterations = 0;
  Index restarts = 0;
  Index reflected = 0;
  double shift_change = std::numeric_limits<double>::infinity();  // data_change() at the end
  double model_change = std::numeric_limits<double>::infinity();  // relative H2 change
  // Frequency-limited IRKA: ||G - Gr||^2 over the band (band_h2_squared_error); NaN otherwise.
  double band_objective = std::numeric_limits<double>::quiet_NaN();
};

/// The vectors one factorisation gave: at shift s with directions b, c, the right vector v and
/// (when computed) the left vector w.
struct Solved {
  Complex s;
  ComplexVector b, c;
  ComplexMatrix v, w;  // w empty when not computed
};

std::string describe(Complex s) {
  if (s.imag() == 0.0) return fmt::format("{:.6g}", s.real());
  return fmt::format("{:.6g}{:+.6g}i", s.real(), s.imag());
}

/// Orthonormal basis of the columns of X (Householder QR), the columns normalised first (resolvent
/// norms differ by orders of magnitude across a band). Numerically dependent columns (nearby
/// shifts) still give an orthonormal basis of the right dimension, whose projection stays valid;
/// only columns dependent to 1e-14 after normalisation (equal shifts and directions) are refused.
/// \throws NumericalError for NaN/Inf or exactly dependent columns.
Matrix orthonormal_basis(Matrix X, const char* side) {
  if (!X.allFinite()) {
    throw NumericalError(fmt::format("the {} basis contains NaN or Inf", side));
  }
  for (Index j = 0; j < X.cols(); ++j) {
    const double norm = X.col(j).norm();
    if (norm > 0.0) X.col(j) /= norm;
  }
  Eigen::ColPivHouseholderQR<Matrix> qr(X);
  qr.setThreshold(1e-14);
  if (qr.rank() < X.cols()) {
    throw NumericalError(fmt::format(
        "the {} basis has rank {} < {}: two shifts (or directions) coincide to working precision",
        side, qr.rank(), X.cols()));
  }
  return qr.householderQ() * Matrix::Identity(X.rows(), X.cols());
}

/// True for a pole with Re >= -1e-12 |lambda|: not asymptotically stable to working precision
/// (relative to the pole itself, so that huge perturbed infinite eigenvalues of a singular E do
/// not make the small stable poles look marginal).
bool is_unstable(Complex p) { return p.real() >= -1e-12 * std::abs(p); }

Index unstable_count(const ComplexVector& poles) {
  Index count = 0;
  for (const Complex& p : poles) count += is_unstable(p) ? 1 : 0;
  return count;
}

class IrkaReducer final : public Reducer {
 public:
  explicit IrkaReducer(Options options) : m_given(options), m_options(options) {}

  void setup(const ReductionContext& context) override {
    if (context.model == nullptr || context.solver == nullptr) {
      throw InputError("irka: setup needs a model and a shifted solver");
    }
    if (context.solver->size() != size_of(*context.model)) {
      throw InputError(fmt::format("irka: the solver has size {}, the model N = {}",
                                   context.solver->size(), size_of(*context.model)));
    }
    m_options = m_given;
    m_surrogate = Surrogate{};
    m_surrogate_agreement = std::numeric_limits<double>::infinity();
    m_built_max_order = 0;
    m_balancing.reset();  // of the previous model, if setup() is called again
    m_view.emplace(*context.model, *context.solver);
    m_model = context.model;
    m_band = context.band;
    if (m_options.structure == Structure::SecondOrder && !m_view->second_order()) {
      throw ConfigError(
          "reducer 'irka': structure = second_order needs a second-order model (M, D, K); this "
          "model is first order (E, A): use structure: first_order");
    }
    classify(*context.model);
    check_model(*context.model);
    choose_projection(*context.model);
    symmetric_defaults();
    if (m_given.surrogate_given && m_given.surrogate && !surrogate_active()) {
      throw ConfigError(
          "reducer 'irka': surrogate = true needs a first-order run (structure: first_order, "
          "projection: two_sided, frequency_limited: false) on a descriptor model with E "
          "symmetric positive definite and A symmetric negative definite, or a second-order "
          "model with M, D and K symmetric positive definite; this run is not one");
    }
    if (m_options.frequency_limited) {
      if (m_options.start == Options::Start::Best) {
        throw ConfigError(
            "reducer 'irka': initial_shifts = best chooses among starts by the H2 norm of the "
            "result, which does not rank frequency-limited models: use band, modal or balanced "
            "with frequency_limited: true");
      }
      const auto started = std::chrono::steady_clock::now();
      m_band_integrals = band_resolvent_integrals(*m_view, m_band, m_options.quadrature);
      m_band_norm_squared = band_h2_squared_error(*m_band_integrals, nullptr);
      m_input = m_view->input_matrix().cast<Complex>();
      m_output_t = m_view->output_matrix().transpose().cast<Complex>();
      m_band_seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    }
  }

  ReducerResult reduce(const ReductionRequest& request) override {
    if (!m_view) throw InputError("irka: reduce() called before setup()");
    if (!request.points.empty()) {
      throw ConfigError(
          "reducer 'irka' chooses its own interpolation points (the mirror images of the reduced "
          "poles); a strategy that sets expansion points cannot drive it: use grow_order");
    }
    const Index r = request.order;
    if (r < 1 || r > max_order()) {
      throw InputError(fmt::format("irka: order = {}: must be in [1, {}] (the {})", r, max_order(),
                                   second_order_variant() ? "size N of the second-order model"
                                                          : "size of the first-order state"));
    }
    const auto started = std::chrono::steady_clock::now();
    m_reused = 0;
    m_surrogate_iterations = 0;
    // warm_start: false promises a model of order r independent of the orders asked before; the
    // surrogate carries their vectors, so it starts empty at every order then.
    if (!m_options.warm_start) {
      m_surrogate = Surrogate{};
      m_surrogate_agreement = std::numeric_limits<double>::infinity();
    }
    Outcome out;
    std::string prefix;
    if (second_order_variant() &&
        m_options.second_order_shifts == SecondOrderShifts::FromFirstOrder) {
      // First-order IRKA finds the shifts; one second-order projection uses them.
      Outcome first = run_from_starts(r, false, prefix);
      Built so = build(first.data, true, r);
      out = std::move(first);
      out.built = std::move(so);
      prefix = "second-order projection at the shifts of first-order IRKA; " + prefix;
    } else if (std::optional<Outcome> o = surrogate_outcome(r)) {
      out = std::move(*o);
    } else {
      out = run_from_starts(r, second_order_variant(), prefix);
      m_built_max_order = std::max(m_built_max_order, r);
    }
    m_warm[r] = Warm{out.data, out.built.poles};

    ReducerResult result;
    result.model = out.built.model;
    result.V = std::move(out.built.V);
    result.W = std::move(out.built.W);
    result.diagnostics["irka_seconds"] =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    result.diagnostics["irka_iterations"] = static_cast<double>(out.iterations);
    result.diagnostics["irka_converged"] = out.converged ? 1.0 : 0.0;
    result.diagnostics["irka_restarts"] = static_cast<double>(out.restarts);
    result.diagnostics["irka_one_sided"] = m_one_sided ? 1.0 : 0.0;
    result.diagnostics["irka_reused_solves"] = static_cast<double>(m_reused);
    result.diagnostics["irka_reflected_poles"] = static_cast<double>(out.reflected);
    result.diagnostics["irka_surrogate_iterations"] = static_cast<double>(m_surrogate_iterations);
    result.diagnostics["irka_surrogate_size"] = static_cast<double>(m_surrogate.U.cols());
    result.diagnostics["irka_change"] = out.shift_change;
    result.diagnostics["irka_model_change"] = out.model_change;
    result.diagnostics["eigenvector_rcond"] = out.built.poles.eigenvector_rcond;
    if (m_band_integrals) {
      const MatrixQuadrature& q = m_band_integrals->quadrature;
      result.diagnostics["band_integral_evaluations"] = static_cast<double>(q.evaluations);
      result.diagnostics["band_integral_error"] =
          q.integral.norm() > 0.0 ? q.error_estimate / q.integral.norm() : q.error_estimate;
      result.diagnostics["band_integral_seconds"] = m_band_seconds;
      // The band H2 error relative to ||G|| over the band, by the integrals' quadrature rule.
      result.diagnostics["band_h2_error"] =
          std::sqrt(std::max(0.0, out.band_objective) / m_band_norm_squared);
      if (!q.converged) {
        prefix += fmt::format("band integrals NOT converged ({:.1e} relative after {} nodes); ",
                              result.diagnostics["band_integral_error"], q.evaluations);
      }
      prefix = "frequency-limited, " + prefix;
    }
    const Index unstable = unstable_count(out.built.poles.poles);
    result.diagnostics[kUnstablePolesDiagnostic] = static_cast<double>(unstable);
    if (m_one_sided && !second_order_variant()) {
      prefix = "one-sided (W = V, symmetric model), " + prefix;
    }
    result.note =
        fmt::format("irka r = {}: {}{} after {} iterations, {} restarts, {} poles reflected", r,
                    prefix, out.reason, out.iterations, out.restarts, out.reflected);
    if (unstable > 0) result.note += fmt::format("; {} reduced poles with Re >= 0", unstable);
    return result;
  }

  Index max_order() const override {
    if (!m_view) return kUnlimitedOrder;
    return second_order_variant() ? m_view->size() : m_view->state_size();
  }

 private:
  /// The damping zeta of starting shifts omega (zeta + i). Frequency-limited IRKA needs Re s > 0:
  /// its interpolation vectors integrate 1 / (s - i w) over the band, singular for s on the axis.
  double start_damping() const {
    return m_options.frequency_limited ? std::max(m_options.initial_damping, kFlMinimumDamping)
                                       : m_options.initial_damping;
  }
  static constexpr double kFlMinimumDamping = 1e-2;

  bool second_order_variant() const { return m_options.structure == Structure::SecondOrder; }

  /// One- or two-sided (`projection`). W = V keeps Er = V'EV SPD and Ar = V'AV symmetric
  /// negative definite for a symmetric definite model, so every iterate is stable with real
  /// poles; but with B != C' its model of order r matches H(s) b at r shifts where two-sided
  /// matches H(s) b, c' H(s) and c' H'(s) b, and it needs larger orders for the same band error
  /// (measured, README: rail_1357 60 against 34, rail_5177 68 against 52; with both B b and C' c
  /// in V at ceil(r/2) shifts 96 on rail_1357, its shifts never settled), so two-sided stays the
  /// default even for those models.
  void choose_projection(const Model& model) {
    if (second_order_variant()) {
      m_one_sided_so = m_options.projection == Projection::OneSided;
      return;
    }
    if (m_options.projection == Projection::OneSided && !m_symmetric) {
      throw ConfigError(
          "reducer 'irka': projection = one_sided with structure first_order needs a descriptor "
          "model with E symmetric positive definite and A symmetric negative definite (then W = V "
          "keeps every reduced model stable); this model is not: use projection: two_sided");
    }
    (void)model;
    m_one_sided = m_options.projection == Projection::OneSided;
    // A symmetric definite pencil has real poles: real shifts throughout.
    if (m_one_sided) m_real_poles = true;
  }

  /// Whether the model is symmetric definite: a descriptor model with E SPD and A symmetric
  /// negative definite (m_symmetric), or a second-order one with M, D, K SPD (m_definite_so).
  /// Either is stable (certified, check_model()) and keeps a Galerkin projection stable.
  void classify(const Model& model) {
    if (const auto* ds = std::get_if<DescriptorModel>(&model)) {
      m_symmetric = is_positive_definite(ds->E) && is_positive_definite(SparseMatrix(-ds->A));
      m_definite_so = false;
    } else {
      const auto& so = std::get<SecondOrderModel>(model);
      m_symmetric = false;
      m_definite_so =
          is_positive_definite(so.M) && is_positive_definite(so.D) && is_positive_definite(so.K);
    }
  }

  /// Defaults for a symmetric definite descriptor model (E SPD, A symmetric negative definite),
  /// unless the configuration sets them: model_tolerance 1e-3 and no restarts (and warm starts
  /// from a larger order, start()). Two-sided IRKA there (B != C') reflects reduced poles,
  /// cycles and restarts without reaching a fixed point (rail_5177: 5 944 factorisations in the
  /// reducer, against 0.22 s for balanced truncation); restarts from modal or band shifts ended
  /// in the same cycles, and the model-change test stops the slow linear convergence once the
  /// model no longer changes. Measured (README): rail_1357 order 38 -> 34 with 7 776 -> 1 922
  /// factorisations, rail_5177 83 -> 52 with 5 944 -> 3 253. Not the default for other models:
  /// model_tolerance 1e-3 stops them too early (cdplayer order 22 -> 26, iss_flirka's basis
  /// breaks down at r = 93).
  void symmetric_defaults() {
    // Second-order definite models take them with the surrogate, whose prediction test needs
    // model_tolerance > 0 (issue 46: the solid family).
    if (!m_symmetric && !surrogate_active()) return;
    if (!m_given.model_tolerance_given) m_options.model_tolerance = kSymmetricModelTolerance;
    if (!m_given.restarts_given) m_options.restarts = 0;
  }
  static constexpr double kSymmetricModelTolerance = 1e-3;

  /// Refuses models IRKA cannot treat: unstable ones (no H2 norm, IRKA's fixed point undefined)
  /// and descriptor models with singular E (the polynomial part of a DAE is not handled).
  void check_model(const Model& model) {
    // A descriptor model with singular E (a DAE) is refused whatever check_stability says.
    std::string singular_e;
    if (const auto* ds = std::get_if<DescriptorModel>(&model)) {
      if (!is_positive_definite(ds->E)) {
        const std::vector<Complex> e_only{Complex(0.0), Complex(1.0)};
        try {
          (void)m_view->solver().factorize_combination(e_only);
        } catch (const NumericalError& e) {
          singular_e = e.what();
        }
      }
    }
    auto refuse_dae = [&](const std::string& poles) {
      throw InputError(fmt::format(
          "irka: E is singular ({}): the model is a DAE, whose polynomial part IRKA does not "
          "handle{}; reduce it with krylov or modal, or give an ODE realisation",
          singular_e, poles));
    };
    m_stability = "not verified";
    if (!m_options.check_stability) {
      if (!singular_e.empty()) refuse_dae("");
      return;
    }
    // E SPD and A symmetric negative definite: every pole is real and negative. M, D, K SPD:
    // for an eigenvector x, x^H (s^2 M + s D + K) x = 0 has roots with Re < 0.
    const bool certified = m_symmetric || m_definite_so;
    if (certified) {
      m_stability = "certified (symmetric definite)";
      // E SPD and A symmetric: every pole is real, and so are the H2-optimal shifts.
      m_real_poles = std::holds_alternative<DescriptorModel>(model);
      return;
    }
    const Index dim = m_view->state_size();
    std::string unstable_text;
    if (dim <= m_options.dense_check_limit) {
      const ComplexVector p = dense_poles(model);
      const Index unstable = unstable_count(p);
      if (unstable > 0) {
        // The unstable pole of least modulus is the most trustworthy; the largest real part
        // shows the extent.
        double largest = -std::numeric_limits<double>::infinity();
        Complex smallest(std::numeric_limits<double>::infinity(), 0.0);
        for (const Complex& z : p) {
          largest = std::max(largest, z.real());
          if (is_unstable(z) && std::abs(z) < std::abs(smallest)) smallest = z;
        }
        unstable_text = fmt::format(
            "{} of its {} computed finite poles have Re >= 0 (the one of least modulus {}; "
            "largest real part {:.3e})",
            unstable, p.size(), describe(smallest), largest);
      }
      m_stability = "dense eigenvalues";
    }
    if (!singular_e.empty()) {
      // Perturbed infinite eigenvalues of a singular E (of index k, of size eps^(-1/k)) look
      // like large finite poles of either sign: say so rather than call the model unstable.
      refuse_dae(unstable_text.empty()
                     ? std::string()
                     : "; besides, " + unstable_text +
                           ", which for a singular E may be perturbed infinite eigenvalues");
    }
    if (!unstable_text.empty()) {
      throw InputError(fmt::format(
          "irka: the model is not asymptotically stable: {}; its H2 norm does not exist and IRKA "
          "has no H2-optimal model to converge to (set check_stability: false to try anyway)",
          unstable_text));
    }
  }

  /// Finite poles of the full model by a dense shift-invert eigenproblem: the eigenvalues mu of
  /// (A - sigma E)^-1 E give lambda = sigma + 1 / mu, and mu = 0 (to 1e-12 max |mu|) are the
  /// infinite eigenvalues of a singular E. Unlike QZ on (A, E), the nonsymmetric QR iteration
  /// also converges on pencils as badly scaled as peec's (|lambda| from 1 to 1e12).
  /// sigma = -||A||_F / ||E||_F (negative: not a pole of a stable model; else a second try).
  ComplexVector dense_poles(const Model& model) const {
    Matrix E, A;
    if (const auto* ds = std::get_if<DescriptorModel>(&model)) {
      E = Matrix(ds->E);
      A = Matrix(ds->A);
    } else {
      const auto& so = std::get<SecondOrderModel>(model);
      const Index n = so.size();
      E = Matrix::Identity(2 * n, 2 * n);
      E.bottomRightCorner(n, n) = Matrix(so.M);
      A = Matrix::Zero(2 * n, 2 * n);
      A.topRightCorner(n, n).setIdentity();
      A.bottomLeftCorner(n, n) = -Matrix(so.K);
      A.bottomRightCorner(n, n) = -Matrix(so.D);
    }
    const double scale = A.norm() / std::max(E.norm(), std::numeric_limits<double>::min());
    for (const double sigma : {-scale, -0.7315 * scale}) {
      const Eigen::PartialPivLU<Matrix> lu(A - sigma * E);
      if (!(lu.rcond() > 1e-14)) continue;
      const Eigen::EigenSolver<Matrix> eig(Matrix(lu.solve(E)), false);
      if (eig.info() != Eigen::Success) continue;
      const ComplexVector mu = eig.eigenvalues();
      const double largest = mu.size() > 0 ? mu.cwiseAbs().maxCoeff() : 0.0;
      std::vector<Complex> finite;
      for (const Complex& z : mu) {
        if (std::abs(z) > 1e-12 * largest) finite.push_back(sigma + 1.0 / z);
      }
      return Eigen::Map<const ComplexVector>(finite.data(), static_cast<Index>(finite.size()));
    }
    throw NumericalError(
        "irka: the stability check could not compute the model's poles (the shifted pencil "
        "A - sigma E was singular at two shifts or the QR iteration failed); set "
        "check_stability: false to skip it");
  }

  /// The reduced model of order r interpolating at `data`: first-order (of the realisation) or
  /// second-order; two-sided, or one-sided (W = V) as choose_projection() decided. Vectors of
  /// the previous build() at equal data are reused (find_solved()).
  Built build(const Interpolation& data, bool second_order, Index r, bool from_surrogate = false) {
    FirstOrderView& view = *m_view;
    const Index rows = second_order ? view.size() : view.state_size();
    Matrix V(rows, r), W(rows, r);
    const bool two_sided = second_order ? !m_one_sided_so : !m_one_sided;
    std::vector<Solved> solved;
    Index k = 0;
    for (Index i = 0; i < data.size(); ++i) {
      const Complex s = data.shifts[static_cast<std::size_t>(i)];
      if (s.imag() < 0.0) continue;  // the conjugate of the previous shift: same real span
      Solved x{s, data.b.col(i), data.c.col(i), {}, {}};
      if (from_surrogate) {
        surrogate_solve_at(x, two_sided);
      } else if (const Solved* old = find_solved(x, two_sided)) {
        x.v = old->v;
        x.w = old->w;
        ++m_reused;
      } else {
        solve_at(x, second_order, two_sided);
      }
      V.col(k) = x.v.col(0).real();
      if (two_sided) W.col(k) = x.w.col(0).real();
      if (s.imag() > 0.0) {
        V.col(k + 1) = x.v.col(0).imag();
        if (two_sided) W.col(k + 1) = x.w.col(0).imag();
        k += 2;
      } else {
        k += 1;
      }
      solved.push_back(std::move(x));
    }
    // Vectors from the surrogate are not the full model's: never reused as solved.
    if (!from_surrogate) m_solved = std::move(solved);
    if (k != r) {
      throw NumericalError(
          fmt::format("{} shifts give {} basis vectors for order {}", data.size(), k, r));
    }
    Built out;
    out.V = orthonormal_basis(V, "right");
    out.W = two_sided ? orthonormal_basis(W, "left") : out.V;
    if (second_order) {
      const auto so = project(*view.so(), out.V, out.W);
      const ReducedDescriptorModel fo = first_order_realization(ReducedModel(so));
      out.poles = pole_residues(fo.E, fo.A, fo.B, fo.C);
      out.model = so;
    } else {
      auto fo = view.project_first_order(out.V, out.W);
      out.poles = two_sided ? pole_residues(fo.E, fo.A, fo.B, fo.C)
                            : symmetric_pole_residues(fo.E, fo.A, fo.B, fo.C);
      out.model = std::move(fo);
    }
    return out;
  }

  /// The surrogate accelerates two-sided first-order IRKA on symmetric definite models, unless
  /// `surrogate: false`: descriptor models with E SPD and A symmetric negative definite (rail),
  /// and second-order models with M, D, K SPD (structural models with Rayleigh damping; issue 46:
  /// a 2 400-DOF solid took 3 786 factorisations to order 93). Elsewhere it is off: a Galerkin
  /// surrogate of a general model need not be stable.
  bool surrogate_active() const {
    return m_options.surrogate && (m_symmetric || m_definite_so) && !m_one_sided &&
           !second_order_variant() && !m_options.frequency_limited;
  }

  /// The vectors of a build() join the surrogate's pending vectors (the projection is updated
  /// when the surrogate is next used, surrogate_poles()): all of V and W for a descriptor model;
  /// for a second-order one the position rows q of the right vectors [q; s q] and the rows y of
  /// the left vectors [(s M' + D') y - Cv' c; y], which span P(s)^-1 B b and
  /// P(s)^-T (C + s Cv)' c.
  void surrogate_add(const Built& built) {
    if (!surrogate_active()) return;
    const bool so = m_view->second_order();
    const Index n = m_view->size();
    for (const Matrix* X : {&built.V, &built.W}) {
      if (X->cols() == 0) continue;
      Matrix& P = m_surrogate.pending;
      const Index old = P.cols();
      P.conservativeResize(n, old + X->cols());
      P.rightCols(X->cols()) = !so             ? *X
                               : X == &built.V ? Matrix(X->topRows(n))
                                               : Matrix(X->bottomRows(n));
    }
  }

  /// The operators the surrogate projects: E, A of a descriptor model; M, D, K of a second-order
  /// one (all symmetric, so U' X U is updated by blocks and their transposes).
  std::vector<const SparseMatrix*> surrogate_operators() const {
    if (const auto* ds = std::get_if<DescriptorModel>(m_model)) return {&ds->E, &ds->A};
    const auto& so = std::get<SecondOrderModel>(*m_model);
    return {&so.M, &so.D, &so.K};
  }

  /// The surrogate in its real modal realisation (null when it is unusable: its eigenproblem
  /// failed or a pole has Re >= 0, which the definite matrices exclude but rounding might not):
  /// the Galerkin projection of the full model onto the span U of every right and left vector
  /// IRKA has computed since setup() (since this reduce() with warm_start: false; from the newest
  /// ones when the column limit would be passed). The idea of running IRKA on a projected problem
  /// and expanding the projection space at its shifts is not ours (e.g. Lin and Simoncini, "A
  /// reduced-IRKA method for large-scale H2-optimal model order reduction", arXiv:2508.00242,
  /// 2025); the Galerkin projection onto both sides' vectors, the prediction test and the
  /// stopping rule are our choices for symmetric models. W = V = U keeps the projected matrices
  /// definite, hence the surrogate stable (real poles for a descriptor model), and because U
  /// holds both sides' vectors at each shift used, the surrogate interpolates G tangentially,
  /// with the derivative, at every one of them (Hermite, as the two-sided projection does; for
  /// second-order models by the structure-preserving form of that theorem, Beattie and Gugercin,
  /// Systems & Control Letters 58, 2009). New vectors are orthogonalised against U (twice) and
  /// dropped when less than kSurrogateDrop of their norm lies outside it.
  const RealModal* surrogate_model() {
    Surrogate& g = m_surrogate;
    if (g.pending.cols() > 0) {
      surrogate_extend();
      g.modal.reset();
      g.solves.reset();
      g.evaluated = false;
    }
    if (!g.evaluated && g.U.cols() > 0) {
      g.evaluated = true;
      try {
        const SurrogateSolves& e = surrogate_solves();
        m_proportional = m_view->second_order() && !e.dense;
        const PoleResidues poles = m_view->second_order() ? scaled_modal_poles(e, g.Bs, g.Cs, g.Cvs)
                                                          : eigenbasis_poles(e, g.Bs, g.Cs);
        if (unstable_count(poles.poles) == 0) g.modal.emplace(poles);
      } catch (const NumericalError&) {
        // Unusable until new vectors change it: IRKA steps on the full model meanwhile.
      }
    }
    return g.modal ? &*g.modal : nullptr;
  }

  /// The surrogate's pencil in its eigenbasis: the one eigen-decomposition of each surrogate, for
  /// its poles (surrogate_model()) and its solves (surrogate_solve_at()).
  ///   descriptor: As x = lambda Es x, X' Es X = I;
  ///   second order: Ks phi = w^2 Ms phi, X' Ms X = I, damping = X' Ds X (diagonal to 1e-9 relative
  ///   under proportional damping, as Rayleigh damping gives; `dense` otherwise).
  struct SurrogateSolves {
    Matrix X;
    Vector lambda;   // descriptor: eigenvalues of (As, Es)
    Vector w2;       // second order: w^2
    Matrix damping;  // second order: X' Ds X
    bool dense = false;
  };

  /// The eigen-decomposition of the current surrogate (cached until it changes).
  /// \throws NumericalError when Es (Ms) is not numerically positive definite, Ks not positive
  ///         definite, or the eigensolver fails.
  const SurrogateSolves& surrogate_solves() {
    Surrogate& g = m_surrogate;
    if (g.solves) return *g.solves;
    SurrogateSolves out;
    const Matrix P0 = 0.5 * (g.P[0] + g.P[0].transpose());
    const Matrix P1 = 0.5 * (g.P[1] + g.P[1].transpose());
    if (Eigen::LLT<Matrix>(P0).info() != Eigen::Success) {
      throw NumericalError("the surrogate's Es (Ms) is not numerically positive definite");
    }
    if (!m_view->second_order()) {
      const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> eig(P1, P0);
      if (eig.info() != Eigen::Success) throw NumericalError("surrogate eigenproblem failed");
      out.X = eig.eigenvectors();
      out.lambda = eig.eigenvalues();
    } else {
      const Matrix P2 = 0.5 * (g.P[2] + g.P[2].transpose());
      const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> eig(P2, P0);
      if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0.0)) {
        throw NumericalError("the surrogate's stiffness is not positive definite");
      }
      out.X = eig.eigenvectors();
      out.w2 = eig.eigenvalues();
      out.damping = out.X.transpose() * P1 * out.X;
      const Vector d = out.damping.diagonal();
      out.dense = (out.damping - Matrix(d.asDiagonal())).norm() > 1e-9 * out.damping.norm();
    }
    g.solves = std::move(out);
    return *g.solves;
  }

  /// The pole-residue form of a symmetric descriptor surrogate from its eigenbasis: poles lambda_i,
  /// b_i = Bs' x_i, c_i = Cs x_i (X^-1 = X' Es).
  static PoleResidues eigenbasis_poles(const SurrogateSolves& e, const Matrix& Bs,
                                       const Matrix& Cs) {
    PoleResidues out;
    out.poles = e.lambda.cast<Complex>();
    out.b = (Bs.transpose() * e.X).cast<Complex>();
    out.c = (Cs * e.X).cast<Complex>();
    out.eigenvector_rcond = 1.0;  // X is Es-orthonormal; not reported for the surrogate
    return out;
  }

  /// The pole-residue form of the second-order surrogate (Ms, Ds, Ks SPD), computed where it is
  /// well scaled: in its undamped modes K phi = w^2 M phi (phi' M phi = 1). With proportional
  /// damping each mode is a scalar oscillator eta'' + d eta' + w^2 eta = b' u with the poles of
  /// s^2 + d s + w^2 and residues (c + lambda cv) b' / (lambda - lambda'): O(k^3) for the
  /// symmetric eigenproblem only. Otherwise the state z = [W eta; eta'] (W = diag(w)),
  /// z' = [0 W; -W -phi' D phi] z + [0; phi' B] u, y = [C phi W^-1, Cv phi] z: entries of the size
  /// of the frequencies and a nearly normal matrix for light damping. (The plain realisation
  /// [0 I; -K -D] mixes w and w^2, 1e5 and 1e11 on a solid; its unbalanced eigenproblem lost the
  /// surrogate's poles to about 1e-7 relative, where IRKA on it stagnated.)
  static PoleResidues scaled_modal_poles(const SurrogateSolves& e, const Matrix& Bs,
                                         const Matrix& Cs, const Matrix& Cvs) {
    const Matrix& phi = e.X;
    const Vector w = e.w2.cwiseSqrt();
    const Index k = w.size();
    const Matrix b = phi.transpose() * Bs;  // row j: b_j'
    const Matrix c = Cs * phi;              // column j: c_j
    const Matrix cv = Cvs.size() > 0 ? Matrix(Cvs * phi) : Matrix::Zero(Cs.rows(), k);
    const Vector d = e.damping.diagonal();
    bool distinct = !e.dense;
    for (Index j = 0; distinct && j < k; ++j) {
      distinct = std::abs(d(j) * d(j) - 4.0 * w(j) * w(j)) > 1e-12 * w(j) * w(j);
    }
    if (distinct) {
      PoleResidues out;
      out.poles.resize(2 * k);
      out.b.resize(Bs.cols(), 2 * k);
      out.c.resize(Cs.rows(), 2 * k);
      for (Index j = 0; j < k; ++j) {
        const Complex root = std::sqrt(Complex(d(j) * d(j) - 4.0 * w(j) * w(j), 0.0));
        const Complex l1 = 0.5 * (-d(j) + root), l2 = 0.5 * (-d(j) - root);
        for (const auto& [i, l, other] :
             {std::tuple{2 * j, l1, l2}, std::tuple{2 * j + 1, l2, l1}}) {
          out.poles(i) = l;
          out.b.col(i) = b.row(j).transpose().cast<Complex>();
          out.c.col(i) = (c.col(j).cast<Complex>() + l * cv.col(j).cast<Complex>()) / (l - other);
        }
      }
      out.eigenvector_rcond = 1.0;
      return out;
    }
    Matrix A = Matrix::Zero(2 * k, 2 * k);
    A.topRightCorner(k, k) = w.asDiagonal();
    A.bottomLeftCorner(k, k) = -Matrix(w.asDiagonal());
    A.bottomRightCorner(k, k) = -e.damping;
    Matrix B = Matrix::Zero(2 * k, Bs.cols());
    B.bottomRows(k) = b;
    Matrix C(Cs.rows(), 2 * k);
    C.leftCols(k) = c * w.cwiseInverse().asDiagonal();
    C.rightCols(k) = cv;
    return pole_residues(Matrix::Identity(2 * k, 2 * k), A, B, C);
  }

  /// The vectors of x from the surrogate instead of the full model, lifted by U: first order,
  /// (s Es - As)^-1 Bs b and its transposed counterpart; second order, q = Ps(s)^-1 Bs b and
  /// y = Ps(s)^-T (Cs + s Cvs)' c (Ps(s) = s^2 Ms + s Ds + Ks) in the realisation's vectors
  /// [q; s q] and [(s M + D) y - Cv' c; y]. Divisions in the eigenbasis (dense LU of Ps(s) with
  /// damping that is not proportional): no full factorisation.
  void surrogate_solve_at(Solved& x, bool output) {
    const SurrogateSolves& e = surrogate_solves();
    const Surrogate& g = m_surrogate;
    const Complex s = x.s;
    const Complex i1(0.0, 1.0);
    // Real matrices times complex vectors, part by part (no complex copy of U or X per shift).
    auto times = [&](const Matrix& A, const ComplexVector& z) -> ComplexVector {
      return A * z.real() + i1 * (A * z.imag());
    };
    auto times_t = [&](const Matrix& A, const ComplexVector& z) -> ComplexVector {
      return A.transpose() * z.real() + i1 * (A.transpose() * z.imag());
    };
    if (!m_view->second_order()) {
      const ComplexVector d = (s - e.lambda.cast<Complex>().array()).inverse().matrix();
      x.v = times(g.U, times(e.X, d.cwiseProduct(times_t(e.X, times(g.Bs, x.b)))));
      if (output) {
        x.w = times(g.U, times(e.X, d.cwiseProduct(times_t(e.X, times_t(g.Cs, x.c)))));
      }
      return;
    }
    // Ps(s)^-1 = X (s^2 I + s X'DsX + diag(w^2))^-1 X', the middle factor diagonal under
    // proportional damping, else a dense LU of k x k.
    auto solve = [&](const ComplexVector& rhs) -> ComplexVector {
      const ComplexVector z = times_t(e.X, rhs);
      if (e.dense) {
        ComplexMatrix P = s * e.damping.cast<Complex>();
        P.diagonal() += (s * s + e.w2.cast<Complex>().array()).matrix();
        return times(e.X, P.partialPivLu().solve(z));
      }
      const ComplexVector den =
          (s * s + s * e.damping.diagonal().cast<Complex>().array() + e.w2.cast<Complex>().array())
              .matrix();
      return times(e.X, z.cwiseQuotient(den));
    };
    const auto& so = *m_view->so();
    const Index n = m_view->size();
    const ComplexVector q = times(g.U, solve(times(g.Bs, x.b)));
    x.v.resize(2 * n, 1);
    x.v.col(0) << q, s * q;
    if (!output) return;
    ComplexVector out = times_t(g.Cs, x.c);
    if (g.Cvs.size() > 0) out += s * times_t(g.Cvs, x.c);
    const ComplexVector y = times(g.U, solve(out));
    auto apply = [&](const SparseMatrix& A, const ComplexVector& z) -> ComplexVector {
      return A * z.real() + i1 * (A * z.imag());
    };
    ComplexVector top = s * apply(so.M, y) + apply(so.D, y);
    if (so.has_velocity_output()) top -= so.Cv.transpose().cast<Complex>() * x.c;
    x.w.resize(2 * n, 1);
    x.w.col(0) << top, y;
  }

  /// Orthonormalises the pending vectors against U and extends U and the projections by them.
  void surrogate_extend() {
    Surrogate& g = m_surrogate;
    Matrix Y = std::move(g.pending);
    g.pending = Matrix();
    for (Index j = 0; j < Y.cols(); ++j) {
      const double norm = Y.col(j).norm();
      if (norm > 0.0) Y.col(j) /= norm;
    }
    if (!Y.allFinite()) Y.resize(Y.rows(), 0);
    const double drop = kSurrogateDrop;
    if (g.U.cols() + Y.cols() > surrogate_max_columns()) {
      // Bounded memory (N x the limit doubles) and dense cost: start again from the newest
      // vectors. Not reached on the rail models (the span stops growing near 250-280).
      g = Surrogate{};
      m_surrogate_agreement = std::numeric_limits<double>::infinity();
    }
    if (g.U.cols() > 0) {
      // First pass on every column; the columns already in span U to kSurrogateDrop (most of
      // them once the surrogate has seen the band: rail_5177 stops growing near 250) are
      // dropped before the second pass, which is then cheap.
      Y -= g.U * (g.U.transpose() * Y);
      Index kept = 0;
      for (Index j = 0; j < Y.cols(); ++j) {
        if (Y.col(j).norm() > drop) Y.col(kept++) = Y.col(j);
      }
      Y.conservativeResize(Eigen::NoChange, kept);
      if (kept > 0) Y -= g.U * (g.U.transpose() * Y);
    }
    // Eigen's column-pivoting QR does not accept a matrix without columns.
    Eigen::ColPivHouseholderQR<Matrix> qr;
    if (Y.cols() > 0) qr.compute(Y);
    Index q = 0;
    const Index diag = std::min(Y.rows(), Y.cols());
    while (q < diag && std::abs(qr.matrixQR()(q, q)) > drop) ++q;
    if (q == 0) return;
    Matrix Q = qr.householderQ() * Matrix::Identity(Y.rows(), q);
    if (g.U.cols() > 0) Q -= g.U * (g.U.transpose() * Q);
    Q = Eigen::HouseholderQR<Matrix>(Q).householderQ() * Matrix::Identity(Q.rows(), q);
    const Index k = g.U.cols();
    const std::vector<const SparseMatrix*> ops = surrogate_operators();
    g.P.resize(ops.size());
    for (std::size_t i = 0; i < ops.size(); ++i) {
      const Matrix XQ = *ops[i] * Q;
      Matrix P(k + q, k + q);
      P.topLeftCorner(k, k) = g.P[i];
      if (k > 0) {
        P.topRightCorner(k, q) = g.U.transpose() * XQ;
        P.bottomLeftCorner(q, k) = P.topRightCorner(k, q).transpose();
      }
      P.bottomRightCorner(q, q) = Q.transpose() * XQ;
      g.P[i] = std::move(P);
    }
    auto append_rows = [&](Matrix& X, const Matrix& rows) {
      X.conservativeResize(k + q, rows.cols());
      X.bottomRows(q) = rows;
    };
    auto append_cols = [&](Matrix& X, const Matrix& cols) {
      X.conservativeResize(cols.rows(), k + q);
      X.rightCols(q) = cols;
    };
    if (const auto* ds = std::get_if<DescriptorModel>(m_model)) {
      append_rows(g.Bs, Q.transpose() * ds->B);
      append_cols(g.Cs, ds->C * Q);
    } else {
      const auto& so = std::get<SecondOrderModel>(*m_model);
      append_rows(g.Bs, Q.transpose() * so.B);
      append_cols(g.Cs, so.C * Q);
      if (so.has_velocity_output()) append_cols(g.Cvs, so.Cv * Q);
    }
    g.U.conservativeResize(Q.rows(), k + q);
    g.U.rightCols(q) = Q;
  }
  static constexpr double kSurrogateDrop = 1e-7;

  /// Columns of U before the surrogate starts again: 600 where its poles come from a symmetric
  /// eigenproblem of that size (a descriptor model, or a second-order one with proportional
  /// damping); 300 for other second-order models, whose poles need a nonsymmetric eigenproblem of
  /// twice the size (Eigen: 1 s at 600, 9 s at 1 200). A build at order r adds up to 2 r.
  Index surrogate_max_columns() const {
    return m_view->second_order() && !m_proportional ? 300 : 600;
  }

  /// The order-r model that the two-sided projection of the surrogate at `data` gives, in
  /// pole-residue form: build() for the surrogate in its real block-diagonal modal realisation
  /// (RealModal), whose solves are divisions by 1 x 1 and 2 x 2 blocks.
  static PoleResidues surrogate_reduced(const RealModal& modal, const Interpolation& data) {
    const Index r = data.size();
    Matrix V(modal.size(), r), W(modal.size(), r);
    Index col = 0;
    for (Index i = 0; i < r; ++i) {
      const Complex s = data.shifts[static_cast<std::size_t>(i)];
      if (s.imag() < 0.0) continue;
      const ComplexVector v = modal.solve(s, modal.B.cast<Complex>() * data.b.col(i), false);
      const ComplexVector w =
          modal.solve(s, modal.C.transpose().cast<Complex>() * data.c.col(i), true);
      V.col(col) = v.real();
      W.col(col) = w.real();
      if (s.imag() > 0.0) {
        V.col(col + 1) = v.imag();
        W.col(col + 1) = w.imag();
        col += 2;
      } else {
        col += 1;
      }
    }
    if (col != r) {
      throw NumericalError(fmt::format("{} shifts give {} basis vectors for order {}", r, col, r));
    }
    V = orthonormal_basis(V, "surrogate right");
    W = orthonormal_basis(W, "surrogate left");
    return pole_residues(W.transpose() * V, W.transpose() * modal.apply(V), W.transpose() * modal.B,
                         modal.C * V);
  }

  /// Below the largest order built on the full model (grow_order's shrink phase), once the
  /// surrogate has reproduced the last full build to kSurrogateTrust (relative H2), order r is
  /// IRKA on the surrogate alone: from the warm start (the dominant poles of a larger order) to
  /// the surrogate's fixed point, and the model built there from the surrogate's vectors lifted
  /// by U, a Petrov-Galerkin projection of the full model like any other (the strategy checks its
  /// band error against the full model), with no full factorisation. Each full build at r costs r/2
  /// complex factorisations: on a 5 040-DOF solid about 8 s a shrink step, 5 steps per run.
  /// std::nullopt when this does not apply or the surrogate cannot build the model.
  std::optional<Outcome> surrogate_outcome(Index r) {
    if (!surrogate_active() || !m_options.warm_start || r >= m_built_max_order ||
        !(m_surrogate_agreement <= kSurrogateTrust)) {
      return std::nullopt;
    }
    const RealModal* g = surrogate_model();
    if (g == nullptr || g->size() < r) return std::nullopt;
    try {
      bool converged = false;
      const Interpolation data = surrogate_iterate(start(r), r, m_options.relaxation, converged);
      Outcome out;
      out.built = build(data, false, r, true);
      out.data = data;
      out.converged = converged && unstable_count(out.built.poles.poles) == 0;
      out.reason = fmt::format(
          "IRKA on the surrogate alone ({}; the surrogate of {} vectors reproduced the last full "
          "build to {:.1e} relative H2), no full factorisation",
          converged ? "at its fixed point" : "not converged on it", m_surrogate.U.cols(),
          m_surrogate_agreement);
      return out;
    } catch (const NumericalError&) {
      return std::nullopt;  // IRKA on the full model instead
    }
  }
  static constexpr double kSurrogateTrust = 1e-5;

  /// IRKA of order r on the surrogate from `data`: plain (relaxed by alpha) iterations, each
  /// O(k r + r^3), until the change of shifts and directions is at most `tolerance`, or the
  /// reduced model changed by at most kSurrogateModelFraction x model_tolerance (`converged`), or
  /// kSurrogateIterations are used or a step breaks down; then the step from the iterate of
  /// smallest change (`data` itself when none built). Counts the iterations in
  /// m_surrogate_iterations. `predicted` receives the surrogate's reduced model at the returned
  /// data: the model the true build there should give (none when the surrogate cannot build it).
  Interpolation surrogate_fixed_point(Interpolation data, Index r, double alpha,
                                      std::optional<PoleResidues>& predicted, bool& converged) {
    const Interpolation proposed = surrogate_iterate(std::move(data), r, alpha, converged);
    predicted.reset();
    const RealModal* g = surrogate_model();
    if (g != nullptr && g->size() >= r) {
      try {
        predicted = surrogate_reduced(*g, proposed);
      } catch (const NumericalError&) {
        // No prediction: convergence then needs two true builds.
      }
    }
    return proposed;
  }

  /// The surrogate iteration of surrogate_fixed_point(), without the prediction.
  Interpolation surrogate_iterate(Interpolation data, Index r, double alpha, bool& converged) {
    converged = false;
    const RealModal* g = surrogate_model();
    if (g == nullptr || g->size() < r) return data;
    Interpolation best = data;
    double best_change = std::numeric_limits<double>::infinity();
    std::optional<PoleResidues> previous;
    for (Index it = 0; it < kSurrogateIterations; ++it) {
      ++m_surrogate_iterations;
      Interpolation next;
      PoleResidues reduced;
      try {
        reduced = surrogate_reduced(*g, data);
        Index reflected = 0;
        next = next_shifts(reduced, r, reflected);
      } catch (const NumericalError&) {
        break;
      }
      const double change = data_change(data, next);
      const double model_change = previous ? relative_h2_change(*previous, reduced) / alpha
                                           : std::numeric_limits<double>::infinity();
      previous = std::move(reduced);
      if (change <= m_options.tolerance ||
          (m_options.model_tolerance > 0.0 &&
           model_change <= kSurrogateModelFraction * m_options.model_tolerance)) {
        converged = true;
        return next;
      }
      if (change < best_change) {
        best_change = change;
        best = next;
      }
      data = relax(data, next, alpha);
    }
    return best;
  }
  static constexpr Index kSurrogateIterations = 100;
  static constexpr double kSurrogateModelFraction = 0.1;

  /// The vectors of the previous build() at the same shift and directions (exactly equal: the
  /// data a warm start or a converged iteration repeats), or null.
  const Solved* find_solved(const Solved& x, bool output) const {
    for (const Solved& old : m_solved) {
      if (old.s == x.s && old.b == x.b && (!output || (old.w.size() > 0 && old.c == x.c))) {
        return &old;
      }
    }
    return nullptr;
  }

  /// One factorisation at x.s and the vectors of x: the right vector, and the left one (the
  /// transposed solve) when `output`.
  void solve_at(Solved& x, bool second_order, bool output) {
    FirstOrderView& view = *m_view;
    const Complex s = x.s;
    std::shared_ptr<const Factorization> p;
    try {
      p = view.solver().factorize(s);
    } catch (const NumericalError& e) {
      throw NumericalError(
          fmt::format("factorisation at the shift {} failed: {}", describe(s), e.what()));
    }
    const ComplexMatrix b = x.b, c = x.c;
    if (m_band_integrals) {
      // Frequency-limited: the columns of the band-limited cross Gramians (quadrature.hpp),
      // (s E - A)^-1 (B beta(s) + E L_B) b and (s E - A)^-T (C' beta(s) + E' L_C) c; the
      // position rows (right) and the P(s)^-T rows (left) serve the second-order variant.
      const Complex beta = band_pole_integral(s, m_band);
      const ComplexMatrix rb =
          beta * (m_input * b) + view.apply_e(m_band_integrals->input).cast<Complex>() * b;
      x.v = view.solve(*p, s, rb);
      if (second_order) x.v = x.v.topRows(view.size()).eval();
      if (output) {
        const ComplexMatrix rc =
            beta * (m_output_t * c) +
            view.apply_e_transposed(m_band_integrals->output).cast<Complex>() * c;
        x.w = view.solve_transposed(*p, s, rc);
        if (second_order) x.w = x.w.bottomRows(view.size()).eval();
      }
    } else {
      x.v = second_order ? view.right_second_order(*p, b) : view.right(*p, s, b);
      if (output) x.w = second_order ? view.left_second_order(*p, s, c) : view.left(*p, s, c);
    }
  }

  /// The settings the starting data read (start_shifts.hpp).
  StartSetting start_setting() {
    StartSetting s;
    s.model = m_model;
    s.view = &*m_view;
    s.band = m_band;
    s.real_poles = m_real_poles;
    s.one_sided = m_one_sided;
    s.damping = start_damping();
    s.dense_check_limit = m_options.dense_check_limit;
    return s;
  }
  Interpolation band_shifts(Index r, Index attempt) {
    return irka::band_shifts(start_setting(), r, attempt);
  }
  Interpolation modal_shifts(Index r) { return irka::modal_shifts(start_setting(), r); }
  Interpolation balanced_shifts(Index r) {
    return irka::balanced_shifts(start_setting(), m_balancing, r);
  }

  /// IRKA from the configured start, or with `initial_shifts: best` from each available start
  /// (band or warm, modal, balanced when dense Gramians are affordable), keeping the converged
  /// result with the largest ||Gr||_H2: at a stationary point <G - Gr, Gr> = 0, so
  /// ||G - Gr||^2 = ||G||^2 - ||Gr||^2 and the largest reduced norm is the smallest error, known
  /// without the full model's norm. Unstable or unconverged candidates count only when no
  /// candidate converged. `note` receives which start won.
  Outcome run_from_starts(Index r, bool second_order, std::string& note) {
    if (m_options.start != Options::Start::Best) return run(r, second_order, start(r));
    std::vector<std::pair<std::string, Interpolation>> starts;
    starts.emplace_back(m_options.warm_start && !m_warm.empty() ? "warm/band" : "band", start(r));
    try {
      starts.emplace_back("modal", modal_shifts(r));
    } catch (const Interrupted&) {
      throw;  // the run's stop request (inside ARPACK), not a missing modal start
    } catch (const Error&) {
      // No modal start for this model (e.g. an unsymmetric K): the others remain.
    }
    if (m_view->state_size() <= m_options.dense_check_limit) {
      starts.emplace_back("balanced", balanced_shifts(r));
    }
    std::optional<Outcome> chosen;
    std::string winner;
    double chosen_norm = -1.0;
    std::string tally;
    for (const auto& [name, data] : starts) {
      Outcome o;
      try {
        o = run(r, second_order, data);
      } catch (const NumericalError& e) {
        tally += fmt::format("{}{}: failed", tally.empty() ? "" : ", ", name);
        continue;
      }
      const bool stable = unstable_count(o.built.poles.poles) == 0;
      const double norm2 = stable ? h2_inner(o.built.poles, o.built.poles).real() : -1.0;
      tally += fmt::format("{}{}: {}{}", tally.empty() ? "" : ", ", name,
                           o.converged ? "converged" : "not converged",
                           stable ? fmt::format(" |Gr| {:.6e}", std::sqrt(norm2)) : ", unstable");
      const bool better = !chosen ||
                          (o.converged && stable && !(chosen->converged && chosen_norm >= 0.0)) ||
                          (o.converged == chosen->converged && stable && norm2 > chosen_norm);
      if (better) {
        chosen = std::move(o);
        chosen_norm = norm2;
        winner = name;
      }
    }
    if (!chosen) {
      throw NumericalError(fmt::format("irka r = {}: every start failed ({})", r, tally));
    }
    note = fmt::format("best of {} starts: {} ({}); ", starts.size(), winner, tally);
    return std::move(*chosen);
  }

  /// Restart data: the first restart tries the modal start (unless it was the configured one:
  /// band shifts spread over decades without dynamics give nearly equal vectors, e.g.
  /// triplechain_mess_n1501 at r = 40 breaks down from the band start), later restarts (or when
  /// no modal start exists) band shifts moved along the band and damped.
  Interpolation restart_shifts(Index r, Index attempt) {
    if (attempt == 1 && m_options.start != Options::Start::Modal) {
      try {
        return modal_shifts(r);
      } catch (const Interrupted&) {
        throw;
      } catch (const Error&) {
        // No modal start for this model: band shifts below.
      }
    }
    return band_shifts(r, attempt);
  }

  /// The starting data of a cold start: modal, balanced or band shifts.
  Interpolation first_shifts(Index r) {
    if (m_options.start == Options::Start::Modal) return modal_shifts(r);
    if (m_options.start == Options::Start::Balanced) return balanced_shifts(r);
    return band_shifts(r, 0);
  }

  /// Warm start for order r: the final data of order r if it ran before; for a symmetric definite
  /// model the mirror images of the r dominant poles of the smallest larger order run before;
  /// else the final data of the largest smaller order run before, completed by shifts in the
  /// widest gaps (in log f) of its frequencies (real ones for a one-sided projection); none:
  /// first_shifts.
  Interpolation start(Index r) {
    if (!m_options.warm_start || m_warm.empty()) return first_shifts(r);
    auto it = m_warm.lower_bound(r);
    if (it != m_warm.end() && it->first == r) return it->second.data;
    if (it != m_warm.end() && (m_symmetric || surrogate_active())) {
      // A larger order ran before (grow_order's shrink phase): the mirror images of the r
      // dominant poles of its model. Measured on the symmetric definite rail models only
      // (rail_1357 order 39 -> 34 with no restarts); on cdplayer it moved the order 22 -> 23.
      try {
        Index reflected = 0;
        return next_shifts(it->second.poles, r, reflected);
      } catch (const NumericalError&) {
        // Too few poles to choose r from: from below.
      }
    }
    if (it == m_warm.begin()) return first_shifts(r);
    --it;
    return completed_shifts(start_setting(), it->second.data, r);
  }

  /// IRKA at order r with the safeguards: converged when the shifts and directions change by at
  /// most `tolerance` (relative) on a stable model; cycling (the data return to within a tenth of
  /// the current step to those of 2..10 iterations before), stagnation (no 10 % smaller change
  /// within stagnation_window iterations), an unstable fixed point and breakdowns restart (modal,
  /// then other band shifts) while restarts remain; max_iterations bounds all attempts together.
  /// Not converged: the stable iterate with the smallest change (the iterate with the smallest
  /// change when none was stable), with the reason.
  Outcome run(Index r, bool second_order, const Interpolation& initial) {
    RunState state;
    // One restart beyond `restarts` when no attempt has built a model (a warm start whose first
    // basis breaks down): an error would end the strategy's run, any model lets it go on.
    auto another = [&](Index attempt) {
      return attempt < m_options.restarts || (!state.have_best && attempt == m_options.restarts);
    };
    for (Index attempt = 0; attempt == 0 || another(attempt - 1); ++attempt) {
      Attempt a = begin_attempt(r, attempt, initial, state.iterations);
      Step end = Step::Continue;
      while (end == Step::Continue && state.iterations < m_options.max_iterations) {
        end = iterate_once(r, second_order, a, state);
      }
      if (end == Step::Settled) return std::move(state.best);
      if (end == Step::Stalled) break;
      if (end == Step::Continue) {  // the loop ended on the budget
        state.reason =
            fmt::format("iteration budget max_iterations = {} used up", m_options.max_iterations);
        break;
      }
      if (another(attempt)) ++state.restarts;
    }
    if (!state.have_best) {
      throw NumericalError(
          fmt::format("irka r = {}: no reduced model could be built: {}", r, state.reason));
    }
    Outcome best = std::move(state.best);
    best.converged = false;
    best.reason =
        fmt::format("not converged: {}; smallest change {:.2e}", state.reason, best.shift_change);
    best.iterations = state.iterations;
    best.restarts = state.restarts;
    best.reflected = state.reflected;
    return best;
  }

  /// What run() carries across attempts: the fallback iterate and the counts.
  struct RunState {
    Outcome best;
    bool have_best = false, best_stable = false;
    Index iterations = 0, reflected = 0, restarts = 0;
    std::string reason;  // why the last attempt ended
  };

  /// One attempt's iterate and its history.
  struct Attempt {
    Interpolation data;
    double alpha = 1.0;  // relaxation
    // The surrogate's model at `data`, when the surrogate proposed it, and whether `data` is a
    // fixed point of the surrogate.
    std::optional<PoleResidues> predicted;
    bool surrogate_converged = false;
    std::vector<Interpolation> trail;
    std::optional<PoleResidues> previous;  // of the previous iterate of this attempt
    double best_change = std::numeric_limits<double>::infinity();
    Index best_at = 0;
  };

  /// How one iteration ends: go on, converged (state.best holds the result), restart (reason in
  /// state.reason), or stop the attempts (stalled at the iteration's floor).
  enum class Step { Continue, Settled, Restart, Stalled };

  /// Attempt 0 starts from `initial`; restarts start from other shifts (restart_shifts) with a
  /// halved relaxation (a 2-cycle is an oscillation that damping can turn into convergence).
  Attempt begin_attempt(Index r, Index attempt, const Interpolation& initial, Index iterations) {
    Attempt a;
    a.alpha = attempt == 0 ? m_options.relaxation
                           : std::max(0.25, m_options.relaxation * std::pow(0.5, attempt));
    a.data = attempt == 0 ? initial : restart_shifts(r, attempt);
    a.best_at = iterations;
    // With a surrogate, the start is first moved to the surrogate's fixed point: the vectors of
    // the orders run before make it a close model of G, so the first build lands near the
    // fixed point of order r instead of iterating there one factorisation per shift per step.
    if (surrogate_active() && (m_surrogate.U.cols() > 0 || m_surrogate.pending.cols() > 0)) {
      a.data =
          surrogate_fixed_point(std::move(a.data), r, a.alpha, a.predicted, a.surrogate_converged);
    }
    return a;
  }

  /// One IRKA iteration of attempt `a`: build at a.data, judge the change, and move a.data on.
  Step iterate_once(Index r, bool second_order, Attempt& a, RunState& state) {
    ++state.iterations;
    check_interrupt(fmt::format("irka, iteration {}", state.iterations));
    Built built;
    Interpolation next;
    try {
      built = build(a.data, second_order, r);
      surrogate_add(built);
      next = next_shifts(built.poles, r, state.reflected);
    } catch (const NumericalError& e) {
      state.reason = fmt::format("breakdown at iteration {}: {}", state.iterations, e.what());
      return Step::Restart;
    }
    Measures m;
    m.change = data_change(a.data, next);
    // The model's relative H2 change since the previous iterate, scaled back by the relaxation
    // (a step of alpha moves the model alpha times as far).
    m.model_change = a.previous ? relative_h2_change(*a.previous, built.poles) / a.alpha
                                : std::numeric_limits<double>::infinity();
    a.previous = built.poles;
    // With a surrogate: the true model against the surrogate's model at the same data,
    // predicted before this build's vectors joined the surrogate. Agreement to model_tolerance
    // means the surrogate reproduces G's reduced model where IRKA now stands, so its fixed point
    // (the data just built) is IRKA's to that accuracy: one build per order instead of two
    // (rail_5177: 536 -> 298 factorisations).
    m.predicted_change = a.predicted ? relative_h2_change(*a.predicted, built.poles)
                                     : std::numeric_limits<double>::infinity();
    if (a.predicted) m_surrogate_agreement = m.predicted_change;
    a.predicted.reset();
    m.objective = m_band_integrals ? band_h2_squared_error(*m_band_integrals, &built.model)
                                   : std::numeric_limits<double>::quiet_NaN();
    keep_if_better(built, a.data, m, state);
    // Only a fixed point of the surrogate predicts one of IRKA (an unconverged surrogate run
    // accepted this way ended rail_5177's order 18 at band error 0.23 instead of 0.09).
    const bool predicted_right =
        m_options.model_tolerance > 0.0 && m.predicted_change <= m_options.model_tolerance;
    const bool settled =
        m.change <= m_options.tolerance ||
        (m_options.model_tolerance > 0.0 && m.model_change <= m_options.model_tolerance) ||
        (predicted_right && a.surrogate_converged);
    if (settled) return settle(std::move(built), a.data, m, state);
    if (predicted_right && !a.surrogate_converged) {
      // The surrogate reproduces G's reduced model here, and IRKA on it found no fixed point in
      // kSurrogateIterations: more builds would retrace that iteration at r factorisations a
      // step (rail_5177 at r = 18: 11 builds, then stagnation).
      state.reason = fmt::format(
          "IRKA on the surrogate (which reproduces the model here to {:.2e}) found no fixed "
          "point in {} iterations",
          m.predicted_change, kSurrogateIterations);
      return Step::Stalled;
    }
    if (const Step end = cycle_or_stagnation(a, next, m.change, state); end != Step::Continue) {
      return end;
    }
    a.trail.push_back(a.data);
    a.data = relax(a.data, next, a.alpha);
    // Surrogate: the step goes on to the surrogate's fixed point. The surrogate now also
    // interpolates G (Hermite) at the shifts just built, so its IRKA map there is the true one;
    // the true build at the proposed data still decides convergence, as without it.
    if (surrogate_active()) {
      a.data =
          surrogate_fixed_point(std::move(a.data), r, a.alpha, a.predicted, a.surrogate_converged);
    }
    return Step::Continue;
  }

  /// What one iteration measured of its iterate.
  struct Measures {
    double change = 0.0;            // of the shifts and directions (data_change)
    double model_change = 0.0;      // relative H2 change of the model, per unit relaxation
    double predicted_change = 0.0;  // relative H2 distance to the surrogate's prediction
    double objective = 0.0;         // frequency-limited: the band H2 error; NaN otherwise
  };

  /// The fallback iterate of a run that does not converge: a stable one before any unstable one
  /// (strategies reject unstable models), then the smallest change. Frequency-limited: among
  /// iterates of equal stability, the smallest band H2 error (the objective itself) rather than
  /// the smallest change.
  void keep_if_better(const Built& built, const Interpolation& data, const Measures& m,
                      RunState& state) const {
    const bool stable_now = unstable_count(built.poles.poles) == 0;
    const bool better = m_band_integrals ? m.objective < state.best.band_objective
                                         : m.change < state.best.shift_change;
    if (state.have_best && !(stable_now && !state.best_stable) &&
        !(stable_now == state.best_stable && better)) {
      return;
    }
    state.best.built = built;
    state.best.data = data;
    state.best.shift_change = m.change;
    state.best.model_change = m.model_change;
    state.best.band_objective = m.objective;
    state.best_stable = stable_now;
    state.have_best = true;
  }

  /// A settled iterate: converged when its model is stable (state.best, with the reason), else a
  /// restart: a fixed point whose model has poles with Re >= 0 (reached through reflected
  /// shifts) is not an H2-optimal model.
  Step settle(Built&& built, const Interpolation& data, const Measures& m, RunState& state) {
    if (const Index unstable = unstable_count(built.poles.poles); unstable > 0) {
      state.reason = fmt::format("settled at iteration {} on a model with {} poles of Re >= 0",
                                 state.iterations, unstable);
      return Step::Restart;
    }
    Outcome& best = state.best;
    best.built = std::move(built);
    best.data = data;
    best.shift_change = m.change;
    best.model_change = m.model_change;
    best.band_objective = m.objective;
    best.converged = true;
    if (m.change <= m_options.tolerance) {
      best.reason = fmt::format("converged (change of shifts and directions {:.2e} <= {:.1e})",
                                m.change, m_options.tolerance);
    } else if (m.model_change <= m_options.model_tolerance) {
      best.reason = fmt::format(
          "converged (relative H2 change of the model {:.2e} <= {:.1e}; shifts and directions "
          "still change by {:.2e})",
          m.model_change, m_options.model_tolerance, m.change);
    } else {
      best.model_change = m.predicted_change;
      best.reason = fmt::format(
          "converged (the model differs from the surrogate's prediction by {:.2e} <= {:.1e} "
          "relative H2; shifts and directions still change by {:.2e})",
          m.predicted_change, m_options.model_tolerance, m.change);
    }
    best.iterations = state.iterations;
    best.restarts = state.restarts;
    best.reflected = state.reflected;
    return Step::Settled;
  }

  /// Cycling (back to within a tenth of the step to where the data were 2..10 iterations ago:
  /// a sequence converging linearly never returns closer than it moves) or stagnation (no 10 %
  /// smaller change in stagnation_window iterations) restart the iteration; within 100 x
  /// tolerance of convergence either is the rounding floor of the iteration (the poles of a
  /// two-sided projection carry its conditioning), not a bad start, and ends the attempts.
  Step cycle_or_stagnation(Attempt& a, const Interpolation& next, double change,
                           RunState& state) const {
    bool restart = false;
    const std::size_t depth = std::min<std::size_t>(10, a.trail.size() + 1);
    for (std::size_t j = 2; j <= depth && !restart; ++j) {
      if (data_change(a.trail[a.trail.size() + 1 - j], next) <= 0.1 * change) {
        state.reason = fmt::format("cycling with period {} at iteration {} (change {:.2e})", j,
                                   state.iterations, change);
        restart = true;
      }
    }
    if (!restart && change < 0.9 * a.best_change) {
      a.best_change = change;
      a.best_at = state.iterations;
    } else if (state.iterations - a.best_at >= m_options.stagnation_window) {
      state.reason = fmt::format(
          "stagnation: no 10% smaller change in {} iterations (best {:.2e}, now {:.2e})",
          m_options.stagnation_window, a.best_change, change);
      restart = true;
    }
    if (!restart) return Step::Continue;
    if (change <= 1e2 * m_options.tolerance) {
      state.reason += fmt::format(
          ", within 100 x tolerance: the rounding floor of this model's iteration lies above "
          "tolerance = {:.1e}",
          m_options.tolerance);
      return Step::Stalled;
    }
    return Step::Restart;
  }

  Options m_given;    // as configured
  Options m_options;  // in effect for the model of setup() (symmetric_defaults())
  std::optional<FirstOrderView> m_view;
  // Frequency-limited IRKA: the band integrals L_B, L_C, and B, C' of the first-order state.
  std::optional<BandResolventIntegrals> m_band_integrals;
  double m_band_seconds = 0.0;
  double m_band_norm_squared = 0.0;  // ||G||^2 over the band
  ComplexMatrix m_input, m_output_t;
  const Model* m_model = nullptr;
  Band m_band;
  std::string m_stability;
  bool m_real_poles = false;    // certified real poles (E SPD, A symmetric): real starting shifts
  bool m_symmetric = false;     // descriptor model with E SPD, A symmetric negative definite
  bool m_definite_so = false;   // second-order model with M, D, K SPD
  bool m_proportional = false;  // ... whose surrogate's damping was proportional when last seen
  // How closely the surrogate predicted the last full build (relative H2; infinity: not yet), and
  // the largest order built on the full model: surrogate_outcome() decides by them.
  double m_surrogate_agreement = std::numeric_limits<double>::infinity();
  Index m_built_max_order = 0;
  bool m_one_sided = false;     // first order, W = V (symmetric model; choose_projection())
  bool m_one_sided_so = false;  // second-order variant, W = V
  /// The vectors of the previous build(), per shift and directions: a warm start begins with the
  /// previous order's final data, whose vectors the last build() of that order computed.
  std::vector<Solved> m_solved;
  Index m_reused = 0;  // solves saved by m_solved in this reduce()
  /// The final data of a run at order r and the poles of its model, for warm starts.
  struct Warm {
    Interpolation data;
    PoleResidues poles;
  };
  std::map<Index, Warm> m_warm;
  /// The Galerkin surrogate (surrogate_model()): U orthonormal N x k, the projections U' X U of
  /// the operators (surrogate_operators()), U'B, C U and Cv U, the vectors not yet added, and the
  /// cached modal realisation (none when unusable; `evaluated` once computed for this U).
  struct Surrogate {
    Matrix U, Bs, Cs, Cvs, pending;
    std::vector<Matrix> P;
    std::optional<RealModal> modal;
    bool evaluated = false;
    std::optional<SurrogateSolves> solves;
  };
  Surrogate m_surrogate;
  Index m_surrogate_iterations = 0;  // in this reduce()
  /// The dense square-root balancing of the model (initial_shifts: balanced/best), computed once.
  std::optional<DenseBalancing> m_balancing;
};

void register_reducers(Registry& registry) {
  registry.add(reducer_factory<IrkaReducer>(
      kName,
      "IRKA: H2-optimal interpolation at the mirror images of the reduced poles (tangential, "
      "MIMO); first order, or second-order structure preserved; safeguarded iteration",
      "0.1.0", option_specs(), {}));
}

}  // namespace
}  // namespace ecmor::irka

ECMOR_PLUGIN(ecmor::irka::register_reducers)
