#pragma once
// Eigen's generalized eigensolver with a convergence query that is safe after a failure.

#include <Eigen/Eigenvalues>

#include "ecmor/base/types.hpp"

namespace ecmor::detail {

/// Eigen::GeneralizedEigenSolver whose converged() may be asked after any compute(). Eigen 3.4's
/// info() asserts that the eigenvalues were computed, so with assertions on it aborts exactly
/// when QZ did not converge, the case it should report (found by the sanitizer run, whose build
/// keeps assertions). converged() asks the underlying RealQZ, which records its status either way.
class QzSolver : public Eigen::GeneralizedEigenSolver<Matrix> {
 public:
  using Eigen::GeneralizedEigenSolver<Matrix>::GeneralizedEigenSolver;
  bool converged() const { return m_realQZ.info() == Eigen::Success; }
};

}  // namespace ecmor::detail
