#pragma once
/// \file lowrank_adi.hpp
/// Large-scale generalized Lyapunov equations of the first-order realisation (E, A, B, C) of any
/// full model (FirstOrderView), by the low-rank ADI iteration in its residual-factor form:
///
///     controllability   A X E' + E X A' + B B' = 0,     X ~ Z Z'
///     observability     A' Y E + E' Y A + C' C = 0,     Y ~ Z Z'
///
/// References: P. Benner, P. Kuerschner, J. Saak, "Efficient handling of complex shift parameters
/// in the low-rank ADI method", Numer. Algorithms 62 (2013) (the residual factor W_k and the real
/// double step for a complex conjugate shift pair); the same authors, "Self-generating and
/// efficient shift parameters in ADI methods for large Lyapunov and Sylvester equations", ETNA 43
/// (2014) (projection shifts); T. Penzl, "A cyclic low-rank Smith method for large sparse Lyapunov
/// equations", SIAM J. Sci. Comput. 21 (2000) (the heuristic shifts).
///
/// One ADI step with a shift p (Re p < 0) solves (A + p E) V = W_{k-1}; for a real p
///     W_k = W_{k-1} - 2 p E V,      Z_k = [Z_{k-1}, sqrt(-2 p) V],
/// and for a complex p the pair (p, conj p) is done at once in real arithmetic with one complex
/// solve: with gamma = 2 sqrt(-Re p), delta = Re p / Im p,
///     W_{k+2} = W_k + gamma^2 E (Re V + delta Im V),
///     Z_{k+2} = [Z_k, gamma (Re V + delta Im V), gamma sqrt(delta^2 + 1) Im V].
/// The residual of Z_k Z_k' is exactly R_k = W_k W_k', so ||R_k||_2 = ||W_k' W_k||_2 (an m x m or
/// p x p matrix): the stopping test costs nothing. The observability equation runs the same
/// iteration on (A', E', C').
///
/// Every solve goes through the model's ShiftedSolver: (A + p E) = -(s E - A) at s = -p, so a
/// second-order model solves with P(-p) = p^2 M - p D + K of size N and no 2N matrix is formed
/// (first_order_view.hpp). One factorisation per shift (per conjugate pair), reused by both
/// Gramians and by every cyclic reuse of the shift.
///
/// Which factor is returned for the observability Gramian: Z with Y ~ Z Z' (the Gramian itself),
/// not a factor of E' Y E. Y is what the equation defines, what the residual is measured on and
/// what the dense gramians() returns; E' Z (FirstOrderView::apply_e_transposed) is one sparse
/// product when a factor of E' Y E is wanted (square-root balancing: the Hankel singular values
/// are the singular values of (E' Zo)' Zc).
///
/// Indefinite right-hand sides (LDL' form; J. Saak, N. Lang, H. Mena, "On the benefits of the
/// LDL^T factorization for large-scale differential matrix equation solvers", Linear Algebra Appl.
/// 480, 2015): A X E' + E X A' + G S G' = 0 with a symmetric, possibly indefinite S runs the same
/// iteration from W_0 = G. Every step is a linear map applied to W from the left, so the identities
/// above hold with S in the middle: X_k = L D L' with the same columns L as the plain iteration
/// would build from G, D = diag(S, ..., S) (one S per block of columns; the shift weights
/// sqrt(-2 Re p) stay in L), and the residual is exactly W_k S W_k'. The frequency-limited (band)
/// Gramians (Gawronski and Juang 1990) solve such equations, with G = [E L_b, B],
/// S = [0 I; I 0]: lowrank_band_gramians().

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"
#include "ecmor/gramians/quadrature.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/band.hpp"

namespace ecmor {

template <class O>
class OptionSpecs;

/// Which Lyapunov equation: controllability (A X E' + E X A' + B B' = 0) or observability
/// (A' Y E + E' Y A + C' C = 0).
enum class GramianSide { Controllability, Observability };
ECMOR_API std::string to_string(GramianSide side);

/// How ADI shifts are generated.
enum class AdiShiftStrategy {
  /// Self-generating projection shifts (Benner, Kuerschner, Saak 2014): Ritz values of the pencil
  /// projected on span(B, E^-1 A B) (span(C', E^-T A' C') for observability) at the start, then on
  /// the columns of Z
  /// added since the last shift set; a new set is generated each time a set is used up.
  Projection,
  /// Penzl's heuristic: Ritz values of Arnoldi on E^-1 A and on A^-1 E, a fixed set selected by
  /// Penzl's min-max rule, reused cyclically.
  Heuristic,
};
/// "projection", "heuristic": the names of AdiOptions' `shifts` (the balanced reducer's
/// adi_shifts).
ECMOR_API const std::vector<std::pair<std::string, AdiShiftStrategy>>& adi_shift_strategy_names();
ECMOR_API std::string to_string(AdiShiftStrategy strategy);
/// Parses a name of adi_shift_strategy_names(). \throws ConfigError listing the valid names.
ECMOR_API AdiShiftStrategy parse_adi_shift_strategy(const std::string& name);

/// Options of the low-rank ADI solver. Defaults (the initialisers) are what the tests and
/// benchmarks use; the valid ranges and the documentation of each field are in specs().
struct ECMOR_API AdiOptions {
  /// Stop when ||R_k||_2 / ||B B'||_2 <= tolerance (||G S G'||_2 for an indefinite right-hand
  /// side).
  double tolerance = 1e-10;
  /// Maximum number of ADI iterations (a conjugate pair counts as two, as in M.E.S.S.). A run that
  /// reaches it returns converged = false with the last residual.
  Index max_iterations = 300;
  /// Shift generation.
  AdiShiftStrategy shifts = AdiShiftStrategy::Projection;
  /// At most this many shifts per generated set (a conjugate pair counts as two; the default is
  /// M-M.E.S.S.'s num_desired). When there are more candidates (Ritz values), Penzl's min-max rule
  /// selects them.
  Index max_shifts = 25;
  /// Projection shifts: project on at most this many of the last columns of Z; 0 means
  /// max_shifts times the number of columns of B (C').
  Index projection_columns = 0;
  /// Heuristic shifts: Arnoldi steps on E^-1 A (large eigenvalues).
  Index arnoldi_steps = 30;
  /// Heuristic shifts: Arnoldi steps on A^-1 E (small eigenvalues).
  Index inverse_arnoldi_steps = 20;
  /// A Ritz pair (theta, u) with Re theta >= 0 whose relative residual
  /// ||A u - theta E u|| / (||A u|| + |theta| ||E u||) is at most this is taken as an eigenvalue
  /// of the model: the model is not asymptotically stable and InputError names theta. Ritz values
  /// with Re >= 0 and a larger residual are projection artefacts of a non-normal pencil and are
  /// mirrored to the left half-plane (-Re + i Im).
  double unstable_ritz_residual = 1e-6;
  /// Compress Z at the end to its dominant singular directions (from the eigen-decomposition of
  /// Z' Z), dropping singular values below compression_tolerance * sigma_max(Z): the Gramian
  /// changes by at most that squared, relatively (plus eps).
  bool compress = true;
  /// Relative singular-value tolerance of the compression: the default's dropped part of Z Z' is
  /// below 1e-16 ||Z Z'||, machine precision of the Gramian.
  double compression_tolerance = 1e-8;
  /// Every field as an option (key = field name) with its valid range or choices and its
  /// documentation: the one statement of the rules that validate() applies and of the balanced
  /// plugin's adi_* keys.
  static const OptionSpecs<AdiOptions>& specs();
  /// \throws ConfigError naming the field, its value and the rule (by specs()), e.g.
  ///         "AdiOptions: tolerance = 2: must be in (0, 1)".
  void validate() const;
};

/// One ADI step: a real shift or a complex conjugate pair done as one real double step.
struct AdiStep {
  Complex shift;          ///< p (for a pair: the member with Im p > 0)
  double residual = 0.0;  ///< ||R||_2 / ||B B'||_2 after the step
  Index columns = 0;      ///< columns of Z after the step
};

/// Result of one low-rank ADI run.
struct ECMOR_API AdiResult {
  GramianSide side = GramianSide::Controllability;
  /// The factor: X ~ Z Z' (controllability) or Y ~ Z Z' (observability), state_size() x rank.
  Matrix Z;
  /// Relative residual ||R_k||_2 / ||B B'||_2, one entry per step (steps[i].residual); entry 0
  /// is the initial residual 1 (Z empty).
  std::vector<double> residuals;
  /// The steps in order.
  std::vector<AdiStep> steps;
  /// ADI iterations (shifts applied; a complex pair counts as two).
  Index iterations = 0;
  /// Every shift applied, conjugate partners included, in order.
  std::vector<Complex> shifts;
  /// The last relative residual (residuals.back()); for the compressed Z see lowrank_residual.
  double residual = 1.0;
  bool converged = false;
  /// Columns of Z before compression (equal to Z.cols() without compression).
  Index uncompressed_rank = 0;
  /// Shift sets generated, and Ritz values with Re >= 0 that were mirrored (see AdiOptions).
  Index shift_sets = 0;
  Index mirrored_ritz_values = 0;
  /// Wall-clock seconds of the run, and of its part spent in the solver (factorisations, solves).
  double seconds = 0.0;
  /// Work counted by the model's solver during this run: numeric factorisations (shifts, and the
  /// E / M check) and solved right-hand-side columns. Factorisations reused from an earlier run of
  /// the same LowRankAdi are not counted again.
  Index factorizations = 0;
  Index solves = 0;
  SolverCounters counters;  ///< the full solver counter difference over the run
  /// "converged: residual 8.3e-11 <= 1e-10 after 42 iterations (rank 84)" or the reason it
  /// stopped.
  std::string message;
};

/// Result of a run with an indefinite right-hand side G S G' (LowRankAdi::solve(side, G, S)).
/// The AdiResult fields keep their meaning with B B' replaced by G S G': `residuals` and
/// `residual` are ||W_k S W_k'||_2 / ||G S G'||_2, the exact residual of X_k = L D L'. `Z` is a
/// positive semidefinite factor of X_k (X_k ~ Z Z'), obtained from the eigen-decomposition of
/// R D R' with L = Q R (Householder): the eigenvalues above compression_tolerance^2 times the
/// largest are kept (all positive ones when compress = false), the negative ones are dropped and
/// reported. For an equation whose solution is semidefinite (band Gramians), X_k has negative
/// eigenvalues only as large as its error, so most_negative_eigenvalue measures how honest the
/// truncation to a semidefinite factor was. uncompressed_rank = L.cols().
struct ECMOR_API AdiLdlResult : AdiResult {
  /// X_k = L D L' before the truncation: L (state_size() x k blocks of S's size), with
  /// D = diag(S, ..., S) implicit (`blocks` copies of S). Kept for checks; clear it to save memory.
  Matrix L;
  Index blocks = 0;
  /// The right-hand side factors as used: A X E' + E X A' + G S G' = 0 (controllability form;
  /// the observability side uses A', E').
  Matrix G, S;
  /// ||G S G'||_2, the residual's reference.
  double rhs_norm = 0.0;
  /// Largest eigenvalue of L D L' (0 when L is empty).
  double largest_eigenvalue = 0.0;
  /// The most negative eigenvalue of L D L' divided by the largest (0 when none is negative):
  /// dropped by the truncation to a semidefinite factor.
  double most_negative_eigenvalue = 0.0;
  /// Negative eigenvalues dropped (their count), and the largest positive eigenvalue dropped by
  /// the compression, relative to the largest eigenvalue (0 when none).
  Index negative_eigenvalues = 0;
  double largest_dropped_positive = 0.0;
};

/// The low-rank ADI solver bound to one model's first-order view. It keeps the factorisations
/// of the shifts it used, so that the second Gramian (same pencil) reuses them.
///
/// Throws (from solve()):
///  * InputError when E (M for second order) is singular: "low-rank ADI: E is singular (...): a
///    DAE (index >= 1) is not supported"; when the model is not asymptotically stable: a Ritz value
///    with Re >= 0 that is an eigenvalue (see AdiOptions::unstable_ritz_residual) or on the
///    imaginary axis, named with its residual;
///  * NumericalError on a breakdown, naming the shift and the iteration: a singular shifted
///    matrix A + p E, a non-finite value in the solve or the residual factor.
class ECMOR_API LowRankAdi {
 public:
  /// \throws ConfigError for invalid options. The view (model and solver) must outlive this.
  LowRankAdi(FirstOrderView& view, const AdiOptions& options = {});
  ~LowRankAdi();
  LowRankAdi(const LowRankAdi&) = delete;
  LowRankAdi& operator=(const LowRankAdi&) = delete;

  /// Runs the iteration for one Gramian.
  AdiResult solve(GramianSide side);

  /// Runs the iteration for A X E' + E X A' + G S G' = 0 (controllability side) or
  /// A' X E + E' X A + G S G' = 0 (observability side) with a symmetric, possibly indefinite S,
  /// in the LDL' form of the file comment: X ~ L D L', and a semidefinite factor Z of it (see
  /// AdiLdlResult). The shifts are generated as for solve(side), from G in place of B (C').
  /// \throws InputError when G does not have state_size() rows or has no column, S is not
  ///         square of G's column count, S is not symmetric (to 1e-12 relative), or G or S has a
  ///         non-finite entry, naming the matrix and the rule; otherwise as solve(side).
  AdiLdlResult solve(GramianSide side, const Matrix& G, const Matrix& S);

  /// Number of distinct shift factorisations currently kept.
  Index cached_factorizations() const;
  /// Drops the kept factorisations (they hold the memory of one sparse factor each).
  void clear_cache();

  const AdiOptions& options() const { return m_options; }

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  AdiOptions m_options;
};

/// Both Gramian factors of a model with one LowRankAdi (the shift factorisations are shared).
struct ECMOR_API LowRankGramians {
  AdiResult controllability;  ///< X ~ Zc Zc'
  AdiResult observability;    ///< Y ~ Zo Zo'
};
ECMOR_API LowRankGramians lowrank_gramians(FirstOrderView& view, const AdiOptions& options = {});

/// ||A Z Z' E' + E Z Z' A' + B B'||_2 / ||B B'||_2 (controllability) or the observability
/// analogue, computed from the factors without forming an N x N matrix: with
/// F = [A Z, E Z, B] (or [A' Z, E' Z, C']) the residual is F S F' with S = [0 I 0; I 0 0; 0 0 I],
/// and its 2-norm is that of R S R' for the thin QR F = Q R. O(N (2r + m)^2): an independent check
/// of the residual-factor norm, and the residual of a compressed factor.
/// \throws InputError when Z does not have state_size() rows.
ECMOR_API double lowrank_residual(FirstOrderView& view, const Matrix& Z, GramianSide side);

/// ||A Z Z' E' + E Z Z' A' + G S G'||_2 / ||G S G'||_2 (controllability; observability with A',
/// E'), the residual of a semidefinite factor Z (e.g. AdiLdlResult::Z after the truncation) for an
/// indefinite right-hand side, by the same QR route as lowrank_residual, O(N (2r + k)^2).
/// \throws InputError when Z or G does not have state_size() rows or S is not k x k for G's k
///         columns.
ECMOR_API double lowrank_residual(FirstOrderView& view, const Matrix& Z, GramianSide side,
                                  const Matrix& G, const Matrix& S);

/// Frequency-limited (band) Gramians of large models (Gawronski and Juang 1990; the dense route
/// and its conventions are in plugins/balanced/gramian_factors.hpp). On Omega = +-[w1, w2] rad/s
/// (w = 2 pi f),
///     P_Omega = (1/2pi) int_Omega (iwE - A)^-1 B B' (iwE - A)^-H dw,
///     Q_Omega = (1/2pi) int_Omega (iwE - A)^-H C' C (iwE - A)^-1 dw,
/// and with (iwE - A)^-1 A = iw (iwE - A)^-1 E - I integrated over Omega,
///     A P E' + E P A' + E Lb B' + B Lb' E' = 0,     Lb = (1/2pi) int_Omega (iwE - A)^-1 B dw,
///     A' Q E + E' Q A + E' Lc C + C' Lc' E = 0,     Lc = (1/2pi) int_Omega (iwE - A)^-T C' dw,
/// (Lb, Lc real: Omega is symmetric). Lb = L_B / 2pi and Lc = L_C / 2pi of
/// band_resolvent_integrals(); E' Lc = S' C' for the dense route's S = s(E^-1 A). The right-hand
/// sides are G S G' with G = [E Lb, B] (resp. [E' Lc, C']) and S = [0 I; I 0], indefinite; the
/// solutions are semidefinite (integrals of semidefinite matrices). Q_Omega itself is returned,
/// as for the plain Gramians (E' Zq is a factor of E' Q E).
struct ECMOR_API LowRankBandGramians {
  AdiLdlResult controllability;  ///< P_Omega ~ Zc Zc' (controllability.Z)
  AdiLdlResult observability;    ///< Q_Omega ~ Zq Zq' (observability.Z)
  /// L_B, L_C and the quadrature diagnostics (evaluations, error_estimate, converged), plus the
  /// band rule and the response at its nodes (band H2 norms: band_h2_squared_error()).
  BandResolventIntegrals integrals;
  double quadrature_seconds = 0.0;  ///< wall time of band_resolvent_integrals
  double seconds = 0.0;             ///< wall time of everything
};

/// Both band Gramian factors with one LowRankAdi (shift factorisations shared by the two sides).
/// G's two blocks are scaled to equal norms (G S G' is unchanged: [a X, Y / a] S [a X, Y / a]' =
/// X Y' + Y X'), which keeps the rounding of W S W' at the level of ||G S G'|| when Lb is small.
/// A band quadrature that misses its tolerance is a result: integrals.quadrature.converged is
/// false and both messages say so (lightly damped models with many poles in the band need more
/// than the default 3000 evaluations).
/// \throws ConfigError for an invalid band, ADI or quadrature options; NumericalError when a
///         quadrature node's factorisation fails (a pole on the imaginary axis inside the band);
///         otherwise as LowRankAdi::solve.
ECMOR_API LowRankBandGramians
lowrank_band_gramians(FirstOrderView& view, const Band& band, const AdiOptions& options = {},
                      const AdaptiveQuadratureOptions& quadrature = {});

}  // namespace ecmor
