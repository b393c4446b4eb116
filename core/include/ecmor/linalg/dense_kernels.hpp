#pragma once
/// \file dense_kernels.hpp
/// Large dense matrix products and singular value decompositions by the BLAS and LAPACK (dgemm /
/// zgemm, dgesdd).
///
/// ecmor compiles Eigen with EIGEN_DONT_PARALLELIZE (its parallelism is across frequencies), so an
/// Eigen product runs on one core. The dense Gramian route of balanced truncation multiplies n x n
/// by n x k matrices with n in the thousands and k close to n (triplechain_mess_n1501: n = 3 002,
/// Gramian ranks ~2 400); there the optimised BLAS (OpenBLAS, multi-threaded, by default since
/// issue 27) is several times faster, and so is LAPACK's divide-and-conquer SVD on top of it (the
/// 2 402 x 2 407 products of that model's factors; the whole dense balanced truncation went from
/// 121 s to 85 s when these SVDs moved from Eigen's BDCSVD to dgesdd, docs/benchmarks.md). Called
/// inside an OpenMP parallel region, OpenBLAS runs on the calling thread only. Use these for
/// matrices of that size, Eigen's for the rest.
#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"

namespace ecmor {

/// op(A) op(B), op(X) = X or X' as asked. \throws InputError on inner dimensions that differ.
ECMOR_API Matrix dense_product(const Matrix& A, const Matrix& B, bool transpose_a = false,
                               bool transpose_b = false);
/// A B for complex matrices. \throws InputError on inner dimensions that differ.
ECMOR_API ComplexMatrix dense_product(const ComplexMatrix& A, const ComplexMatrix& B);

/// Thin SVD A = U diag(s) V' (U: rows x k, V: cols x k, k = min(rows, cols), s descending).
struct ThinSvd {
  Matrix U, V;
  Vector s;
};
/// By LAPACK's dgesdd. \throws NumericalError when it does not converge, InputError on a
/// non-finite entry.
ECMOR_API ThinSvd thin_svd(const Matrix& A);

}  // namespace ecmor
