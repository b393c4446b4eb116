// balanced.cpp: the "balanced" reducer: balanced truncation (BT) from Gramian factors computed once
// per setup(): first-order square-root and balancing-free square-root BT, the second-order
// variants p, v, pv, vp, fv (Reis and Stykel 2008; Meyer and Srinivasan 1996) returning
// (Mr, Dr, Kr, Br, Cr), and frequency-limited BT on the driver's band (Gawronski and Juang 1990).
// See README.md for the algorithm, the Gramian blocks of each variant and measured numbers.
#include <fmt/format.h>

#include <Eigen/QR>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/linalg/dense_kernels.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/plugin/plugin.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "gramian_factors.hpp"
#include "lowrank_factors.hpp"

namespace ecmor::balanced {
namespace {

constexpr const char* kName = "balanced";
constexpr double kEps = std::numeric_limits<double>::epsilon();

enum class Method { SquareRoot, BalancingFree };
enum class Structure { FirstOrder, SecondOrder };
enum class Variant { P, V, PV, VP, FV };
enum class GramianRoute { Auto, Dense, LowRank };

/// gramians: auto picks the dense route up to this many first-order states and low-rank ADI
/// above. Why 2000: the dense Schur form costs O(n^3) with a large constant (about 30 s at 2000
/// states on the 2-core CI machine, minutes at 3000), while ADI's cost grows with the Gramian's
/// rank, not with n^3.
constexpr Index kAutoDenseStates = 2000;

std::string to_string(Variant v) {
  switch (v) {
    case Variant::P:
      return "p";
    case Variant::V:
      return "v";
    case Variant::PV:
      return "pv";
    case Variant::VP:
      return "vp";
    case Variant::FV:
      return "fv";
  }
  return "?";
}

/// The factor blocks a second-order variant balances (README table), stated once for the
/// balancing (prepare_balancing) and the bases (reduce_second_order). V comes from Zc1 or Zc2
/// (Pp or Pv), balanced against Zo1 or Zo2 (Qp or Qv). W always comes from Zq2 = M^-T Zo2, so it
/// needs a balancing against Qv: the main one, or for a variant balanced against Qp (p, vp) a
/// second one of Pv with Qv; fv is one-sided (W = V).
struct VariantBlocks {
  bool v_from_velocities;   ///< V from Zc2 (Pv); else Zc1 (Pp)
  bool against_velocities;  ///< balanced against Zo2 (Qv); else Zo1 (Qp)
  bool one_sided;           ///< W = V
  /// W needs the second balancing, of Pv with Qv.
  bool w_from_second() const { return !against_velocities && !one_sided; }
};

VariantBlocks blocks_of(Variant v) {
  return {.v_from_velocities = v == Variant::V || v == Variant::VP,
          .against_velocities = v == Variant::V || v == Variant::PV,
          .one_sided = v == Variant::FV};
}

/// The reducer's settings; the initialisers are the defaults, option_specs() the keys, ranges
/// and documentation.
struct Options {
  Method method = Method::SquareRoot;
  Structure structure = Structure::FirstOrder;
  Variant variant = Variant::PV;
  bool band_limited = false;
  double hsv_tolerance = 0.0;  // 0: off
  GramianRoute gramians = GramianRoute::Auto;
  AdiOptions adi;
  bool adi_require_convergence = false;
  // band_limited on the low-rank route.
  AdaptiveQuadratureOptions quadrature = band_quadrature_defaults();
};

/// The option `key` of AdiOptions::specs() (core states its range and documentation once) as
/// this reducer's key adi_<key>, read into Options::adi and given only when `applies` holds. The
/// plugin offers only the ADI keys a user tunes; the others keep core's defaults.
Option<Options> adi_option(const std::string& key, std::function<bool(const Options&)> applies,
                           const std::string& rule) {
  for (const auto& opt : AdiOptions::specs().options())
    if (opt.key() == key) return opt.prefixed("adi_").nested(&Options::adi).only_if(applies, rule);
  throw std::logic_error("AdiOptions::specs() has no option " + key);
}

const OptionSpecs<Options>& option_specs() {
  auto low_rank = [](const Options& o) { return o.gramians != GramianRoute::Dense; };
  const std::string low_rank_only =
      "applies to low-rank Gramians only (gramians: auto or lowrank), not to gramians: dense";
  auto band_low_rank = [](const Options& o) {
    return o.band_limited && o.gramians != GramianRoute::Dense;
  };
  const std::string band_low_rank_only =
      "applies to band_limited: true on the low-rank route only (the dense band Gramians use a "
      "matrix function, no quadrature)";
  static const OptionSpecs<Options> specs({
      choice("method", &Options::method,
             {{"square_root", Method::SquareRoot}, {"balancing_free", Method::BalancingFree}},
             "square_root: V = Zc V_r S_r^-1/2, W = Zq U_r S_r^-1/2 (first order: Er = I); "
             "balancing_free: orthonormal bases of the same subspaces (same transfer function, "
             "better conditioned when s_r is small)"),
      choice("structure", &Options::structure,
             {{"first_order", Structure::FirstOrder}, {"second_order", Structure::SecondOrder}},
             "first_order: BT of the (first-order realisation of the) model, returns E, A, B, C of "
             "order r; second_order: returns Mr, Dr, Kr, Br, Cr of size r (second-order models "
             "only)"),
      choice("variant", &Options::variant,
             {{"p", Variant::P},
              {"v", Variant::V},
              {"pv", Variant::PV},
              {"vp", Variant::VP},
              {"fv", Variant::FV}},
             "which Gramian blocks are balanced (README): p (Pp, Qp), v (Pv, Qv), pv (Pp, Qv), "
             "vp (Pv, Qp), fv (free velocity: Pp, one-sided W = V)")
          .only_if([](const Options& o) { return o.structure == Structure::SecondOrder; },
                   "applies to structure: second_order only (second-order models)"),
      option("band_limited", &Options::band_limited,
             "frequency-limited BT: Gramians restricted to the driver's band (Gawronski-Juang); "
             "no a-priori error bound"),
      option("hsv_tolerance", &Options::hsv_tolerance,
             "caps the order: at most the number of Hankel singular values s_i > hsv_tolerance * "
             "s_1 (max_order(); a larger requested order returns that many states); 0 = off")
          .range(Range::closed_open(0, 1)),
      choice("gramians", &Options::gramians,
             {{"auto", GramianRoute::Auto},
              {"dense", GramianRoute::Dense},
              {"lowrank", GramianRoute::LowRank}},
             "auto: dense up to 2000 first-order states, low-rank ADI above; dense: "
             "Bartels-Stewart on the Schur form (gramian_factors.hpp); lowrank: low-rank ADI "
             "factors through s^2 M + s D + K or s E - A (no 2N matrix)"),
      adi_option("tolerance", low_rank, low_rank_only),
      adi_option("max_iterations", low_rank, low_rank_only),
      adi_option("shifts", low_rank, low_rank_only),
      adi_option("max_shifts", low_rank, low_rank_only),
      option("adi_require_convergence", &Options::adi_require_convergence,
             "true: an ADI run that reaches adi_max_iterations before adi_tolerance fails the "
             "setup (NumericalError with the residuals); false: the approximate Gramians are "
             "truncated, the note carries a warning, adi_converged = 0 and no a-priori bound is "
             "reported")
          .only_if(low_rank, low_rank_only),
      band_quadrature_specs()
          .at("band_quadrature_tolerance")
          .nested(&Options::quadrature)
          .only_if(band_low_rank, band_low_rank_only),
      band_quadrature_specs()
          .at("band_quadrature_budget")
          .nested(&Options::quadrature)
          .only_if(band_low_rank, band_low_rank_only),
  });
  return specs;
}

/// The SVD Zl' Zr = U diag(s) V' of one pair of factors, with the numerical rank of s.
struct Balancing {
  Matrix U, V;
  Vector s;
  Index rank = 0;
  double floor = 0.0;  ///< s_i at or below this are not resolved by the factors (balance())
};

/// Thin SVD of Zl' Zr. Numerical rank: s_i^2 is an eigenvalue of Xr Xl (Xr = Zr Zr', Xl = Zl Zl'),
/// and each Gramian carries an absolute error of about n eps ||X|| (backward-stable solver plus
/// the factor's truncation at that level, gramian_factors.hpp), which moves the eigenvalues of
/// Xr Xl by up to about n eps ||Xr|| ||Xl||. An s_i with s_i^2 below that cannot be told from zero:
/// the floor is s_i > sqrt(n eps trace(Xr) trace(Xl)) (traces bound the 2-norms from above, so the
/// floor errs on the safe side). Rank-deficient directions also make the square-root bases
/// (scaled by s^-1/2) meaningless, another reason not to go below it.
///
/// Factors made of blocks with errors of their own (`block_rows` > 0: the positions and velocities
/// of a second-order model's low-rank factors, GramianFactors::block_rows) are judged where that
/// bound is tightest. Scaling block b of the state by t_b (Zr_b -> t_b Zr_b, Zl_b -> Zl_b / t_b)
/// leaves Zl' Zr and so the s_i unchanged, and each block's error scales with it; the product of
/// traces, sum_b t_b^2 ||Zr_b||^2 times sum_b ||Zl_b||^2 / t_b^2, is smallest (Cauchy-Schwarz) at
/// (sum_b ||Zr_b|| ||Zl_b||)^2. There the floor is sqrt(eps) sum_b ||Zr_b|| ||Zl_b||, without the
/// worst case's factor n: measured against Gramians solved exactly in the equilibrated modal
/// realisation of clamped solids (N = 270 and 540, test
/// LowRankFactorsOfASolidResolveTheHsvsDownToTheirBlockFloor), the low-rank HSVs agree to about
/// 1e-10 s_1 down to 1e-7 s_1 and to 1 % down to 1e-8 s_1, while this floor is 8e-8 .. 9e-8 s_1
/// (and the n eps one 2e-6 .. 3e-6 s_1). Why it matters: on a 3-D solid, velocities are omega
/// times positions, so Zr is dominated by its velocity rows and Zl by its position rows; the
/// unscaled floor stood at 5e-4 .. 1.5e-3 s_1 and capped BT at 14-16 states where plain BT needs
/// 80-90 for a band error of 1e-2 (docs/benchmarks.md, issue 46).
double resolution_floor(const Matrix& Zl, const Matrix& Zr, Index n, Index block_rows) {
  if (block_rows <= 0 || block_rows >= Zr.rows() || Zr.rows() % block_rows != 0 ||
      Zl.rows() != Zr.rows()) {
    return std::sqrt(static_cast<double>(n) * kEps) * Zl.norm() * Zr.norm();
  }
  double sum = 0.0;
  for (Index row = 0; row < Zr.rows(); row += block_rows) {
    sum += Zl.middleRows(row, block_rows).norm() * Zr.middleRows(row, block_rows).norm();
  }
  return std::sqrt(kEps) * sum;
}

Balancing balance(const Matrix& Zl, const Matrix& Zr, Index n, Index block_rows = 0) {
  Balancing b;
  ThinSvd svd = thin_svd(dense_product(Zl, Zr, true, false));
  b.U = std::move(svd.U);
  b.V = std::move(svd.V);
  b.s = std::move(svd.s);
  b.floor = resolution_floor(Zl, Zr, n, block_rows);
  while (b.rank < b.s.size() && b.s(b.rank) > b.floor) ++b.rank;
  return b;
}

/// Orthonormal basis of the columns of X (Householder QR; X has full column rank by construction:
/// r <= numerical rank of the balancing).
Matrix orthonormal(const Matrix& X) {
  const Eigen::HouseholderQR<Matrix> qr(X);
  return qr.householderQ() * Matrix::Identity(X.rows(), X.cols());
}

Index unstable_count(const ComplexVector& p) {
  Index count = 0;
  for (const Complex& z : p) count += z.real() < 0.0 ? 0 : 1;  // NaN counts as unstable
  return count;
}

class BalancedReducer final : public Reducer {
 public:
  explicit BalancedReducer(Options options) : m_options(options) {}

  void setup(const ReductionContext& context) override {
    if (context.model == nullptr || context.solver == nullptr) {
      throw InputError("balanced: setup needs a model and a shifted solver");
    }
    m_view.emplace(*context.model, *context.solver);
    m_band = context.band;
    if (m_options.structure == Structure::SecondOrder && !m_view->second_order()) {
      throw ConfigError(fmt::format(
          "reducer 'balanced': structure: second_order (variant: {}) needs a second-order model "
          "(M, D, K); this model is first order (E, A): use structure: first_order",
          to_string(m_options.variant)));
    }
    if (m_options.band_limited) m_band.validate();
    // Undamped first: its message names D = 0, the cause (K is regular there).
    refuse_undamped(*m_view, "Gramians");
    refuse_pole_at_zero(*m_view, *context.model);
    // The one place the Gramian factors are computed: everything below uses only m_factors.
    m_adi.reset();
    m_factors.reset();
    if (use_lowrank()) {
      AdiSummary summary;
      m_factors = m_options.band_limited
                      ? lowrank_band_gramian_factors(*m_view, m_band, m_options.adi,
                                                     m_options.quadrature, summary)
                      : lowrank_gramian_factors(*m_view, m_options.adi, summary);
      if (!summary.converged() && m_options.adi_require_convergence) {
        const bool adi = summary.controllability.converged && summary.observability.converged;
        throw NumericalError(
            adi ? fmt::format("balanced: the band quadrature did not reach "
                              "band_quadrature_tolerance = {:.3g} within band_quadrature_budget "
                              "= {} evaluations (estimate {:.2e}); raise the budget, or set "
                              "adi_require_convergence: false",
                              m_options.quadrature.relative_tolerance,
                              m_options.quadrature.max_evaluations, summary.quadrature_error)
                : fmt::format(
                      "balanced: low-rank ADI did not reach adi_tolerance = {:.3g} within "
                      "adi_max_iterations = {} ({}); raise adi_max_iterations, or set "
                      "adi_require_convergence: false to truncate the approximate Gramians (the "
                      "band error is still verified by the driver)",
                      m_options.adi.tolerance, m_options.adi.max_iterations, summary.text()));
      }
      m_adi = std::move(summary);
    } else {
      m_factors = dense_gramian_factors(
          *context.model, m_options.band_limited ? std::optional<Band>(m_band) : std::nullopt);
    }
    prepare_balancing();
  }

  ReducerResult reduce(const ReductionRequest& request) override {
    if (!m_factors) throw InputError("balanced: reduce() called before setup()");
    if (!request.points.empty()) {
      throw ConfigError(
          "reducer 'balanced' does not use expansion points (it truncates a balanced "
          "realisation); a strategy that sets points cannot drive it: use grow_order");
    }
    if (request.order < 1) {
      throw InputError(fmt::format("balanced: order = {}: must be >= 1", request.order));
    }
    const auto started = std::chrono::steady_clock::now();
    const Index cap = max_order();
    const Index r = std::min(request.order, cap);
    ReducerResult result;
    const Vector& s = m_main.s;
    if (m_options.structure == Structure::FirstOrder) {
      reduce_first_order(r, result);
    } else {
      reduce_second_order(r, result);
    }
    const double next = r < s.size() ? s(r) : 0.0;
    result.diagnostics["gramian_seconds"] = m_factors->seconds;
    if (m_adi) {
      const AdiResult &c = m_adi->controllability, &o = m_adi->observability;
      result.diagnostics["adi_residual_c"] = c.residual;
      result.diagnostics["adi_residual_o"] = o.residual;
      result.diagnostics["adi_iterations_c"] = static_cast<double>(c.iterations);
      result.diagnostics["adi_iterations_o"] = static_cast<double>(o.iterations);
      result.diagnostics["adi_converged"] = m_adi->converged() ? 1.0 : 0.0;
      result.diagnostics["adi_factorizations"] =
          static_cast<double>(c.factorizations + o.factorizations);
      if (m_adi->band) {
        result.diagnostics["band_integral_evaluations"] =
            static_cast<double>(m_adi->quadrature_evaluations);
        result.diagnostics["band_integral_error"] = m_adi->quadrature_error;
        result.diagnostics["band_integral_seconds"] = m_adi->quadrature_seconds;
      }
    } else {
      result.diagnostics["lyapunov_residual_c"] = m_factors->residual_c;
      result.diagnostics["lyapunov_residual_o"] = m_factors->residual_o;
    }
    result.diagnostics["gramian_rank_c"] = static_cast<double>(m_factors->Zc.cols());
    result.diagnostics["gramian_rank_o"] = static_cast<double>(m_factors->Zq.cols());
    result.diagnostics["hsv_1"] = s.size() > 0 ? s(0) : 0.0;
    result.diagnostics["hsv_r"] = s(r - 1);
    result.diagnostics["hsv_next"] = next;
    // Glover's bound holds for the exact Gramians; truncated ADI factors void it.
    const bool bound = m_options.structure == Structure::FirstOrder && !m_options.band_limited &&
                       (!m_adi || m_adi->converged());
    const double tail = s.size() > r ? s.tail(s.size() - r).sum() : 0.0;
    if (bound) result.diagnostics["error_bound"] = 2.0 * tail;
    const Index unstable = unstable_count(poles(result.model));
    result.diagnostics[kUnstablePolesDiagnostic] = static_cast<double>(unstable);
    result.diagnostics["balanced_seconds"] =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

    std::string what = m_options.structure == Structure::FirstOrder
                           ? "first-order"
                           : fmt::format("second-order {}", to_string(m_options.variant));
    if (m_options.band_limited) what = "frequency-limited " + what;
    result.note =
        fmt::format("{} BT ({}) r = {}: hsv s_1 = {:.3e}, s_r = {:.3e}, s_r+1 = {:.3e}; {}", what,
                    m_options.method == Method::SquareRoot ? "square root" : "balancing-free", r,
                    s.size() > 0 ? s(0) : 0.0, s(r - 1), next,
                    bound ? fmt::format("bound 2 sum(tail) = {:.3e}", 2.0 * tail)
                          : std::string("no a-priori bound"));
    if (r < request.order) {
      result.note += fmt::format("; order {} capped at {} ({})", request.order, r,
                                 r == m_hsv_cap ? "hsv_tolerance" : "numerical rank of the hsv");
    }
    // At the numerical rank the driver cannot grow the order further: say why here, since the
    // strategy's message only says "the reducer delivers at most order r".
    const bool at_rank = r == m_rank && m_rank < m_hsv_cap;
    result.diagnostics["order_limit_reached"] = at_rank ? 1.0 : 0.0;
    if (at_rank) result.note += "; " + limit_text(r);
    if (unstable > 0) result.note += fmt::format("; {} reduced poles with Re >= 0", unstable);
    if (m_adi) {
      result.note += fmt::format(
          "; low-rank ADI Gramians (ranks {} / {}, {} / {} iterations, "
          "residuals {:.2e} / {:.2e})",
          m_factors->Zc.cols(), m_factors->Zq.cols(), m_adi->controllability.iterations,
          m_adi->observability.iterations, m_adi->controllability.residual,
          m_adi->observability.residual);
      const bool adi_ok = m_adi->controllability.converged && m_adi->observability.converged;
      if (!adi_ok) {
        result.note += fmt::format(
            "; WARNING: ADI did not converge to {:.1e} within {} iterations: the Gramians are "
            "approximate{}",
            m_options.adi.tolerance, m_options.adi.max_iterations,
            m_options.structure == Structure::FirstOrder && !m_options.band_limited
                ? " and the a-priori bound does not hold"
                : "");
      }
      if (!m_adi->quadrature_converged) {
        result.note += fmt::format(
            "; WARNING: the band quadrature missed {:.1e} (estimate {:.1e} after {} "
            "evaluations): the band Gramians' right-hand sides are approximate",
            m_options.quadrature.relative_tolerance, m_adi->quadrature_error,
            m_adi->quadrature_evaluations);
      }
    }
    return result;
  }

  /// Names why r = max_order() is the largest order: the resolution floor of the HSVs and, when
  /// the low-rank ADI stopped at its budget, that the Gramians are unconverged (the case of a
  /// lightly damped model such as triplechain_mess_n1501, README "When BT stops early").
  std::string limit_text(Index r) const {
    // Variants p and vp cap the order at the smaller rank of two balancings: name the one that
    // caps it (quoting the main one there read "s_41 = 5.5e-06 is at or below 2.2e-08").
    const bool left_caps = m_left && m_left->rank < m_main.rank;
    const Balancing& b = left_caps ? *m_left : m_main;
    std::string text = fmt::format(
        "BT LIMIT: order {} is the largest this reducer delivers (s_{} = {:.3e}{} is at or below "
        "{:.3e}, the floor at which the Gramian factors resolve Hankel singular values)",
        r, r + 1, r < b.s.size() ? b.s(r) : 0.0,
        left_caps ? " of the velocity balancing that gives W" : "", b.floor);
    if (m_adi && !(m_adi->controllability.converged && m_adi->observability.converged)) {
      text += fmt::format(
          "; cause: low-rank ADI did not converge (residuals {:.2e} / {:.2e} > adi_tolerance "
          "{:.1e} after {} / {} iterations{}), so the Gramians are approximate",
          m_adi->controllability.residual, m_adi->observability.residual, m_options.adi.tolerance,
          m_adi->controllability.iterations, m_adi->observability.iterations, route_text());
      text += m_view->second_order() && m_options.structure == Structure::FirstOrder
                  ? "; try a larger adi_max_iterations with structure: second_order"
                  : "; try a larger adi_max_iterations";
    }
    return text;
  }

  /// How the Gramian route was chosen, for the note.
  std::string route_text() const {
    if (m_options.gramians != GramianRoute::Auto) return "";
    return fmt::format("; gramians: auto took low-rank ADI for {} > {} first-order states",
                       m_view->state_size(), kAutoDenseStates);
  }

  Index max_order() const override {
    if (!m_factors) return kUnlimitedOrder;
    return std::min(m_rank, m_hsv_cap);
  }

 private:
  bool use_lowrank() const {
    switch (m_options.gramians) {
      case GramianRoute::Dense:
        return false;
      case GramianRoute::LowRank:
        return true;
      case GramianRoute::Auto:
        break;
    }
    return m_view->state_size() > kAutoDenseStates;
  }

  /// The SVDs of the products of factor blocks the chosen structure and variant need. Notation:
  /// Zc = [Zc1; Zc2], Zq = [Zq1; Zq2] (position and velocity rows of the first-order state
  /// x = [q; q']), Zo = E' Zq = [Zq1; M' Zq2]: the blocks of P and E'QE are
  ///     Pp = Zc1 Zc1',  Pv = Zc2 Zc2',  Qp = Zo1 Zo1',  Qv = Zo2 Zo2' = M' Q22 M.
  void prepare_balancing() {
    const GramianFactors& g = *m_factors;
    const Index states = g.states;
    if (m_options.structure == Structure::FirstOrder) {
      m_main = balance(g.Zo, g.Zc, states, g.block_rows);
      m_rank = m_main.rank;
    } else {
      const Index n = m_view->size();
      const auto Zc1 = g.Zc.topRows(n), Zc2 = g.Zc.bottomRows(n);
      const auto Zo1 = g.Zo.topRows(n), Zo2 = g.Zo.bottomRows(n);
      const VariantBlocks b = blocks_of(m_options.variant);
      m_main = balance(b.against_velocities ? Zo2 : Zo1, b.v_from_velocities ? Zc2 : Zc1, n);
      // W spans the dominant left singular directions of Zo2' Zc2 mapped back through M^-T, i.e.
      // Zq2 U_v, when the main balancing is not against Qv.
      if (b.w_from_second()) m_left = balance(Zo2, Zc2, n);
      m_rank = std::min(m_main.rank, n);
      if (m_left) m_rank = std::min(m_rank, m_left->rank);
    }
    m_hsv_cap = kUnlimitedOrder;
    if (m_options.hsv_tolerance > 0.0 && m_main.s.size() > 0) {
      Index k = 0;
      while (k < m_main.s.size() && m_main.s(k) > m_options.hsv_tolerance * m_main.s(0)) ++k;
      m_hsv_cap = std::max<Index>(1, k);
    }
    if (m_rank < 1) {
      throw NumericalError(
          "balanced: the Hankel singular values are all at the rounding level of the Gramians "
          "(zero transfer function?)");
    }
  }

  /// Columns of Z * Y_r, scaled by s_r^-1/2 (square root) or orthonormalised (balancing-free).
  Matrix basis(const Matrix& Z, const Matrix& Y, const Vector& s, Index r) const {
    const Matrix X = Z * Y.leftCols(r);
    if (m_options.method == Method::BalancingFree) return orthonormal(X);
    return X * s.head(r).cwiseSqrt().cwiseInverse().asDiagonal();
  }

  void reduce_first_order(Index r, ReducerResult& result) const {
    const GramianFactors& g = *m_factors;
    Matrix V = basis(g.Zc, m_main.V, m_main.s, r);
    Matrix W = basis(g.Zq, m_main.U, m_main.s, r);
    ReducedDescriptorModel fo = m_view->project_first_order(V, W);
    if (m_options.method == Method::SquareRoot) {
      // W' E V = S^-1/2 U' (Zo' Zc) V S^-1/2 = I by construction; its rounding is reported and the
      // exact identity used (square-root BT returns a standard state-space model).
      result.diagnostics["biorthogonality_loss"] =
          (fo.E - Matrix::Identity(r, r)).cwiseAbs().maxCoeff();
      fo.E = Matrix::Identity(r, r);
    }
    result.model = std::move(fo);
    result.V = std::move(V);
    result.W = std::move(W);
  }

  void reduce_second_order(Index r, ReducerResult& result) const {
    const GramianFactors& g = *m_factors;
    const Index n = m_view->size();
    const Matrix Zc1 = g.Zc.topRows(n), Zc2 = g.Zc.bottomRows(n);
    const Matrix Zq2 = g.Zq.bottomRows(n);
    const VariantBlocks b = blocks_of(m_options.variant);
    Matrix V = basis(b.v_from_velocities ? Zc2 : Zc1, m_main.V, m_main.s, r);
    const Balancing& w = b.w_from_second() ? *m_left : m_main;
    Matrix W = b.one_sided ? V : basis(Zq2, w.U, w.s, r);
    // Mr = W'MV, Dr = W'DV, Kr = W'KV, Br = W'B, Cr = CV (+ Cvr = Cv V): the column scalings of
    // the square-root and balancing-free bases give the same transfer function.
    result.model = project(*m_view->so(), V, W);
    result.V = std::move(V);
    result.W = std::move(W);
  }

  Options m_options;
  std::optional<FirstOrderView> m_view;
  Band m_band;
  std::optional<GramianFactors> m_factors;
  std::optional<AdiSummary> m_adi;  // set when the low-rank route ran
  Balancing m_main;                 // its s are the reported Hankel singular values
  std::optional<Balancing> m_left;  // p, vp: the velocity balancing that gives W
  Index m_rank = 0;
  Index m_hsv_cap = kUnlimitedOrder;
};

void register_reducers(Registry& registry) {
  registry.add(reducer_factory<BalancedReducer>(
      kName,
      "balanced truncation from Gramian factors computed once: first-order square root or "
      "balancing-free (a-priori bound 2 sum(tail)), second-order variants p/v/pv/vp/fv, "
      "frequency-limited to the band; dense Gramians for small models, low-rank ADI for large ones",
      "0.1.0", option_specs(), {}));
}

}  // namespace
}  // namespace ecmor::balanced

ECMOR_PLUGIN(ecmor::balanced::register_reducers)
