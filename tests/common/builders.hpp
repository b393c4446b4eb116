#pragma once
/// \file builders.hpp
/// Model pieces shared by the test suites: sparse copies of dense matrices, seeded random
/// matrices, model directories of generated models, and the benchmark models (read relative
/// to the build directory, where ctest runs the tests).

#include <filesystem>
#include <random>
#include <string>

#include "ecmor/base/types.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/model/model_io.hpp"

namespace ecmor::test {

/// The nonzero entries of X as a compressed sparse matrix.
inline SparseMatrix sparse(const Matrix& X) {
  SparseMatrix S = X.sparseView(0.0, 0.0);
  S.makeCompressed();
  return S;
}

/// Entries uniform in [-1, 1] from a Mersenne twister seeded with `seed`, column by column.
inline Matrix random_matrix(Index rows, Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Matrix X(rows, cols);
  for (Index j = 0; j < cols; ++j)
    for (Index i = 0; i < rows; ++i) X(i, j) = u(gen);
  return X;
}

/// A model of models by its directory name.
inline Model shared_model(const std::string& name) { return load_model("models/" + name); }

/// A model directory (M, D, K, B, C .mtx) of a generated second-order model, for runs of the
/// driver; `what` is the files' comment.
inline void write_model_dir(const std::filesystem::path& dir, const SecondOrderModel& m,
                            const std::string& what) {
  std::filesystem::create_directories(dir);
  write_matrix_market(dir / "M.mtx", m.M, what);
  write_matrix_market(dir / "D.mtx", m.D, what);
  write_matrix_market(dir / "K.mtx", m.K, what);
  write_matrix_market(dir / "B.mtx", Matrix(m.B), what);
  write_matrix_market(dir / "C.mtx", Matrix(m.C), what);
}

}  // namespace ecmor::test
