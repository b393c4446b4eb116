// krylov.cpp: the "krylov" reducer: structure-preserving moment matching (rational Krylov) at one
// or several expansion points, one- or two-sided, block or tangential for MIMO models, with the
// subspaces generated per point by a two-level orthogonal Arnoldi process (toar.hpp). See README.md
// for the algorithm, the parameters, the request semantics and the failure modes.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <list>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/plugin/plugin.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "incremental_projection.hpp"
#include "second_order_view.hpp"
#include "toar.hpp"

namespace ecmor::krylov {
namespace {

constexpr const char* kName = "krylov";

/// The reducer's settings; the initialisers are the defaults, option_specs() the keys, ranges
/// and documentation.
struct Options {
  bool two_sided = false;
  std::vector<double> points_hz;           // configured points s0 = i 2 pi f
  std::vector<double> real_points;         // configured real shifts s0 >= 0 (rad/s)
  std::vector<double> point_moments{1.0};  // blocks per round for each configured point
  Index point_count = 1;
  bool linear_spacing = false;  // point_count points equally spaced in f instead of log f
  Index tangential_directions = 0;
  double deflation_tolerance = 1e-10;
  Index cache_points = 64;
  Index max_moments_per_point = 100;
  // structure: auto reduces a first-order model with second-order structure (second_order_form,
  // symmetric M, D, K, M SPD) through that structure; first_order never looks for it.
  bool structure_auto = true;

  std::size_t configured() const { return points_hz.size() + real_points.size(); }
};

const OptionSpecs<Options>& option_specs() {
  auto no_configured_points = [](const Options& o) { return o.configured() == 0; };
  static const OptionSpecs<Options> specs(
      {
          choice("projection", &Options::two_sided, {{"one_sided", false}, {"two_sided", true}},
                 "one_sided (W = V, k moments per block; keeps SPD M, D, K SPD, hence stable) or "
                 "two_sided (W from the transposed pencil, 2k moments; may lose stability); a "
                 "point's `moments` counts blocks per side either way"),
          option("points", &Options::points_hz,
                 "expansion points as frequencies (s0 = i 2 pi f), inside or outside the band; "
                 "used when a request gives no points")
              .unit("Hz")
              .range(Range::above(0).finite()),
          option("real_points", &Options::real_points,
                 "real expansion points s0 (e.g. 0 for the static response; refused for a model "
                 "with rigid-body modes); after `points`")
              .unit("rad/s")
              .range(Range::at_least(0).finite()),
          option("point_moments", &Options::point_moments,
                 "moment blocks per round for each configured point (points, then real_points; or "
                 "the point_count log-spaced points, low to high); one value applies to all")
              .integers()
              .range(Range::closed(1, 1e6)),
          option("point_count", &Options::point_count,
                 "without points/real_points: p points log-spaced in the band (midpoints of p "
                 "equal sections of [log f_min, log f_max]; 1 = geometric centre)")
              .range(Range::closed(1, 10000))
              .only_if(no_configured_points,
                       "conflicts with points/real_points (give either the points or a count)"),
          choice("point_spacing", &Options::linear_spacing, {{"log", false}, {"linear", true}},
                 "spacing of the point_count points: log (in log f) or linear (in f; midpoints of "
                 "p equal sections of [f_min, f_max], for bands whose resonances crowd the top)")
              .only_if(no_configured_points,
                       "applies to point_count points only, not to points/real_points"),
          option("tangential_directions", &Options::tangential_directions,
                 "0 = full block; l > 0: the l dominant right (input side) / left (output side) "
                 "singular vectors of H(s0) as directions; l >= m (p) means the full block")
              .range(Range::closed(0, 100000)),
          option("deflation_tolerance", &Options::deflation_tolerance,
                 "a vector whose part orthogonal to the basis is below this times its norm is "
                 "dropped")
              .range(Range::closed(1e-15, 1e-2)),
          option("cache_points", &Options::cache_points,
                 "point states (factorisation, Q, Arnoldi coefficients) kept, least recently used "
                 "dropped; a request with more distinct points keeps all of its own for that "
                 "request, unless the run's memory plan allows fewer factorisations")
              .range(Range::closed(1, 1000000)),
          option("max_moments_per_point", &Options::max_moments_per_point,
                 "budget of moment blocks at one point; a request beyond it is an InputError")
              .range(Range::closed(1, 1000000)),
          choice("structure", &Options::structure_auto, {{"auto", true}, {"first_order", false}},
                 "auto: a first-order model that is a second-order one in the state x = [q; q'] "
                 "(ecmor::second_order_form; symmetric M, D, K, M SPD) is reduced through that "
                 "structure, V = blkdiag(V2, V2), which keeps one-sided models stable; orders are "
                 "even (a cap r allows floor(r/2) second-order columns, r = 1 gives order 2); "
                 "first_order: never"),
      },
      {[](const Options& o, const OptionCheck<Options>& c) {
        // point_moments weights the configured points, or without them the point_count ones.
        const std::size_t n = o.point_moments.size();
        if (n > 1 && o.configured() > 0 && n != o.configured()) {
          c.fail(o.point_moments, fmt::format("{} values for {} configured points: give one per "
                                              "point or one for all",
                                              n, o.configured()));
        }
        if (n > 1 && o.configured() == 0 && static_cast<Index>(n) != o.point_count) {
          c.fail(o.point_moments,
                 fmt::format("{} values for {} = {} log-spaced points: give one per point or "
                             "one for all",
                             n, c.key(o.point_count), o.point_count));
        }
      }});
  return specs;
}

/// A configured point, its weight (moment blocks added per round by the grow path) and the key
/// it came from (points, real_points, or point_count for the log-spaced ones).
struct ConfiguredPoint {
  Complex s;
  Index weight = 1;
  const char* key = "point_count";
};

std::string describe(Complex s) {
  if (s.imag() == 0.0) return fmt::format("s0 = {:g}", s.real());
  if (s.real() == 0.0) return fmt::format("f = {:g} Hz (s0 = {:g}i)", s.imag() / kTwoPi, s.imag());
  return fmt::format("s0 = {:g}{:+g}i", s.real(), s.imag());
}

/// True if the symmetric matrix S is positive definite, proven despite rounding: the Cholesky
/// factorisation of S~ - c I succeeds in floating point, where S~ = D S D with D a diagonal of
/// powers of two (exact scaling, equilibrating the diagonal to [1, 4)) and c = 2 (n + 1) u /
/// (1 - (n + 1) u) tr(S~) (u the unit round-off): a successful floating-point Cholesky of S~ - c I
/// with c >= gamma_(n+1) / (1 - gamma_(n+1)) tr(S~) proves S~, hence S, positive definite (S. M.
/// Rump, Verification of positive definiteness, BIT 46 (2006) 433-452; the factor 2 is a safety
/// margin for the rounding of the shift itself; the underflow term is irrelevant at these
/// magnitudes). False means "not proven" (semidefinite, indefinite, or too ill-conditioned for the
/// margin c ~ 1e-15 n^2 relative to the equilibrated diagonal), never "indefinite".
bool proven_positive_definite(const Matrix& S) {
  const Index n = S.rows();
  Vector scale(n);
  for (Index i = 0; i < n; ++i) {
    const double d = S(i, i);
    if (!(d > 0.0) || !std::isfinite(d)) return false;
    scale(i) = std::ldexp(1.0, -(std::ilogb(d) / 2));
  }
  Matrix St = scale.asDiagonal() * S * scale.asDiagonal();  // exact: powers of two
  const double u = std::numeric_limits<double>::epsilon() / 2.0;
  const double nu = static_cast<double>(n + 1) * u;
  const double gamma = nu / (1.0 - nu);
  const double c = 2.0 * gamma / (1.0 - gamma) * St.trace();
  St.diagonal().array() -= c;
  const Eigen::LLT<Matrix> llt(St);
  return llt.info() == Eigen::Success;
}

/// Stability certificate for a reduced second-order model: Mr, Dr, Kr exactly symmetric and each
/// proven positive definite. Then every pole has Re < 0 (for an eigenvector x, the pole solves
/// m s^2 + d s + k = 0 with m = x^H Mr x, d, k real and > 0, whose roots have Re < 0), which is
/// what the eigenvalues would report, without their O(n^3) cost on a 2n x 2n pencil. One-sided
/// projection of a model with symmetric M, D, K gives exactly symmetric reduced matrices
/// (IncrementalProjection mirrors them).
bool certified_stable(const ReducedModel& model) {
  const auto* so = std::get_if<ReducedSecondOrderModel>(&model);
  if (so == nullptr || so->size() == 0) return false;
  for (const Matrix* X : {&so->M, &so->D, &so->K}) {
    if (!(*X == X->transpose()) || !proven_positive_definite(*X)) return false;
  }
  return true;
}

/// One appended moment block: which point (index in the list) and block, and the column counts of
/// V and W after it (W stays 0 for one-sided projection).
struct Segment {
  std::size_t point = 0;
  Index block = 0;
  Index v_end = 0;
  Index w_end = 0;
};

/// Cached state of one expansion point: its factorisation and the engines of both sides.
struct PointState {
  Complex s;
  std::shared_ptr<const Factorization> factorization;
  std::unique_ptr<Engine> right;
  std::unique_ptr<Engine> left;
};

class KrylovReducer final : public Reducer {
 public:
  explicit KrylovReducer(Options options)
      : m_options(std::move(options)), m_cache_limit(m_options.cache_points) {}

  void setup(const ReductionContext& context) override {
    if (context.model == nullptr || context.solver == nullptr) {
      throw InputError("krylov: setup needs a model and a shifted solver");
    }
    if (context.solver->size() != size_of(*context.model)) {
      throw InputError(fmt::format("krylov: the solver has size {}, the model N = {}",
                                   context.solver->size(), size_of(*context.model)));
    }
    m_model = context.model;
    m_solver = context.solver;
    m_structure = detect_structure(context);
    if (m_structure) {
      // From here on the reducer works on the recovered second-order model (its solves answered
      // by the first-order solver); finish() turns each result back into a first-order one.
      m_model = &m_structure->second;
      m_solver = m_structure->solver.get();
    }
    m_band = context.band;
    m_n = size_of(*m_model);
    m_second_order = std::holds_alternative<SecondOrderModel>(*m_model);
    const SparseMatrix* E11 = m_structure ? &m_structure->E11 : nullptr;
    m_grow_projection.emplace(m_model, E11);
    m_points_projection.emplace(m_model, E11);
    std::visit([&](const auto& m) { m_B = m.B; }, *m_model);
    // Output side: C, or Cv when the position output is zero (velocity output): the moments of
    // s g(s) at s0 span the same space as those of g(s). Both non-zero: no single start block.
    if (const auto* so = std::get_if<SecondOrderModel>(m_model)) {
      const bool has_c = so->C.size() > 0 && so->C.cwiseAbs().maxCoeff() > 0.0;
      const bool has_cv = so->has_velocity_output() && so->Cv.cwiseAbs().maxCoeff() > 0.0;
      if (m_options.two_sided && has_c && has_cv) {
        throw ConfigError(
            "reducer 'krylov': projection = two_sided needs one output matrix, but the model has "
            "both a position output C and a velocity output Cv (y = (C + s Cv) q): the left "
            "Krylov space of C + s Cv is not generated by one start block; use projection: "
            "one_sided (which matches the moments of the state, hence of any output)");
      }
      m_output = has_c || !has_cv ? so->C : so->Cv;
      m_velocity_start = !has_c && has_cv;
    } else {
      m_output = std::get<DescriptorModel>(*m_model).C;
    }
    if (m_options.two_sided && (m_output.size() == 0 || m_output.cwiseAbs().maxCoeff() == 0.0)) {
      throw InputError("krylov: two_sided projection needs a non-zero output matrix; C is zero");
    }
    // Configured points (used when a request brings none).
    m_configured.clear();
    std::size_t k = 0;
    auto weight = [&]() {
      const double w = k < m_options.point_moments.size()    ? m_options.point_moments[k]
                       : m_options.point_moments.size() == 1 ? m_options.point_moments[0]
                                                             : 1.0;
      ++k;
      return static_cast<Index>(w);
    };
    for (double f : m_options.points_hz) {
      m_configured.push_back({s_from_hz(f), weight(), "points"});
    }
    for (double s : m_options.real_points) {
      m_configured.push_back({Complex(s, 0.0), weight(), "real_points"});
    }
    if (m_configured.empty()) {
      const Index p = m_options.point_count;
      const double lo = std::log(m_band.f_min_hz), hi = std::log(m_band.f_max_hz);
      for (Index i = 0; i < p; ++i) {
        // Midpoints of p equal sections of [log f_min, log f_max] (p = 1: the geometric centre),
        // or of [f_min, f_max]: the resonances of a chain or a beam crowd the top of a band that
        // spans decades, where log spacing leaves few points.
        const double t = (static_cast<double>(i) + 0.5) / static_cast<double>(p);
        const double f = m_options.linear_spacing
                             ? m_band.f_min_hz + t * (m_band.f_max_hz - m_band.f_min_hz)
                             : std::exp(lo + t * (hi - lo));
        m_configured.push_back({s_from_hz(f), weight()});
      }
    }
    setup_rigid_modes();
    for (const auto& c : m_configured) {
      validate_point(c.s, 1, "configured point");
      refuse_rigid_pole(c.s, c.key);
    }
  }

  ReducerResult reduce(const ReductionRequest& request) override {
    if (m_model == nullptr) throw InputError("krylov: reduce() called before setup()");
    // Per-request bookkeeping: factorizations_reused counts the points of this request only.
    m_touched.clear();
    m_cache_hits = 0;
    if (request.order < 0) {
      throw InputError(fmt::format("krylov: order = {}: must be >= 0", request.order));
    }
    if (request.points.empty() && request.order < 1) {
      throw InputError(
          fmt::format("krylov: order = {}: must be >= 1 when the request gives no expansion points",
                      request.order));
    }
    m_requested_order = request.order;
    // Through the second-order structure every column of the second-order basis V2 gives two
    // first-order states (V = blkdiag(V2, V2)): a cap r allows floor(r / 2) columns, and r = 1
    // the smallest such model, order 2 (the note says so).
    ReductionRequest mapped = request;
    if (m_structure && request.order > 0) mapped.order = std::max<Index>(1, request.order / 2);
    if (!mapped.points.empty()) return reduce_points(mapped);
    return reduce_grow(mapped.order);
  }

  Index max_order() const override {
    const Index n = m_grow.exhausted ? usable(m_grow.V, m_grow.W) : m_n;
    return m_structure ? 2 * n : n;
  }

  /// Two first-order states per second-order column through the second-order structure.
  Index order_step() const override { return m_structure ? 2 : 1; }

 private:
  // ---- second-order structure of a first-order model -----------------------------------------

  /// The recovered second-order model of a first-order one, with the E11 block (projected as
  /// W2' E11 V2 for the first-order reduced model) and its solver view.
  struct Structure {
    Model second;
    SparseMatrix E11;
    std::unique_ptr<SecondOrderView> solver;
  };

  /// The structure to reduce through, or nullptr for the plain path: structure: auto, a
  /// descriptor model that second_order_form() recognises, symmetric D and K, M symmetric positive
  /// definite (then one-sided projection keeps Mr, Dr, Kr symmetric, and SPD ones SPD, which is
  /// what makes the path worth taking), and, two-sided, a single output block.
  std::unique_ptr<Structure> detect_structure(const ReductionContext& context) const {
    if (!m_options.structure_auto) return nullptr;
    const auto* ds = std::get_if<DescriptorModel>(context.model);
    if (ds == nullptr) return nullptr;
    std::optional<SecondOrderModel> so = second_order_form(*ds);
    if (!so) return nullptr;
    // The library's symmetry threshold (is_positive_definite's default). The SLICOT building
    // (build: K and D of build_so, slightly unsymmetric) fails it and keeps the first-order path:
    // the symmetric argument for stability does not hold for it.
    constexpr double kSymmetryTol = 1e-10;
    if (!(relative_asymmetry(so->D) <= kSymmetryTol) ||
        !(relative_asymmetry(so->K) <= kSymmetryTol) ||
        !is_positive_definite(so->M, kSymmetryTol)) {
      return nullptr;
    }
    // Two-sided second-order Krylov needs one output start block (C or Cv, see setup); with both
    // the first-order path, which has one (C = [C1 C2]), is taken.
    const bool has_c = so->C.size() > 0 && so->C.cwiseAbs().maxCoeff() > 0.0;
    if (m_options.two_sided && has_c && so->has_velocity_output()) return nullptr;
    auto st = std::make_unique<Structure>();
    const Index n = so->size();
    st->E11 = ds->E.topLeftCorner(n, n);
    st->second = std::move(*so);
    st->solver =
        std::make_unique<SecondOrderView>(*context.solver, std::get<SecondOrderModel>(st->second));
    return st;
  }

  /// blkdiag(X, X).
  static Matrix block_diagonal(const Matrix& X) {
    Matrix Y = Matrix::Zero(2 * X.rows(), 2 * X.cols());
    Y.topLeftCorner(X.rows(), X.cols()) = X;
    Y.bottomRightCorner(X.rows(), X.cols()) = X;
    return Y;
  }

  /// The first-order reduced model of the reduced second-order model r and F = W2' E11 V2:
  /// Er = blkdiag(F, Mr), Ar = [0 F; -Kr -Dr], Br = [0; Br], Cr = [Cr Cvr], which is
  /// project(first-order model, blkdiag(V2, V2), blkdiag(W2, W2)) since E12 = E21 = 0, A11 = 0,
  /// A12 = E11 and B1 = 0.
  static ReducedDescriptorModel first_order_of(const ReducedSecondOrderModel& r, const Matrix& F) {
    const Index k = r.size();
    ReducedDescriptorModel d;
    d.E = Matrix::Zero(2 * k, 2 * k);
    d.E.topLeftCorner(k, k) = F;
    d.E.bottomRightCorner(k, k) = r.M;
    d.A = Matrix::Zero(2 * k, 2 * k);
    d.A.topRightCorner(k, k) = F;
    d.A.bottomLeftCorner(k, k) = -r.K;
    d.A.bottomRightCorner(k, k) = -r.D;
    d.B = Matrix::Zero(2 * k, r.B.cols());
    d.B.bottomRows(k) = r.B;
    d.C = Matrix::Zero(r.C.rows(), 2 * k);
    d.C.leftCols(k) = r.C;
    if (r.has_velocity_output()) d.C.rightCols(k) = r.Cv;
    return d;
  }

  /// First-order states of n second-order columns (n itself on the plain path).
  Index states(Index n) const { return m_structure ? 2 * n : n; }

  // ---- rigid-body modes -----------------------------------------------------------------------

  /// The rigid-body modes of the (second-order) model reduced: the null space N of K
  /// (rigid_body_modes). Moments at s0 != 0 contain the rigid-body response only approximately
  /// (measured on a free 3-D solid, N = 2 460: 4 of its 6 rigid-body modes at order 24), so a
  /// reduced model would lose some of the full model's poles at s = 0; N is therefore put into V
  /// (and W) ahead of the Krylov vectors: K V e_j = 0 for those columns, so (Kr, Mr) has exactly
  /// the full model's zero eigenvalues (Cauchy interlacing bounds them from above). The analysis
  /// is the core's (shared with the driver through its cache of the last model analysed); a
  /// positive definite K ends it at one Cholesky factorisation and leaves the reducer unchanged.
  /// Through the second-order structure the recovered model is analysed with a solver of its own
  /// (the view factorises only K + s D + s^2 M, not the K - sigma M of the Lanczos step).
  void setup_rigid_modes() {
    m_rigid = RigidBodyModes{};
    m_rigid_basis.resize(m_n, 0);
    if (!m_second_order) return;
    m_rigid =
        m_structure ? rigid_body_modes(m_structure->second) : rigid_body_modes(*m_model, *m_solver);
    if (!m_rigid.decided || m_rigid.count == 0) return;
    // Euclidean-orthonormal like the Krylov columns appended after it (the analysis gives an
    // M-orthonormal basis of the same space).
    orthonormalize_append(m_rigid_basis, m_rigid.basis, {}, m_options.deflation_tolerance);
  }

  /// Columns of V (and W) taken by the rigid-body modes, ahead of the Krylov vectors.
  Index rigid_columns() const { return m_rigid_basis.cols(); }

  /// Refuses an expansion point at which P(s0) = K + s0 D + s0^2 M is K to working precision on
  /// the rigid-body modes: there P(s0) is singular (s0 is a pole of the model), and whether its
  /// factorisation fails is a matter of rounding (on a free 3-D solid the factorisation of K
  /// succeeds and the run ended with order 2 and band error 1.6). On the M-orthonormal null space
  /// N, N' P(s0) N = s0 N'DN + s0^2 I; s0 is refused when its smallest singular value is at most
  /// the rounding level of K's zero eigenvalues (the largest computed one, at least the floor
  /// kRigidFloor of the spectrum scale). s0 = 0 always is. `key`: the option a configured point
  /// came from (ConfigError), nullptr for a request's point `index` (InputError).
  void refuse_rigid_pole(Complex s, const char* key, std::size_t index = 0) const {
    if (m_rigid.count == 0 || m_rigid_basis.cols() == 0) return;
    const SparseMatrix& D = std::get<SecondOrderModel>(*m_model).D;
    const Matrix& N = m_rigid.basis;
    const ComplexMatrix R = s * Matrix(N.transpose() * (D * N)).cast<Complex>() +
                            s * s * ComplexMatrix::Identity(N.cols(), N.cols());
    const double sigma_min =
        Eigen::JacobiSVD<ComplexMatrix>(R).singularValues().minCoeff();  // descending, last
    const double rounding =
        std::max(kRigidFloor * m_rigid.scale, m_rigid.rigid_eigenvalues.cwiseAbs().maxCoeff());
    if (sigma_min > rounding) return;
    const std::string where = key != nullptr ? fmt::format("{}: {}", key, describe(s))
                                             : fmt::format("point {} {}", index, describe(s));
    const std::string what = fmt::format(
        "reducer 'krylov': {} is a pole of the model: it has {} rigid-body mode{} (poles at s = "
        "0; {}), and at this point P(s0) = K + s0 D + s0^2 M is K to working precision on them "
        "(smallest singular value {:.3g} of s0 N'DN + s0^2 I <= {:.3g}, the rounding of K's zero "
        "eigenvalues), hence singular: Krylov cannot expand there. Use a point away from 0, e.g. "
        "points: [{:g}] (f_min of the band, Hz) or real_points: [{:g}] (2 pi f_min, rad/s); the "
        "rigid-body modes are kept anyway (the null space of K is the first {} column{} of V)",
        where, m_rigid.count, m_rigid.count == 1 ? "" : "s", m_rigid.method, sigma_min, rounding,
        m_band.f_min_hz, kTwoPi * m_band.f_min_hz, rigid_columns(),
        rigid_columns() == 1 ? "" : "s");
    if (key != nullptr) throw ConfigError(what);
    throw InputError(what);
  }

  // ---- points --------------------------------------------------------------------------------

  void validate_point(Complex s, Index moments, const std::string& what) const {
    if (!std::isfinite(s.real()) || !std::isfinite(s.imag())) {
      throw InputError(fmt::format("krylov: {} {}: must be finite", what, describe(s)));
    }
    if (s.real() < 0.0) {
      throw InputError(fmt::format(
          "krylov: {} {}: Re(s0) < 0 is not allowed (expansion points lie in the closed right "
          "half plane, away from the poles of a stable model)",
          what, describe(s)));
    }
    if (s.imag() < 0.0) {
      throw InputError(fmt::format(
          "krylov: {} {}: Im(s0) < 0 (f < 0); use the conjugate point, which the real basis "
          "interpolates as well",
          what, describe(s)));
    }
    if (moments < 1) {
      throw InputError(
          fmt::format("krylov: {} {}: moments = {}: must be >= 1", what, describe(s), moments));
    }
    if (moments > m_options.max_moments_per_point) {
      throw InputError(fmt::format("krylov: {} {}: moments = {} exceeds max_moments_per_point = {}",
                                   what, describe(s), moments, m_options.max_moments_per_point));
    }
  }

  /// Makes room for the points of one request: the cached ones move to the front (most recently
  /// used), and the cache holds up to max(cache_points, number of distinct points) states during
  /// this request, so that a request never evicts its own points (which would refactorise them at
  /// every rebuild, e.g. greedy placement with more points than cache_points). States beyond that
  /// bound, least recently used first, are dropped now.
  void reserve_cache(const std::vector<Complex>& request_points) {
    std::vector<Complex> distinct;
    for (const Complex& s : request_points) {
      if (std::find(distinct.begin(), distinct.end(), s) == distinct.end()) distinct.push_back(s);
    }
    for (auto s = distinct.rbegin(); s != distinct.rend(); ++s) {
      const auto it = std::find_if(m_cache.begin(), m_cache.end(),
                                   [&](const PointState& st) { return st.s == *s; });
      if (it != m_cache.end()) m_cache.splice(m_cache.begin(), m_cache, it);
    }
    // The memory plan may allow fewer (ShiftedSolver::reuse_limit): then points are factorised
    // again when they are visited again, instead of the run running out of memory. At least the
    // state in use stays.
    m_cache_limit = std::min(std::max(m_options.cache_points, static_cast<Index>(distinct.size())),
                             std::max<Index>(1, m_solver->reuse_limit()));
    while (static_cast<Index>(m_cache.size()) > m_cache_limit) {
      m_cache.pop_back();
      ++m_evictions;
    }
  }

  /// The cached state of point s (LRU over at most m_cache_limit states, see reserve_cache).
  PointState& state(Complex s) {
    for (auto it = m_cache.begin(); it != m_cache.end(); ++it) {
      if (it->s == s) {
        m_cache.splice(m_cache.begin(), m_cache, it);
        // Count each point once per request: "this request found its factorisation cached".
        if (std::find(m_touched.begin(), m_touched.end(), s) == m_touched.end()) {
          ++m_cache_hits;
          m_touched.push_back(s);
        }
        return m_cache.front();
      }
    }
    const Index terms = m_solver->terms();
    std::vector<Complex> w(static_cast<std::size_t>(terms));
    for (Index k = 0; k < terms; ++k) {
      w[static_cast<std::size_t>(k)] = ipow(s, k);
    }
    PointState st;
    st.s = s;
    try {
      st.factorization = m_solver->factorize_combination(w);
    } catch (const NumericalError& e) {
      // s0 = 0 is the one point a user picks on purpose (the static response): there P(0) = K
      // (or -A), singular for a free-floating body, whose rigid-body modes are poles at 0.
      throw NumericalError(fmt::format(
          "krylov: P(s0) is singular at the expansion point {}: s0 is (numerically) an "
          "eigenvalue of the model{}; move the point ({})",
          describe(s),
          s == Complex(0.0, 0.0) ? " (at s0 = 0: K is singular, e.g. the rigid-body modes of a "
                                   "free-floating body; Krylov works at any point s0 != 0)"
                                 : "",
          e.what()));
    }
    ++m_factorizations;
    m_touched.push_back(s);
    m_cache.push_front(std::move(st));
    while (static_cast<Index>(m_cache.size()) > m_cache_limit) {
      m_cache.pop_back();
      ++m_evictions;
    }
    return m_cache.front();
  }

  Engine& engine(PointState& st, Side side) {
    std::unique_ptr<Engine>& e = side == Side::Right ? st.right : st.left;
    if (!e) {
      const Complex s = st.s;
      Matrix input;
      ComplexMatrix other;
      if (side == Side::Right) {
        input = m_B;
        // H(s0) = (C + s0 Cv) x(s0): the transfer matrix whose right singular vectors give the
        // input directions.
        other = m_output_full(s);
      } else {
        input = m_output.transpose();
        other = m_B.transpose().cast<Complex>();
      }
      const bool real = s.imag() == 0.0 && !st.factorization->is_complex();
      const double tol = m_options.deflation_tolerance;
      const Index l = m_options.tangential_directions;
      if (real) {
        e = std::make_unique<Toar<double>>(*m_solver, st.factorization, s, side, m_second_order,
                                           input, other, l, tol);
      } else {
        e = std::make_unique<Toar<Complex>>(*m_solver, st.factorization, s, side, m_second_order,
                                            input, other, l, tol);
      }
    }
    return *e;
  }

  ComplexMatrix m_output_full(Complex s) const {
    if (const auto* so = std::get_if<SecondOrderModel>(m_model)) {
      ComplexMatrix c = so->C.cast<Complex>();
      if (so->has_velocity_output()) c += s * so->Cv.cast<Complex>();
      return c;
    }
    return std::get<DescriptorModel>(*m_model).C.cast<Complex>();
  }

  /// Appends block `block` of point s of one side to X. Returns false when the point's Krylov
  /// space is exhausted before that block (nothing appended, nothing more to come).
  bool append_block(Complex s, Side side, Index block, Matrix& X) {
    PointState& st = state(s);
    Engine& e = engine(st, side);
    e.extend(block + 1);
    const Index from = e.columns_through(block);
    const Index to = e.columns_through(block + 1);
    if (from == to && e.complete_blocks() == kUnlimitedOrder) return false;
    if (to > from) {
      const Index parts = (to - from) * (e.is_complex() ? 2 : 1);
      const Matrix cols = e.real_columns(from, to);
      m_noise_parts += parts - cols.cols();
      m_basis_deflations +=
          cols.cols() - orthonormalize_append(X, cols, {}, m_options.deflation_tolerance);
    }
    return true;
  }

  /// Appends block `block` of point s to V and, two-sided, to W. Returns false when the point's
  /// Krylov spaces are exhausted before that block. If either side throws (a failed solve, a
  /// breakdown), V, W and the append counters are restored before the exception leaves: otherwise
  /// V could keep the input side's columns with no segment recording them (the grow path keeps V
  /// and W across requests, and strategies catch the error and call again). The engines need no
  /// undo: Toar::step() commits nothing before its checks pass.
  bool append_pair(Complex s, Index block, Matrix& V, Matrix& W) {
    const Index v0 = V.cols(), w0 = W.cols();
    const Index deflations0 = m_basis_deflations, noise0 = m_noise_parts;
    try {
      bool any = append_block(s, Side::Right, block, V);
      if (m_options.two_sided) any = append_block(s, Side::Left, block, W) || any;
      return any;
    } catch (...) {
      V.conservativeResize(Eigen::NoChange, v0);
      W.conservativeResize(Eigen::NoChange, w0);
      m_basis_deflations = deflations0;
      m_noise_parts = noise0;
      throw;
    }
  }

  Index usable(const Matrix& V, const Matrix& W) const {
    return m_options.two_sided ? std::min(V.cols(), W.cols()) : V.cols();
  }

  // ---- grow path (no points in the request) ---------------------------------------------------

  struct GrowState {
    Matrix V, W;
    std::vector<Index> blocks;  // per configured point
    std::vector<bool> done;     // per configured point: exhausted or at its budget
    std::vector<Segment> segments;
    std::size_t cursor = 0;  // next point in the round
    Index sub = 0;           // blocks already added at `cursor` in this round
    bool exhausted = false;
  };

  ReducerResult reduce_grow(Index order) {
    GrowState& g = m_grow;
    if (g.blocks.empty()) {
      // The rigid-body modes first (setup_rigid_modes; none for a positive definite K).
      g.V = m_rigid_basis;
      g.W = m_options.two_sided ? m_rigid_basis : Matrix(0, 0);
      g.blocks.assign(m_configured.size(), 0);
      g.done.assign(m_configured.size(), false);
    }
    std::vector<Complex> configured;
    for (const auto& c : m_configured) configured.push_back(c.s);
    reserve_cache(configured);
    // Round-robin: each point gets `weight` blocks per round, until the order is reached.
    while (usable(g.V, g.W) < order && !g.exhausted) {
      const std::size_t i = g.cursor;
      const ConfiguredPoint& p = m_configured[i];
      if (!g.done[i]) {
        const Index j = g.blocks[i];
        const bool any = append_pair(p.s, j, g.V, g.W);
        if (any) {
          g.segments.push_back({i, j, g.V.cols(), g.W.cols()});
          ++g.blocks[i];
        }
        if (!any || g.blocks[i] >= m_options.max_moments_per_point) g.done[i] = true;
      }
      if (++g.sub >= m_configured[i].weight || g.done[i]) {
        g.sub = 0;
        g.cursor = (g.cursor + 1) % m_configured.size();
      }
      g.exhausted = std::all_of(g.done.begin(), g.done.end(), [](bool d) { return d; });
    }
    std::vector<ExpansionPoint> points;
    for (const auto& c : m_configured) points.push_back({c.s, 0});
    // V and W only grow here (a failed append restores them to their earlier columns), so the
    // projection of their leading columns stays valid for ever.
    return finish(g.V, g.W, *m_grow_projection, g.segments, points, order, g.exhausted, "grow");
  }

  // ---- points path ----------------------------------------------------------------------------

  struct PointsBuild {
    std::vector<ExpansionPoint> points;
    Matrix V, W;
    std::vector<Segment> segments;
    bool valid = false;
  };

  ReducerResult reduce_points(const ReductionRequest& request) {
    const std::vector<ExpansionPoint>& pts = request.points;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      validate_point(pts[i].s, pts[i].moments, fmt::format("point {}", i + 1));
      refuse_rigid_pole(pts[i].s, nullptr, i + 1);
    }
    std::vector<Complex> request_points;
    for (const auto& p : pts) request_points.push_back(p.s);
    reserve_cache(request_points);
    PointsBuild& b = m_points;
    // Reuse the previous V (and W) up to the last point the new list extends: all earlier
    // points equal, that one at the same s with at least as many moments.
    std::size_t keep_points = 0;  // points whose segments are kept
    if (b.valid) {
      while (keep_points < b.points.size() && keep_points < pts.size() &&
             b.points[keep_points] == pts[keep_points]) {
        ++keep_points;
      }
      if (keep_points < b.points.size() && keep_points < pts.size() &&
          b.points[keep_points].s == pts[keep_points].s &&
          b.points[keep_points].moments <= pts[keep_points].moments) {
        ++keep_points;
      }
    }
    // The rigid-body modes lead every V (and W): kept whatever the points (setup_rigid_modes).
    Index v_keep = rigid_columns(), w_keep = m_options.two_sided ? rigid_columns() : 0;
    std::vector<Segment> segments;
    std::vector<Index> have(pts.size(), 0);
    for (const Segment& s : b.segments) {
      if (s.point >= keep_points) break;
      segments.push_back(s);
      v_keep = s.v_end;
      w_keep = s.w_end;
      have[s.point] = s.block + 1;
    }
    m_reused_columns = b.valid ? v_keep - rigid_columns() : 0;
    // The kept columns are copied bit for bit below, so their projection stays valid (one-sided, W
    // has no columns and w_keep = 0).
    m_points_projection->keep(!b.valid              ? 0
                              : m_options.two_sided ? std::min(v_keep, w_keep)
                                                    : v_keep);
    Matrix V = b.valid ? Matrix(b.V.leftCols(v_keep)) : m_rigid_basis;
    Matrix W = !m_options.two_sided ? Matrix(0, 0)
               : b.valid            ? Matrix(b.W.leftCols(w_keep))
                                    : m_rigid_basis;
    // Points whose segments were kept but whose Krylov space ran out earlier have fewer
    // segments than moments; continuing them appends nothing, which is right.
    for (std::size_t i = 0; i < pts.size(); ++i) {
      for (Index j = have[i]; j < pts[i].moments; ++j) {
        if (!append_pair(pts[i].s, j, V, W)) break;
        segments.push_back({i, j, V.cols(), W.cols()});
      }
    }
    b.points = pts;
    b.V = V;
    b.W = W;
    b.segments = segments;
    b.valid = true;
    std::vector<ExpansionPoint> points = pts;
    for (auto& p : points) p.moments = 0;
    return finish(V, W, *m_points_projection, segments, points, request.order, false, "points");
  }

  // ---- result -----------------------------------------------------------------------------------

  /// Number of poles of `model` with Re >= 0 (NaN counts: a pole we cannot place is not known to
  /// be stable). Exact, and cheap where possible: 0 when certified_stable() proves it (one-sided
  /// projections of symmetric models: Cholesky factorisations of n x n matrices instead of the
  /// eigenvalues of a 2n x 2n pencil); otherwise the eigenvalues (ecmor::poles, which reuses them
  /// for a model it saw recently, so the estimator's pole samples cost nothing more).
  /// `certified`: the caller has proven every pole stable (certified_stable, lift_to_first_order).
  /// Sets m_last_zero_poles to those of them in the full model's disc of rigid-body poles (|s| <=
  /// sqrt(zero_bound), see reduced_model_stability), 0 without rigid-body modes.
  Index unstable_poles(const ReducedModel& model, bool certified) {
    m_last_certified = false;
    m_last_zero_poles = 0;
    if (certified) {
      m_last_certified = true;
      return 0;
    }
    const ComplexVector p = poles(model);
    ++m_pole_requests;
    const double zero_radius = m_rigid.count > 0 ? std::sqrt(m_rigid.zero_bound) : 0.0;
    Index unstable = 0;
    for (Index i = 0; i < p.size(); ++i) {
      if (!(p[i].real() < 0.0)) {
        ++unstable;
        if (std::abs(p[i]) <= zero_radius) ++m_last_zero_poles;
      }
    }
    return unstable;
  }

  /// What a result delivers: its columns and the moments they match.
  struct Delivered {
    Index n = 0;             ///< columns of V (and W) returned
    bool capped = false;     ///< n is the requested order, below the columns built
    bool block_cut = false;  ///< some point's last block lies partly beyond the n columns
    std::vector<ExpansionPoint> points;  ///< each s once, with its moment blocks matched (or 0)
    Index repeats = 0;                   ///< repeated points merged into one
    Index total_moments = 0;             ///< moment blocks matched, over all points
    Index used_points = 0;               ///< points with at least one block matched
  };

  /// The columns returned (all usable ones, or the requested order) and the moments they match:
  /// the complete blocks inside them. ExpansionPoint::moments counts moment blocks per side: k
  /// blocks match k moments at s0 (and conj(s0)) one-sided, 2k two-sided (k blocks in V and k in
  /// W).
  Delivered delivered(const Matrix& V_all, const Matrix& W_all,
                      const std::vector<Segment>& segments, std::vector<ExpansionPoint> points,
                      Index order) const {
    const bool two = m_options.two_sided;
    Delivered out;
    out.n = usable(V_all, W_all);
    out.capped = order > 0 && out.n > order;
    if (out.capped) out.n = order;
    for (const Segment& s : segments) {
      if (s.v_end <= out.n && (!two || s.w_end <= out.n)) {
        points[s.point].moments = s.block + 1;
      } else {
        out.block_cut = true;
      }
    }
    out.points = merged(points, out.repeats);
    for (const auto& p : out.points) {
      out.total_moments += p.moments;
      if (p.moments > 0) ++out.used_points;
    }
    return out;
  }

  /// Repeated points (optimisers place several at one frequency: DIRECT-L's first sample is the
  /// box centre, BOBYQA pushes points onto a bound) share one engine, so a later copy's blocks
  /// add no columns (they deflate): each s once, with the largest moment count of its copies, so
  /// that the points, the moments and the note do not overstate the model. `repeats`: the copies
  /// merged.
  static std::vector<ExpansionPoint> merged(const std::vector<ExpansionPoint>& points,
                                            Index& repeats) {
    std::vector<ExpansionPoint> distinct;
    for (const auto& p : points) {
      const auto it = std::find_if(distinct.begin(), distinct.end(),
                                   [&](const ExpansionPoint& q) { return q.s == p.s; });
      if (it == distinct.end()) {
        distinct.push_back(p);
      } else {
        it->moments = std::max(it->moments, p.moments);
        ++repeats;
      }
    }
    return distinct;
  }

  /// V, W and the reduced model of their first n columns, = project(*m_model, V, W) computing
  /// only the columns not projected before; through the second-order structure, lifted back to
  /// the first-order model. `certified`: every pole is proven stable (certified_stable()).
  ReducerResult projected(const Matrix& V_all, const Matrix& W_all,
                          IncrementalProjection& projection, Index n, bool& certified) const {
    const bool two = m_options.two_sided;
    ReducerResult result;
    result.V = V_all.leftCols(n);
    result.W = two ? Matrix(W_all.leftCols(n)) : result.V;
    projection.extend(V_all, W_all, n, two);
    result.model = projection.model(n);
    certified = certified_stable(result.model);
    if (m_structure) lift_to_first_order(result, projection.extra(n), certified);
    return result;
  }

  /// Back to the first-order model: V = blkdiag(V2, V2), W = blkdiag(W2, W2), F = W2' E11 V2. Its
  /// reduced pencil s Er - Ar = [s F, -F; Kr, s Mr + Dr] has det = det(F) det(s^2 Mr + s Dr + Kr),
  /// so with F nonsingular its poles are those of the second-order reduced model: the
  /// certificate of (Mr, Dr, Kr) carries over once F is proven positive definite (one-sided with
  /// E11 exactly symmetric, F is exactly symmetric: mirrored by the projection).
  void lift_to_first_order(ReducerResult& result, const Matrix& F, bool& certified) const {
    certified = certified && F == F.transpose() && proven_positive_definite(F);
    result.model = first_order_of(std::get<ReducedSecondOrderModel>(result.model), F);
    result.V = block_diagonal(result.V);
    result.W = m_options.two_sided ? block_diagonal(result.W) : result.V;
  }

  /// Diagnostics of the bases (orthogonality, and two-sided the condition of W'V), of the
  /// engines of the cached points, and the cache and work counters.
  void add_diagnostics(std::map<std::string, double>& d, const IncrementalProjection& projection,
                       const Delivered& got, const std::string& path) const {
    const Index n = got.n;
    d["orthogonality_loss"] = projection.orthogonality_loss_v(n);
    if (m_options.two_sided) {
      d["orthogonality_loss_W"] = projection.orthogonality_loss_w(n);
      const Matrix G = projection.wtv(n);
      if (G.size() > 0) {
        const Eigen::JacobiSVD<Matrix> svd(G);
        const Vector sv = svd.singularValues();
        d["wtv_condition"] = sv(sv.size() - 1) > 0.0 ? sv(0) / sv(sv.size() - 1)
                                                     : std::numeric_limits<double>::infinity();
      }
    }
    double q_loss = 0.0, u_loss = 0.0;
    Index deflated = 0, solves = 0;
    for (const auto& st : m_cache) {
      for (const Engine* e : {st.right.get(), st.left.get()}) {
        if (e == nullptr) continue;
        q_loss = std::max(q_loss, e->orthogonality_loss());
        u_loss = std::max(u_loss, e->coefficient_orthogonality_loss());
        deflated += e->stats().candidate_deflations + e->stats().q_deflations;
        solves += e->stats().solves;
      }
    }
    d["q_orthogonality_loss"] = q_loss;
    d["arnoldi_orthogonality_loss"] = u_loss;
    d["deflated_vectors"] = static_cast<double>(deflated);
    d["basis_deflations"] = static_cast<double>(m_basis_deflations);
    d["noise_parts_dropped"] = static_cast<double>(m_noise_parts);
    d["factorizations"] = static_cast<double>(m_factorizations);
    d["factorizations_reused"] = static_cast<double>(m_cache_hits);
    d["cache_evictions"] = static_cast<double>(m_evictions);
    d["cached_points"] = static_cast<double>(m_cache.size());
    d["cached_solves"] = static_cast<double>(solves);
    d["points"] = static_cast<double>(got.used_points);
    d["moments"] = static_cast<double>(got.total_moments);
    if (path == "points") d["reused_columns"] = static_cast<double>(m_reused_columns);
  }

  /// The note's account of the basis: points, moments and sides, then what cut or trimmed it.
  std::string basis_note(const Matrix& V_all, const Matrix& W_all, const Delivered& got,
                         Index order, bool exhausted, const std::string& path) const {
    const bool two = m_options.two_sided;
    const Index n = got.n;
    std::string note = fmt::format(
        "{} point{}, {} moment{}, {}", got.used_points, got.used_points == 1 ? "" : "s",
        got.total_moments, got.total_moments == 1 ? "" : "s", two ? "two-sided" : "one-sided");
    const Index l = m_options.tangential_directions;
    if (l > 0) note += fmt::format(", tangential ({} direction{})", l, l == 1 ? "" : "s");
    if (two && m_velocity_start) note += ", output side from Cv (velocity output)";
    if (got.repeats > 0) {
      note += fmt::format("; {} repeated point{} merged", got.repeats, got.repeats == 1 ? "" : "s");
    }
    if (got.block_cut && got.capped) {
      note += fmt::format("; last block cut at order {}", states(n));
    }
    if (two && V_all.cols() != W_all.cols() && !got.capped) {
      note += fmt::format("; {} trimmed from {} to {} columns to match {} (deflation)",
                          V_all.cols() > W_all.cols() ? "V" : "W",
                          states(std::max(V_all.cols(), W_all.cols())), states(n),
                          V_all.cols() > W_all.cols() ? "W" : "V");
    }
    if (path == "grow" && n < order) {
      note +=
          fmt::format("; order {} requested, {} available ({})", m_requested_order, states(n),
                      exhausted ? "Krylov subspaces exhausted or moment budget used" : "deflation");
    } else if (m_structure && m_requested_order % 2 == 1 && states(n) != m_requested_order) {
      note += fmt::format("; order {} requested, {} delivered (two states per second-order column)",
                          m_requested_order, states(n));
    }
    return note;
  }

  /// The rigid-body modes ahead of the Krylov vectors (setup_rigid_modes): the diagnostic and the
  /// note's part. A cap below their number leaves some out, and the stability rule then names the
  /// model as keeping fewer.
  std::string rigid_note(Index n, std::map<std::string, double>& d) const {
    const Index rigid_in_basis = std::min(rigid_columns(), n);
    d["rigid_modes_in_basis"] = static_cast<double>(rigid_in_basis);
    if (rigid_columns() == 0) return "";
    return rigid_in_basis == rigid_columns()
               ? fmt::format("; {} rigid-body mode{} (null space of K) first in the basis",
                             rigid_in_basis, rigid_in_basis == 1 ? "" : "s")
               : fmt::format(
                     "; only {} of the {} rigid-body modes (null space of K) in the "
                     "basis: order {} is below their number",
                     rigid_in_basis, rigid_columns(), states(n));
  }

  /// Stability: reported, never hidden or repaired. Sets the result's pole diagnostics and returns
  /// the note's part.
  std::string stability_note(ReducerResult& result, bool certified) {
    auto& d = result.diagnostics;
    std::string note;
    try {
      const Index unstable = unstable_poles(result.model, certified);
      d[kUnstablePolesDiagnostic] = static_cast<double>(unstable);
      // Poles at s = 0 from the rigid-body modes are the full model's (the stability rule judges
      // them); only the others mean that the projection lost stability.
      const Index away = unstable - m_last_zero_poles;
      if (away > 0) {
        note += fmt::format("; {} projection lost stability: {} pole{} with Re >= 0{}",
                            m_options.two_sided ? "two-sided" : "one-sided", away,
                            away == 1 ? "" : "s", m_last_zero_poles > 0 ? " away from s = 0" : "");
      }
    } catch (const Error& e) {
      d[kUnstablePolesDiagnostic] = std::numeric_limits<double>::quiet_NaN();
      note += std::string("; poles not computed: ") + e.what();
    }
    d["stability_certified"] = m_last_certified ? 1.0 : 0.0;
    d["pole_requests"] = static_cast<double>(m_pole_requests);
    return note;
  }

  ReducerResult finish(const Matrix& V_all, const Matrix& W_all, IncrementalProjection& projection,
                       const std::vector<Segment>& segments, std::vector<ExpansionPoint> points,
                       Index order, bool exhausted, const std::string& path) {
    const Delivered got = delivered(V_all, W_all, segments, std::move(points), order);
    bool certified = false;
    ReducerResult result = projected(V_all, W_all, projection, got.n, certified);
    for (const auto& p : got.points) {
      if (p.moments > 0) result.points.push_back(p);
    }
    auto& d = result.diagnostics;
    add_diagnostics(d, projection, got, path);
    std::string note = basis_note(V_all, W_all, got, order, exhausted, path);
    d["second_order_structure"] = m_structure ? 1.0 : 0.0;
    if (m_structure) note += "; second-order structure of the first-order model used (x = [q; q'])";
    note += rigid_note(got.n, d);
    note += stability_note(result, certified);
    result.note = note;
    return result;
  }

  Options m_options;
  const Model* m_model = nullptr;
  ShiftedSolver* m_solver = nullptr;
  Band m_band;
  Index m_n = 0;  // size of the model reduced (n = N / 2 through the second-order structure)
  bool m_second_order = true;
  std::unique_ptr<Structure> m_structure;  // set: reducing through the second-order structure
  Index m_requested_order = 0;             // order of the current request, as given
  Matrix m_B;
  Matrix m_output;  // p x N start of the output side (C, or Cv for velocity outputs)
  bool m_velocity_start = false;
  std::vector<ConfiguredPoint> m_configured;
  std::list<PointState> m_cache;  // most recently used first
  Index m_factorizations = 0;
  Index m_cache_hits = 0;    // points of the current request found cached (reset per request)
  Index m_cache_limit = 64;  // cache bound of the current request (reserve_cache)
  Index m_evictions = 0;
  Index m_basis_deflations = 0;
  Index m_noise_parts = 0;
  Index m_reused_columns = 0;
  std::vector<Complex> m_touched;  // points accessed by the current request
  GrowState m_grow;
  PointsBuild m_points;
  // Projections of the two paths' bases (set up in setup(): they need the model).
  std::optional<IncrementalProjection> m_grow_projection, m_points_projection;
  Index m_pole_requests = 0;      // models whose poles this reducer asked for (cumulative)
  bool m_last_certified = false;  // the last count came from certified_stable()
  Index m_last_zero_poles = 0;    // of the last count, poles in the rigid-body disc around s = 0
  RigidBodyModes m_rigid;         // of the model reduced (setup_rigid_modes)
  Matrix m_rigid_basis;           // m_n x count, Euclidean-orthonormal basis of null(K)
};

void register_reducers(Registry& registry) {
  registry.add(reducer_factory<KrylovReducer>(
      kName,
      "moment matching (rational Krylov) by a two-level orthogonal Arnoldi process: multipoint, "
      "one- or two-sided, block or tangential, second order preserved",
      "0.1.0", option_specs(), {true, true, true}));
}

}  // namespace
}  // namespace ecmor::krylov

ECMOR_PLUGIN(ecmor::krylov::register_reducers)
