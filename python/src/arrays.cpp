// arrays.cpp: see arrays.hpp. Sparse input of any layout is scattered into compressed columns by
// counting (the transposition of CSR, the bucketing of COO), each column sorted by row and its
// duplicates summed, as scipy's own conversions do: one pass over the input, one copy.
#include "arrays.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <vector>

#include "ecmor/base/error.hpp"

namespace ecmor::python {
namespace {

constexpr double kExactIntegers = 9007199254740992.0;  // 2^53: every integer up to it is a double

[[noreturn]] void fail(const std::string& origin, const std::string& what) {
  throw InputError(origin + ": " + what);
}

// One strided array of numbers, read element by element whatever its dtype; the dtypes accepted
// are those whose values a double holds exactly.
class Numbers {
 public:
  Numbers(const py::array& a, std::string origin, std::string field, bool indices)
      : m_origin(std::move(origin)), m_field(std::move(field)), m_indices(indices) {
    const py::dtype dt = a.dtype();
    m_kind = dt.kind();
    m_size = static_cast<int>(dt.itemsize());
    const char order = dt.byteorder();
    const std::string name = py::str(py::handle(dt)).cast<std::string>();
    if (order == '>')
      fail(m_origin, fmt::format("{} has the big-endian dtype {}: convert it with "
                                 ".astype(np.float64) (or the native integer type)",
                                 m_field, name));
    const bool integer = m_kind == 'i' || m_kind == 'u';
    if (indices && !integer)
      fail(m_origin,
           fmt::format("{} has dtype {}: sparse index arrays must be integers", m_field, name));
    if (m_kind == 'c')
      fail(m_origin, fmt::format("{} has dtype {}: ecmor's models are real (a complex matrix "
                                 "is never cast to its real part)",
                                 m_field, name));
    const bool real = m_kind == 'f' && (m_size == 4 || m_size == 8);
    if (!real && !integer)
      fail(m_origin,
           fmt::format("{} has dtype {}: expected float64, float32 or an integer type (values a "
                       "double holds exactly; nothing else is cast)",
                       m_field, name));
    m_data = static_cast<const char*>(a.data());
  }

  /// Element at byte offset `offset` as a double; integers beyond 2^53 are refused.
  double at(py::ssize_t offset, py::ssize_t index) const {
    const char* p = m_data + offset;
    switch (m_kind) {
      case 'f':
        return m_size == 8 ? read<double>(p) : static_cast<double>(read<float>(p));
      case 'i':
        return exact(m_size == 1   ? read<std::int8_t>(p)
                     : m_size == 2 ? read<std::int16_t>(p)
                     : m_size == 4 ? read<std::int32_t>(p)
                                   : read<std::int64_t>(p),
                     index);
      default:
        return exact(m_size == 1   ? read<std::uint8_t>(p)
                     : m_size == 2 ? read<std::uint16_t>(p)
                     : m_size == 4 ? read<std::uint32_t>(p)
                                   : static_cast<long double>(read<std::uint64_t>(p)),
                     index);
    }
  }

  /// An index entry, checked to lie in [0, limit].
  Index index_at(py::ssize_t offset, py::ssize_t index, Index limit, const char* what) const {
    const double v = at(offset, index);
    if (!(v >= 0.0 && v <= static_cast<double>(limit)))
      fail(m_origin,
           fmt::format("{}[{}] = {}: must be in [0, {}] ({})", m_field, index, v, limit, what));
    return static_cast<Index>(v);
  }

 private:
  template <class T>
  static T read(const char* p) {
    T v;
    std::memcpy(&v, p, sizeof v);  // NumPy arrays need not be aligned
    return v;
  }
  template <class T>
  double exact(T v, py::ssize_t index) const {
    const long double x = static_cast<long double>(v);
    if (x > kExactIntegers || x < -kExactIntegers)
      fail(m_origin, fmt::format("{}[{}] = {}: beyond 2^53, not exactly a double", m_field, index,
                                 static_cast<double>(x)));
    return static_cast<double>(x);
  }

  const char* m_data = nullptr;
  char m_kind = 0;
  int m_size = 0;
  std::string m_origin, m_field;
  bool m_indices;
};

// A 1-D array of the input tuple with its reader.
struct Vector1 {
  py::array array;
  py::ssize_t size = 0, stride = 0;
  Numbers numbers;
  Vector1(py::array a, const std::string& origin, const char* field, bool indices)
      : array(std::move(a)), numbers(checked(array, origin, field), origin, field, indices) {
    size = array.shape(0);
    stride = array.strides(0);
  }
  double value(py::ssize_t k) const { return numbers.at(k * stride, k); }
  Index index(py::ssize_t k, Index limit, const char* what) const {
    return numbers.index_at(k * stride, k, limit, what);
  }

 private:
  static const py::array& checked(const py::array& a, const std::string& origin,
                                  const char* field) {
    if (a.ndim() != 1)
      fail(origin, fmt::format("{} is a {}-D array: must be 1-D", field, a.ndim()));
    return a;
  }
};

Index dimension(const py::handle& h, const std::string& origin, const char* which) {
  const long long v = h.cast<long long>();
  if (v < 0) fail(origin, fmt::format("{} {} < 0", which, v));
  if (v > std::numeric_limits<int>::max() - 1)
    fail(origin, fmt::format("{} {} > {}: ecmor's sparse matrices index with 32-bit integers",
                             which, v, std::numeric_limits<int>::max() - 1));
  return static_cast<Index>(v);
}

py::array as_array(const py::handle& h, const std::string& origin, const char* field) {
  if (!py::isinstance<py::array>(h))
    fail(origin, fmt::format("{} is a {}, not a NumPy array", field,
                             py::str(py::type::of(h).attr("__name__")).cast<std::string>()));
  return py::reinterpret_borrow<py::array>(h);
}

// Compressed columns from entries given by `visit(f)`, which calls f(row, col, value) for each
// stored entry in input order; `count` is how many. Each column is then sorted by row and its
// duplicates summed (CSR input arrives sorted; CSC and COO may not).
template <class Visit>
SparseMatrix scatter(Index rows, Index cols, Index count, Visit&& visit) {
  std::vector<int> start(static_cast<std::size_t>(cols) + 1, 0);
  visit([&](Index, Index j, double) { ++start[static_cast<std::size_t>(j) + 1]; });
  std::partial_sum(start.begin(), start.end(), start.begin());
  SparseMatrix m(rows, cols);
  m.resizeNonZeros(count);
  std::vector<int> next(start.begin(), start.end() - 1);
  int* inner = m.innerIndexPtr();
  double* values = m.valuePtr();
  visit([&](Index i, Index j, double v) {
    const int k = next[static_cast<std::size_t>(j)]++;
    inner[k] = static_cast<int>(i);
    values[k] = v;
  });
  // Sort each column by row and sum duplicates, compacting in place.
  int* outer = m.outerIndexPtr();
  int write = 0;
  std::vector<std::pair<int, double>> column;
  for (Index j = 0; j < cols; ++j) {
    const int begin = start[static_cast<std::size_t>(j)];
    const int end = start[static_cast<std::size_t>(j) + 1];
    bool sorted = true;
    for (int k = begin + 1; k < end && sorted; ++k) sorted = inner[k - 1] < inner[k];
    outer[j] = write;
    if (sorted) {
      for (int k = begin; k < end; ++k, ++write) {
        inner[write] = inner[k];
        values[write] = values[k];
      }
      continue;
    }
    column.clear();
    for (int k = begin; k < end; ++k) column.emplace_back(inner[k], values[k]);
    std::stable_sort(column.begin(), column.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (std::size_t k = 0; k < column.size(); ++k) {
      if (k > 0 && column[k].first == column[k - 1].first) {
        values[write - 1] += column[k].second;
      } else {
        inner[write] = column[k].first;
        values[write] = column[k].second;
        ++write;
      }
    }
  }
  outer[cols] = write;
  m.data().resize(write);
  return m;
}

struct SparseInput {
  std::string format, origin;
  Index rows = 0, cols = 0;
  py::tuple parts;
};

SparseInput sparse_input(const py::tuple& input, const std::string& origin) {
  SparseInput s;
  s.format = input[0].cast<std::string>();
  s.origin =
      origin.empty() ? input[1].cast<std::string>() : origin + ": " + input[1].cast<std::string>();
  const py::tuple shape = input[2].cast<py::tuple>();
  s.rows = dimension(shape[0], s.origin, "rows");
  s.cols = dimension(shape[1], s.origin, "columns");
  s.parts = input;
  return s;
}

// Calls f(row, col, value) for every stored entry of a sparse input, validating its arrays.
template <class F>
void visit_sparse(const SparseInput& s, F&& f) {
  const Vector1 a(as_array(s.parts[3], s.origin, s.format == "coo" ? "row" : "indptr"), s.origin,
                  s.format == "coo" ? "row" : "indptr", true);
  const Vector1 b(as_array(s.parts[4], s.origin, s.format == "coo" ? "col" : "indices"), s.origin,
                  s.format == "coo" ? "col" : "indices", true);
  const Vector1 data(as_array(s.parts[5], s.origin, "data"), s.origin, "data", false);
  if (s.format == "coo") {
    if (a.size != data.size || b.size != data.size)
      fail(s.origin, fmt::format("row, col and data have {}, {} and {} entries: must be equal",
                                 a.size, b.size, data.size));
    for (py::ssize_t k = 0; k < data.size; ++k)
      f(a.index(k, s.rows - 1, "a row index"), b.index(k, s.cols - 1, "a column index"),
        data.value(k));
    return;
  }
  const bool csc = s.format == "csc";
  const Index outer = csc ? s.cols : s.rows, inner = csc ? s.rows : s.cols;
  if (a.size != outer + 1)
    fail(s.origin, fmt::format("indptr has {} entries: must be {} + 1 = {} ({})", a.size, outer,
                               outer + 1, csc ? "columns" : "rows"));
  const Index nnz = a.index(outer, data.size, "the number of stored entries");
  if (b.size < nnz || data.size < nnz)
    fail(s.origin, fmt::format("indptr[-1] = {} but indices and data have {} and {} entries", nnz,
                               b.size, data.size));
  Index previous = a.index(0, 0, "indptr starts at 0");
  for (Index o = 0; o < outer; ++o) {
    const Index end = a.index(o + 1, nnz, "within the stored entries");
    if (end < previous)
      fail(s.origin, fmt::format("indptr[{}] = {} < indptr[{}] = {}: must not decrease", o + 1, end,
                                 o, previous));
    for (Index k = previous; k < end; ++k) {
      const Index i = b.index(k, inner - 1, csc ? "a row index" : "a column index");
      const double v = data.value(k);
      if (csc)
        f(i, o, v);
      else
        f(o, i, v);
    }
    previous = end;
  }
}

Index stored_entries(const SparseInput& s) {
  Index count = 0;
  visit_sparse(s, [&](Index, Index, double) { ++count; });
  return count;
}

// A dense input's reader: rows, columns and value(i, j).
struct DenseInput {
  py::array array;
  Index rows = 0, cols = 0;
  py::ssize_t s0 = 0, s1 = 0;
  std::string origin;
  DenseInput(const py::tuple& input, const std::string& prefix) {
    origin = prefix.empty() ? input[1].cast<std::string>()
                            : prefix + ": " + input[1].cast<std::string>();
    array = as_array(input[2], origin, "the matrix");
    if (array.ndim() != 2)
      fail(origin, fmt::format("a {}-D array: must be 2-D (for one column use .reshape(-1, 1), "
                               "for one row .reshape(1, -1))",
                               array.ndim()));
    rows = dimension(py::int_(array.shape(0)), origin, "rows");
    cols = dimension(py::int_(array.shape(1)), origin, "columns");
    s0 = array.strides(0);
    s1 = array.strides(1);
  }
};

}  // namespace

SparseMatrix sparse_from(const py::tuple& input, const std::string& origin) {
  const std::string format = input[0].cast<std::string>();
  if (format == "dense") {
    const DenseInput d(input, origin);
    const Numbers n(d.array, d.origin, "the matrix", false);
    auto visit = [&](auto&& f) {
      for (Index j = 0; j < d.cols; ++j)
        for (Index i = 0; i < d.rows; ++i) {
          const double v = n.at(i * d.s0 + j * d.s1, i + j * d.rows);
          if (v != 0.0) f(i, j, v);  // NaN too: validate() names it
        }
    };
    Index count = 0;
    visit([&](Index, Index, double) { ++count; });
    return scatter(d.rows, d.cols, count, visit);
  }
  const SparseInput s = sparse_input(input, origin);
  const Index count = stored_entries(s);
  return scatter(s.rows, s.cols, count, [&](auto&& f) { visit_sparse(s, f); });
}

Matrix dense_from(const py::tuple& input, const std::string& origin) {
  const std::string format = input[0].cast<std::string>();
  if (format == "dense") {
    const DenseInput d(input, origin);
    const Numbers n(d.array, d.origin, "the matrix", false);
    Matrix m(d.rows, d.cols);
    for (Index j = 0; j < d.cols; ++j)
      for (Index i = 0; i < d.rows; ++i) m(i, j) = n.at(i * d.s0 + j * d.s1, i + j * d.rows);
    return m;
  }
  const SparseInput s = sparse_input(input, origin);
  Matrix m = Matrix::Zero(s.rows, s.cols);
  visit_sparse(s, [&](Index i, Index j, double v) { m(i, j) += v; });
  return m;
}

namespace {

py::array read_only(py::array a) {
  a.attr("flags").attr("writeable") = false;
  return a;
}

}  // namespace

py::array dense_view(const Matrix& m, const py::object& owner) {
  if (m.size() == 0) return py::array(py::dtype::of<double>(), {m.rows(), m.cols()});
  const auto d = static_cast<py::ssize_t>(sizeof(double));
  return read_only(py::array(py::dtype::of<double>(), {m.rows(), m.cols()},
                             {d, d * std::max<py::ssize_t>(m.rows(), 1)}, m.data(), owner));
}

py::tuple sparse_view(const SparseMatrix& m, const py::object& owner) {
  if (!m.isCompressed())
    throw std::logic_error("sparse_view: the matrix is not in compressed form");
  const Index nnz = m.nonZeros();
  py::array data(py::dtype::of<double>(), {nnz}, {}, m.valuePtr(), owner);
  py::array indices(py::dtype::of<int>(), {nnz}, {}, m.innerIndexPtr(), owner);
  py::array indptr(py::dtype::of<int>(), {m.cols() + 1}, {}, m.outerIndexPtr(), owner);
  return py::make_tuple(read_only(data), read_only(indices), read_only(indptr));
}

}  // namespace ecmor::python
