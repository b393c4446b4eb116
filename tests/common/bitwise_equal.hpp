#pragma once
/// \file bitwise_equal.hpp
/// Exact comparisons for I/O round trips: same sizes and the same doubles bit for bit (a written
/// and re-read matrix must not change in its last digit), for matrices and for whole models.

#include <algorithm>
#include <cstring>
#include <variant>

#include "ecmor/model/model.hpp"

namespace ecmor::test {

inline bool bitwise_equal(const Matrix& A, const Matrix& B) {
  return A.rows() == B.rows() && A.cols() == B.cols() &&
         (A.size() == 0 || std::memcmp(A.data(), B.data(),
                                       sizeof(double) * static_cast<std::size_t>(A.size())) == 0);
}

/// The same pattern (stored entries) and the same values bit for bit.
inline bool bitwise_equal(const SparseMatrix& A_in, const SparseMatrix& B_in) {
  SparseMatrix A = A_in, B = B_in;
  A.makeCompressed();
  B.makeCompressed();
  return A.rows() == B.rows() && A.cols() == B.cols() && A.nonZeros() == B.nonZeros() &&
         std::equal(A.outerIndexPtr(), A.outerIndexPtr() + A.cols() + 1, B.outerIndexPtr()) &&
         std::equal(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros(), B.innerIndexPtr()) &&
         (A.nonZeros() == 0 ||
          std::memcmp(A.valuePtr(), B.valuePtr(),
                      sizeof(double) * static_cast<std::size_t>(A.nonZeros())) == 0);
}

template <class Mat>
bool bitwise_equal(const SecondOrderSystem<Mat>& a, const SecondOrderSystem<Mat>& b) {
  return bitwise_equal(a.M, b.M) && bitwise_equal(a.D, b.D) && bitwise_equal(a.K, b.K) &&
         bitwise_equal(a.B, b.B) && bitwise_equal(a.C, b.C) && bitwise_equal(a.Cv, b.Cv);
}

template <class Mat>
bool bitwise_equal(const DescriptorSystem<Mat>& a, const DescriptorSystem<Mat>& b) {
  return bitwise_equal(a.E, b.E) && bitwise_equal(a.A, b.A) && bitwise_equal(a.B, b.B) &&
         bitwise_equal(a.C, b.C);
}

/// Same kind and every matrix bitwise equal (full or reduced models).
template <class... Kinds>
bool bitwise_equal(const std::variant<Kinds...>& a, const std::variant<Kinds...>& b) {
  return a.index() == b.index() &&
         std::visit(
             [&](const auto& x) {
               return bitwise_equal(x, std::get<std::decay_t<decltype(x)>>(b));
             },
             a);
}

}  // namespace ecmor::test
