#pragma once
/// \file types.hpp
/// Scalar, vector and matrix types used throughout ecmor's public API.

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <complex>
#include <cstdint>
#include <limits>

namespace ecmor {

using Index = Eigen::Index;
using Real = double;
using Complex = std::complex<double>;

/// Sparse matrices of full models: column-major with 32-bit indices (what CHOLMOD/UMFPACK "di"
/// take).
using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using ComplexSparseMatrix = Eigen::SparseMatrix<Complex, Eigen::ColMajor, int>;
using Matrix = Eigen::MatrixXd;
using ComplexMatrix = Eigen::MatrixXcd;
using Vector = Eigen::VectorXd;
using ComplexVector = Eigen::VectorXcd;

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;
constexpr Index kUnlimitedOrder = std::numeric_limits<Index>::max();

/// s = i 2 pi f for a frequency in Hz.
inline Complex s_from_hz(double f_hz) { return Complex(0.0, kTwoPi * f_hz); }

}  // namespace ecmor
