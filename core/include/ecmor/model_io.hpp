#pragma once
/// \file model_io.hpp
/// Loading full models from a directory of Matrix Market files and writing reduced models.
///
/// Directory conventions (see ../shared/models/README.md):
///   second order: M.mtx D.mtx K.mtx B.mtx C.mtx [Cv.mtx]   (D.mtx optional: absent means D = 0)
///   descriptor:   E.mtx A.mtx B.mtx C.mtx                 (E.mtx optional: absent means E = I)
/// The kind is detected from which files are present; both sets present is an error.

#include <filesystem>
#include <string>
#include <vector>

#include "ecmor/export.hpp"
#include "ecmor/model.hpp"

namespace ecmor {

/// Loads and validates (ecmor::validate) the model in `dir`.
/// \throws InputError: directory missing, neither or both file sets present, a malformed file (with
///         file and line), sizes inconsistent between files (naming both files and their sizes).
ECMOR_API Model load_model(const std::filesystem::path& dir);

/// Writes a reduced model to `dir` as Mr.mtx Dr.mtx Kr.mtx Br.mtx Cr.mtx [Cvr.mtx] (second order)
/// or Er.mtx Ar.mtx Br.mtx Cr.mtx (descriptor), each atomically. Creates `dir` if needed.
/// Files of the other kind (and a stale Cvr.mtx) left in `dir` by an earlier write are removed.
/// \throws IoError naming the file that cannot be written; NumericalError for a non-finite entry.
ECMOR_API void write_reduced_model(const std::filesystem::path& dir, const ReducedModel& model);

/// Reads a reduced model written by write_reduced_model (dense) and validates it. Dr.mtx absent
/// means Dr = 0, Er.mtx absent means Er = I.
ECMOR_API ReducedModel read_reduced_model(const std::filesystem::path& dir);

/// Sizes, nnz, symmetry and definiteness of a model's matrices (for `ecmor info`).
struct MatrixSummary {
  std::string name;   ///< "M", "K", "E", ...
  Index rows = 0, cols = 0, nnz = 0;
  double relative_asymmetry = 0.0;  ///< ||A - A'||_F / ||A||_F (NaN for non-square B, C, Cv)
  /// "positive definite" / "not positive definite" for symmetric M, D, K, E (Cholesky);
  /// "negative definite" / "not negative definite" for a symmetric A (Cholesky of -A);
  /// "not checked" for unsymmetric matrices (relative asymmetry > 1e-10), for B, C, Cv and when
  /// N > 200000.
  std::string definiteness;
};
struct ModelSummary {
  ModelKind kind = ModelKind::SecondOrder;
  Index size = 0, inputs = 0, outputs = 0;
  bool velocity_output = false;
  std::vector<MatrixSummary> matrices;
};
/// Matrices listed: M, D, K, B, C[, Cv] (second order) or E, A, B, C (descriptor).
ECMOR_API ModelSummary summarize(const Model& model);

}  // namespace ecmor
