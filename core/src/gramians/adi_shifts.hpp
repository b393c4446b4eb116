// adi_shifts.hpp: the shift sets of the low-rank ADI iteration: Ritz values of the pencil (A, E),
// by projection on the growing factor or by Penzl's Arnoldi heuristic, screened for Re >= 0 and
// thinned by Penzl's min-max selection. Private to core (gramians).
#pragma once

#include <optional>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/gramians/lowrank_adi.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "gramians/adi_ops.hpp"

namespace ecmor::detail {

struct RitzPair {
  Complex value;
  ComplexVector vector;  // in the state space (empty when not needed)
};

/// Penzl's min-max selection (LYAPACK lp_mnmx): from the candidate set R (Re < 0, closed under
/// conjugation, each pair stored once with Im > 0), pick the one minimising the worst ADI
/// contraction max_x |(p - x) / (p + x)| over R, then repeatedly the candidate where the product
/// of the contractions of the shifts chosen so far is largest. A complex candidate counts twice.
std::vector<Complex> select_minmax(const std::vector<Complex>& candidates, Index max_count);

/// A basis of the range of X, orthonormal to working accuracy for its well-determined part:
/// U = X V L^-1/2 over the eigenpairs of X' X above k eps lambda_max (directions below that are
/// rounding). The Ritz values are computed from the generalized projected pencil (U'AU, U'EU), so
/// a slight loss of orthogonality does not bias them; the Gram route is one matrix product,
/// where a pivoted QR of the tall block took seconds at N = 2e4.
Matrix range_basis(const Matrix& X);

/// Where the ADI shifts come from. Unstable Ritz values (Re >= 0) are either eigenvalues of the
/// model (the Gramians do not exist: refused with its name) or artefacts of projecting a
/// non-normal pencil (mirrored); the Ritz pair's backward error tells them apart, see
/// AdiOptions::unstable_ritz_residual. Counts the mirrored values in AdiResult.
class AdiShiftSource {
 public:
  AdiShiftSource(FirstOrderView& view, const AdiRealOps& ops, const AdiOptions& options);

  /// Penzl's heuristic set: Ritz values of E^-1 A and reciprocals of those of A^-1 E, with `e` a
  /// factorisation of E (M for second order). Computed once; the spectra of (A, E) and (A', E')
  /// agree, so the set serves both sides.
  std::vector<Complex> heuristic(const Factorization& e, AdiResult& result);

  /// The min-max selection among the admissible Ritz values of the pencil (A, E) (A', E' with
  /// `transposed`) projected on span(X).
  std::vector<Complex> projection(const Matrix& X, bool transposed, AdiResult& result) const;

 private:
  /// Relative backward error of a Ritz pair: ||A u - theta E u|| / (||A u|| + |theta| ||E u||).
  double ritz_residual(const RitzPair& r, bool transposed) const;
  /// Ritz values with Re >= 0: refuse the model if one is an eigenvalue, else mirror or drop.
  /// Returns the admissible shift candidates (Re < 0, each conjugate pair once with Im > 0).
  std::vector<Complex> admissible(const std::vector<RitzPair>& ritz, bool transposed,
                                  const char* where, AdiResult& result) const;
  /// Ritz pairs of the pencil (A, E) (or (A', E')) projected on span(X).
  std::vector<RitzPair> projected_ritz(const Matrix& X, bool transposed) const;

  FirstOrderView& m_view;
  const AdiRealOps& m_ops;
  const AdiOptions& m_options;
  std::optional<std::vector<Complex>> m_heuristic;
};

}  // namespace ecmor::detail
