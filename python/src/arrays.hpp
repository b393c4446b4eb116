#pragma once
// arrays.hpp: NumPy and SciPy matrices in, Eigen matrices out, and back. Every value is read
// exactly once into ecmor's own storage (one copy, whatever the input format); no dtype is
// converted unless the conversion is exact, and every rule broken is a named ecmor::InputError.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

#include "ecmor/base/types.hpp"

namespace ecmor::python {

namespace py = pybind11;

/// A matrix as the Python layer hands it over (ecmor/_matrices.py, as_input):
///   ("dense", name, array)                              a 2-D NumPy array, any strides
///   ("csc" | "csr", name, (rows, cols), indptr, indices, data)
///   ("coo", name, (rows, cols), row, col, data)
/// `name` ("K", "B") prefixes every message.
SparseMatrix sparse_from(const py::tuple& input, const std::string& origin);
Matrix dense_from(const py::tuple& input, const std::string& origin);

/// A read-only NumPy view of `m` (no copy), kept alive by `owner`.
py::array dense_view(const Matrix& m, const py::object& owner);
/// The CSC arrays (data, indices, indptr) of `m` as read-only views kept alive by `owner`.
py::tuple sparse_view(const SparseMatrix& m, const py::object& owner);

}  // namespace ecmor::python
