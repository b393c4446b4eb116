// mat_file.cpp: the matio wrapper behind `model: {file: X.mat}` and `output.format: mat`.
// matio's default logger is off (no Mat_LogInit), so it neither prints nor aborts: every failure
// comes back as a null pointer or an error code, turned here into an error naming the file, the
// variable and the rule. Sparse data from a file is checked before it is indexed: a damaged or
// hostile file must give an error, never an out-of-bounds read.
#include "model/mat_file.hpp"

#include <fmt/format.h>
#include <matio.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <system_error>
#include <vector>

#include "ecmor/base/error.hpp"

namespace ecmor::detail {
namespace {

namespace fs = std::filesystem;

// The zeros a dense read of a sparse variable materialises are not backed by the file; as in the
// Matrix Market reader (matrix_market.cpp), they get a budget: 256 MiB of doubles.
constexpr std::size_t kMaxDenseFromSparse = std::size_t{1} << 25;

std::string dims_text(const matvar_t& v) {
  if (v.dims == nullptr) return "(no dimensions)";
  std::string s;
  for (int k = 0; k < v.rank; ++k) {
    if (k > 0) s += " x ";
    s += std::to_string(v.dims[k]);
  }
  return s;
}

/// MATLAB's name of a class that cannot hold a model matrix; nullptr for the numeric classes.
const char* non_numeric_class(enum matio_classes c) {
  switch (c) {
    case MAT_C_CELL:
      return "a cell array";
    case MAT_C_STRUCT:
      return "a struct";
    case MAT_C_OBJECT:
      return "an object";
    case MAT_C_CHAR:
      return "a char array (text)";
    case MAT_C_FUNCTION:
      return "a function handle";
    case MAT_C_OPAQUE:
      return "an opaque object (e.g. a string or a table)";
    default:
      return nullptr;
  }
}

/// Element k of a buffer of matio type `type` as a double (no reader for types that are not real
/// numbers: text, nested arrays).
template <class T>
double element(const void* data, std::size_t k) {
  T v;
  std::memcpy(&v, static_cast<const char*>(data) + k * sizeof(T), sizeof(T));
  return static_cast<double>(v);
}
using ElementReader = double (*)(const void*, std::size_t);
ElementReader element_reader(enum matio_types type) {
  switch (type) {
    case MAT_T_DOUBLE:
      return element<double>;
    case MAT_T_SINGLE:
      return element<float>;
    case MAT_T_INT8:
      return element<std::int8_t>;
    case MAT_T_UINT8:
      return element<std::uint8_t>;
    case MAT_T_INT16:
      return element<std::int16_t>;
    case MAT_T_UINT16:
      return element<std::uint16_t>;
    case MAT_T_INT32:
      return element<std::int32_t>;
    case MAT_T_UINT32:
      return element<std::uint32_t>;
    case MAT_T_INT64:
      return element<std::int64_t>;
    case MAT_T_UINT64:
      return element<std::uint64_t>;
    default:
      return nullptr;
  }
}

const matvar_t* as_var(const void* p) { return static_cast<const matvar_t*>(p); }

}  // namespace

void MatReader::VarDeleter::operator()(void* var) const {
  Mat_VarFree(static_cast<matvar_t*>(var));
}

MatReader::MatReader(const fs::path& path, std::string origin) : m_origin(std::move(origin)) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) fail("file does not exist");
  if (fs::is_directory(st)) fail("is a directory, not a .mat file");
  m_mat = Mat_Open(path.c_str(), MAT_ACC_RDONLY);
  if (m_mat == nullptr) fail("not a MAT file (matio cannot open it as MAT v4, v5 or v7.3)");
  size_t n = 0;
  char** dir = Mat_GetDir(m_mat, &n);  // owned by m_mat
  for (size_t k = 0; dir != nullptr && k < n; ++k)
    if (dir[k] != nullptr) m_names.insert(dir[k]);
}

MatReader::~MatReader() {
  if (m_mat != nullptr) Mat_Close(m_mat);
}

void MatReader::fail(const std::string& rule) const { throw InputError(m_origin + ": " + rule); }

std::string MatReader::found_list() const {
  return m_names.empty() ? "no variables" : fmt::format("{}", fmt::join(m_names, ", "));
}

MatReader::VarPtr MatReader::read(const std::string& name, bool with_data) const {
  if (!has(name)) fail(var(name) + " is missing (found: " + found_list() + ")");
  VarPtr v(with_data ? Mat_VarRead(m_mat, name.c_str()) : Mat_VarReadInfo(m_mat, name.c_str()));
  if (!v) fail(var(name) + ": matio cannot read it (damaged or unsupported data)");
  const matvar_t& m = *as_var(v.get());
  if (const char* what = non_numeric_class(m.class_type))
    fail(var(name) + " is " + what +
         ": must be a numeric or logical matrix (double, single, integer or logical; dense or "
         "sparse)");
  if (m.isComplex)
    fail(var(name) +
         " is complex: only real matrices are accepted (a model has real coefficients)");
  if (m.rank != 2 || m.dims == nullptr)
    fail(var(name) + " has " + std::to_string(m.rank) + " dimensions (" + dims_text(m) +
         "): must be a 2-D matrix");
  constexpr auto kMax = static_cast<std::size_t>(std::numeric_limits<int>::max());
  if (m.dims[0] > kMax || m.dims[1] > kMax)
    fail(var(name) + " is " + dims_text(m) + ": too large (at most 2^31 - 1 rows and columns)");
  return v;
}

std::pair<Index, Index> MatReader::shape(const std::string& name) const {
  const VarPtr v = read(name, false);
  return {static_cast<Index>(as_var(v.get())->dims[0]),
          static_cast<Index>(as_var(v.get())->dims[1])};
}

SparseMatrix MatReader::sparse(const std::string& name) const {
  return sparse_of(read(name, true).get(), name);
}

Matrix MatReader::dense(const std::string& name) const {
  return dense_of(read(name, true).get(), name);
}

SparseMatrix MatReader::sparse_of(const void* var_ptr, const std::string& name) const {
  const matvar_t& m = *static_cast<const matvar_t*>(var_ptr);
  const auto rows = static_cast<Index>(m.dims[0]);
  const auto cols = static_cast<Index>(m.dims[1]);
  SparseMatrix A(rows, cols);
  std::vector<Eigen::Triplet<double, int>> t;
  if (m.class_type != MAT_C_SPARSE) {
    const Matrix D = dense_of(var_ptr, name);
    for (Index j = 0; j < cols; ++j)
      for (Index i = 0; i < rows; ++i)
        if (D(i, j) != 0.0)  // true for NaN as well: validate() then names it
          t.emplace_back(static_cast<int>(i), static_cast<int>(j), D(i, j));
    A.setFromTriplets(t.begin(), t.end());
    A.makeCompressed();
    return A;
  }
  const auto* s = static_cast<const mat_sparse_t*>(m.data);
  const ElementReader get = element_reader(m.data_type);
  const std::string bad = var(name) + " has malformed sparse data: ";
  if (s == nullptr || s->jc == nullptr || get == nullptr)
    fail(bad + "no column pointers or values");
  if (static_cast<Index>(s->njc) != cols + 1)
    fail(bad + std::to_string(s->njc) + " column pointers for " + std::to_string(cols) +
         " columns (expected columns + 1)");
  const std::size_t nnz = s->jc[cols];
  if (s->jc[0] != 0 || nnz > s->nir || nnz > s->ndata || (nnz > 0 && s->ir == nullptr) ||
      (nnz > 0 && s->data == nullptr))
    fail(bad + "column pointers run from " + std::to_string(s->jc[0]) + " to " +
         std::to_string(nnz) + " over " + std::to_string(s->nir) + " row indices and " +
         std::to_string(s->ndata) + " values");
  if (nnz > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    fail(var(name) + " has " + std::to_string(nnz) + " nonzeros: at most 2^31 - 1 are supported");
  t.reserve(nnz);
  for (Index j = 0; j < cols; ++j) {
    const std::size_t begin = s->jc[j], end = s->jc[j + 1];
    if (end < begin) fail(bad + "column pointers decrease at column " + std::to_string(j + 1));
    for (std::size_t k = begin; k < end; ++k) {
      if (static_cast<Index>(s->ir[k]) >= rows)
        fail(bad + "row index " + std::to_string(s->ir[k] + 1) + " in column " +
             std::to_string(j + 1) + " is out of range 1.." + std::to_string(rows));
      t.emplace_back(static_cast<int>(s->ir[k]), static_cast<int>(j), get(s->data, k));
    }
  }
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

Matrix MatReader::dense_of(const void* var_ptr, const std::string& name) const {
  const matvar_t& m = *static_cast<const matvar_t*>(var_ptr);
  const auto rows = static_cast<Index>(m.dims[0]);
  const auto cols = static_cast<Index>(m.dims[1]);
  std::size_t count = 0;
  const bool overflow = __builtin_mul_overflow(m.dims[0], m.dims[1], &count);
  if (m.class_type == MAT_C_SPARSE) {
    // The zeros of a sparse variable are not in the file: bound what densifying it allocates
    // (B and C are N x m and p x N with m, p small).
    if (overflow || count > kMaxDenseFromSparse)
      fail(var(name) + " is a sparse " + dims_text(m) +
           " matrix: too large to hold densely (at most 2^25 entries)");
    return Matrix(sparse_of(var_ptr, name));
  }
  if (m.class_type == MAT_C_EMPTY || count == 0) return Matrix(rows, cols);
  const ElementReader get = element_reader(m.data_type);
  if (get == nullptr)
    fail(var(name) + ": its data (matio type " + std::to_string(m.data_type) +
         ") is not a real number");
  // matio allocated the data; check that it holds every entry before allocating the result.
  std::size_t needed = 0;
  if (overflow || __builtin_mul_overflow(count, Mat_SizeOf(m.data_type), &needed) ||
      m.data == nullptr || m.nbytes < needed)
    fail(var(name) + " is " + dims_text(m) + " but holds only " + std::to_string(m.nbytes) +
         " bytes of data");
  Matrix A(rows, cols);
  for (std::size_t k = 0; k < count; ++k) A.data()[k] = get(m.data, k);  // both column-major
  return A;
}

MatWriter::MatWriter(const fs::path& path, const fs::path& target, const char* header)
    : m_target(target) {
  m_mat = Mat_CreateVer(path.c_str(), header, MAT_FT_MAT5);
  if (m_mat == nullptr)
    throw IoError("cannot write " + target.string() + ": matio cannot create " + path.string());
}

MatWriter::~MatWriter() {
  if (m_mat != nullptr) Mat_Close(m_mat);
}

void MatWriter::write(const std::string& name, const Matrix& A) {
  if (!A.allFinite())
    throw NumericalError("cannot write " + m_target.string() + ": variable " + name +
                         " has a non-finite value (NaN or Inf)");
  size_t dims[2] = {static_cast<size_t>(A.rows()), static_cast<size_t>(A.cols())};
  // matio takes non-const pointers but does not write through them with MAT_F_DONT_COPY_DATA.
  matvar_t* v = Mat_VarCreate(name.c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims,
                              const_cast<double*>(A.data()), MAT_F_DONT_COPY_DATA);
  if (v == nullptr)
    throw IoError("cannot write " + m_target.string() + ": matio cannot create variable " + name);
  const int rc = Mat_VarWrite(m_mat, v, MAT_COMPRESSION_NONE);
  Mat_VarFree(v);
  if (rc != 0)
    throw IoError("cannot write " + m_target.string() + ": matio failed to write variable " + name +
                  " (error " + std::to_string(rc) + ")");
}

void MatWriter::close() {
  _mat_t* mat = m_mat;
  m_mat = nullptr;
  if (mat != nullptr && Mat_Close(mat) != 0)
    throw IoError("cannot write " + m_target.string() + ": matio failed to close it");
}

}  // namespace ecmor::detail
