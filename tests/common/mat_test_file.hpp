#pragma once
/// \file mat_test_file.hpp
/// Writing and reading MATLAB .mat files with matio directly, independently of ecmor's own reader
/// and writer: the tests build model files (also broken ones) and check written outputs with it.
/// Test targets that include it link Matio::Matio.

#include <matio.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::test {

/// A new MAT file (v5 or v7.3) written variable by variable; closed by the destructor or close().
class MatTestFile {
 public:
  MatTestFile(const std::filesystem::path& path, mat_ft version) : m_path(path) {
    m_mat = Mat_CreateVer(path.c_str(), nullptr, version);
    if (m_mat == nullptr) throw std::runtime_error("matio cannot create " + path.string());
  }
  ~MatTestFile() { close(); }
  MatTestFile(const MatTestFile&) = delete;
  MatTestFile& operator=(const MatTestFile&) = delete;

  void close() {
    if (m_mat != nullptr) Mat_Close(m_mat);
    m_mat = nullptr;
  }

  /// A dense double matrix.
  void dense(const std::string& name, const Matrix& A) {
    write(name, MAT_C_DOUBLE, MAT_T_DOUBLE, {A.rows(), A.cols()}, const_cast<double*>(A.data()), 0);
  }

  /// A dense matrix stored in another numeric class (values cast to T), e.g. int32 or single;
  /// logical = true marks a uint8 matrix as MATLAB logical.
  template <class T>
  void dense_as(const std::string& name, const Matrix& A, matio_classes cls, matio_types type,
                bool logical = false) {
    std::vector<T> data(static_cast<std::size_t>(A.size()));
    for (Index k = 0; k < A.size(); ++k)
      data[static_cast<std::size_t>(k)] = static_cast<T>(A.data()[k]);
    write(name, cls, type, {A.rows(), A.cols()}, data.data(), logical ? MAT_F_LOGICAL : 0);
  }

  /// A real sparse double matrix (MATLAB's CSC: jc column pointers, ir row indices).
  void sparse(const std::string& name, const SparseMatrix& A_in) {
    SparseMatrix A = A_in;
    A.makeCompressed();
    std::vector<mat_uint32_t> jc(A.outerIndexPtr(), A.outerIndexPtr() + A.cols() + 1);
    std::vector<mat_uint32_t> ir(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
    std::vector<double> values(A.valuePtr(), A.valuePtr() + A.nonZeros());
    write_sparse(name, A.rows(), A.cols(), jc, ir, values.data(), 0);
  }

  /// A complex matrix (real part A, imaginary part 1 everywhere), dense or sparse.
  void complex(const std::string& name, const Matrix& A, bool as_sparse) {
    const std::vector<double> im(static_cast<std::size_t>(A.size()), 1.0);
    std::vector<double> re(A.data(), A.data() + A.size());
    mat_complex_split_t split{re.data(), const_cast<double*>(im.data())};
    if (!as_sparse) {
      write(name, MAT_C_DOUBLE, MAT_T_DOUBLE, {A.rows(), A.cols()}, &split, MAT_F_COMPLEX);
      return;
    }
    // Every entry stored (a full pattern), column by column.
    std::vector<mat_uint32_t> jc, ir;
    for (Index j = 0; j <= A.cols(); ++j) jc.push_back(static_cast<mat_uint32_t>(j * A.rows()));
    for (Index j = 0; j < A.cols(); ++j)
      for (Index i = 0; i < A.rows(); ++i) ir.push_back(static_cast<mat_uint32_t>(i));
    write_sparse(name, A.rows(), A.cols(), jc, ir, &split, MAT_F_COMPLEX);
  }

  /// A char array (text).
  void text(const std::string& name, const std::string& s) {
    std::string copy = s;
    write(name, MAT_C_CHAR, MAT_T_UINT8, {1, static_cast<Index>(s.size())}, copy.data(), 0);
  }

  /// A rows x cols x pages double array of ones.
  void three_d(const std::string& name, Index rows, Index cols, Index pages) {
    std::vector<double> data(static_cast<std::size_t>(rows * cols * pages), 1.0);
    size_t dims[3] = {static_cast<size_t>(rows), static_cast<size_t>(cols),
                      static_cast<size_t>(pages)};
    finish(name, Mat_VarCreate(name.c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 3, dims, data.data(),
                               MAT_F_DONT_COPY_DATA));
  }

  /// The matrices of a model under their conventional names: M, D, K sparse and B, C, Cv dense
  /// (second order) or E, A sparse and B, C dense (descriptor).
  void model(const Model& model) {
    if (const auto* so = std::get_if<SecondOrderModel>(&model)) {
      sparse("M", so->M);
      sparse("D", so->D);
      sparse("K", so->K);
      dense("B", so->B);
      dense("C", so->C);
      if (so->has_velocity_output()) dense("Cv", so->Cv);
    } else {
      const auto& de = std::get<DescriptorModel>(model);
      sparse("E", de.E);
      sparse("A", de.A);
      dense("B", de.B);
      dense("C", de.C);
    }
  }

 private:
  void write(const std::string& name, matio_classes cls, matio_types type,
             std::initializer_list<Index> shape, void* data, int flags) {
    std::vector<size_t> dims;
    for (Index d : shape) dims.push_back(static_cast<size_t>(d));
    finish(name, Mat_VarCreate(name.c_str(), cls, type, 2, dims.data(), data,
                               flags | MAT_F_DONT_COPY_DATA));
  }
  void write_sparse(const std::string& name, Index rows, Index cols, std::vector<mat_uint32_t>& jc,
                    std::vector<mat_uint32_t>& ir, void* data, int flags) {
    mat_sparse_t s{};
    s.nzmax = static_cast<mat_uint32_t>(ir.size());
    s.nir = static_cast<mat_uint32_t>(ir.size());
    s.ir = ir.data();
    s.njc = static_cast<mat_uint32_t>(jc.size());
    s.jc = jc.data();
    s.ndata = static_cast<mat_uint32_t>(ir.size());
    s.data = data;
    size_t dims[2] = {static_cast<size_t>(rows), static_cast<size_t>(cols)};
    finish(name, Mat_VarCreate(name.c_str(), MAT_C_SPARSE, MAT_T_DOUBLE, 2, dims, &s,
                               flags | MAT_F_DONT_COPY_DATA));
  }
  void finish(const std::string& name, matvar_t* v) {
    if (v == nullptr) throw std::runtime_error("matio cannot create variable " + name);
    const int rc = Mat_VarWrite(m_mat, v, MAT_COMPRESSION_NONE);
    Mat_VarFree(v);
    if (rc != 0) throw std::runtime_error("matio cannot write variable " + name);
  }

  std::filesystem::path m_path;
  mat_t* m_mat = nullptr;
};

/// The names of the variables in a MAT file.
inline std::vector<std::string> mat_variable_names(const std::filesystem::path& path) {
  mat_t* mat = Mat_Open(path.c_str(), MAT_ACC_RDONLY);
  if (mat == nullptr) throw std::runtime_error("matio cannot open " + path.string());
  std::vector<std::string> names;
  size_t n = 0;
  char** dir = Mat_GetDir(mat, &n);
  for (size_t k = 0; dir != nullptr && k < n; ++k) names.emplace_back(dir[k]);
  Mat_Close(mat);
  return names;
}

/// A dense double variable of a MAT file (as ecmor writes them).
inline Matrix mat_read_dense(const std::filesystem::path& path, const std::string& name) {
  mat_t* mat = Mat_Open(path.c_str(), MAT_ACC_RDONLY);
  if (mat == nullptr) throw std::runtime_error("matio cannot open " + path.string());
  matvar_t* v = Mat_VarRead(mat, name.c_str());
  Matrix A;
  const bool ok = v != nullptr && v->class_type == MAT_C_DOUBLE && v->data_type == MAT_T_DOUBLE &&
                  v->rank == 2 && !v->isComplex;
  if (ok) {
    A.resize(static_cast<Index>(v->dims[0]), static_cast<Index>(v->dims[1]));
    if (A.size() > 0)
      std::memcpy(A.data(), v->data, sizeof(double) * static_cast<std::size_t>(A.size()));
  }
  Mat_VarFree(v);
  Mat_Close(mat);
  if (!ok) throw std::runtime_error(path.string() + ": no dense double variable " + name);
  return A;
}

}  // namespace ecmor::test
