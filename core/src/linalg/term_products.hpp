#pragma once
// term_products.hpp: the two products with a combination of terms that the sparse solvers
// implement with one routine. Private to the core's sources.
#include <span>

#include "ecmor/linalg/shifted_solver.hpp"

namespace ecmor::detail {

/// A ShiftedSolver whose products y = sum_k w_k T_k x and y = sum_k w_k T_k^T x are both
/// `Solver::apply(weights, x, transposed)`. It adds no virtual function, so a solver derived from
/// it has the vtable of any other ShiftedSolver.
template <class Solver>
class TermProducts : public ShiftedSolver {
 public:
  ComplexMatrix apply_combination(std::span<const Complex> weights,
                                  const ComplexMatrix& x) const final {
    return static_cast<const Solver&>(*this).apply(weights, x, false);
  }
  ComplexMatrix apply_combination_transposed(std::span<const Complex> weights,
                                             const ComplexMatrix& x) const final {
    return static_cast<const Solver&>(*this).apply(weights, x, true);
  }
};

}  // namespace ecmor::detail
