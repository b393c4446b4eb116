#pragma once
/// \file model_io.hpp
/// Loading full models from a directory of Matrix Market files or from a MATLAB .mat file, and
/// writing and reading reduced models.
///
/// Directory conventions (see models/README.md):
///   second order: M.mtx D.mtx K.mtx B.mtx C.mtx [Cv.mtx]   (D.mtx optional: absent means D = 0)
///   descriptor:   E.mtx A.mtx B.mtx C.mtx                 (E.mtx optional: absent means E = I)
/// Each file may be gzip'ed instead (K.mtx.gz), mixed within a directory; a matrix present in
/// both forms is an InputError naming both files.
/// A .mat file (MAT v4, v5 or v7.3, read with matio) holds the same matrices as variables named
/// M, D, K, B, C[, Cv] or E, A, B, C (or renamed, ModelSource::variables), each dense or sparse,
/// of any real numeric or logical class (converted to double). In a descriptor file a variable D
/// is the feedthrough (y = C x + D u): ecmor's models have none, so it must be empty or all zero.
/// The kind is detected from which matrices are present; both sets present is an error.

#include <filesystem>
#include <map>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "ecmor/export.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// Where a full model is read from (YAML `model: {dir: ...}` or `model: {file: ..., variables:
/// {...}}`).
struct ModelSource {
  /// A directory of Matrix Market files, or a MATLAB file whose name ends in .mat (any case).
  std::filesystem::path path;
  /// .mat files only: the variable that holds each matrix, by its role (model_variable_roles()),
  /// e.g. {{"M", "Mass"}, {"K", "Stiff"}}. A role not listed is read from the variable of its own
  /// name.
  std::map<std::string, std::string> variables;
};

/// True for a file name with the extension .mat, in any case.
inline bool is_mat_file_name(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  return ext.size() == 4 && ext[0] == '.' && (ext[1] == 'm' || ext[1] == 'M') &&
         (ext[2] == 'a' || ext[2] == 'A') && (ext[3] == 't' || ext[3] == 'T');
}

/// How load_model and read_reduced_model tell a MATLAB file from a directory: a path that is not
/// a directory and whose name ends in .mat, whether or not it exists.
inline bool is_mat_path(const std::filesystem::path& path) {
  std::error_code ec;
  return is_mat_file_name(path) && !std::filesystem::is_directory(path, ec);
}

/// The roles ModelSource::variables may rename: M, D, K, B, C, Cv, E, A.
inline const std::vector<std::string>& model_variable_roles() {
  static const std::vector<std::string> roles = {"M", "D", "K", "B", "C", "Cv", "E", "A"};
  return roles;
}

/// Loads and validates (ecmor::validate) the model at `source.path`: a model directory or a .mat
/// file (chosen by whether the path is a directory, else by the extension .mat).
/// \throws InputError naming the directory or file, the file or variable, and the rule broken:
///         directory or file missing, not a MAT file, neither or both sets present, a required
///         matrix missing, a malformed .mtx file (with its line), sizes inconsistent between the
///         matrices (naming both and their sizes), a complex, non-numeric (char, cell, struct) or
///         not 2-D variable, a non-zero feedthrough D in a descriptor .mat file, NaN or Inf
///         (ecmor::validate), `variables` for a directory, an unknown role in `variables`, or
///         two roles read from one variable.
ECMOR_API Model load_model(const ModelSource& source);

/// load_model({path}): a model directory or a .mat file with the default variable names.
ECMOR_API Model load_model(const std::filesystem::path& path);

/// Writes a reduced model to `dir` as Mr.mtx Dr.mtx Kr.mtx Br.mtx Cr.mtx [Cvr.mtx] (second order)
/// or Er.mtx Ar.mtx Br.mtx Cr.mtx (descriptor), each atomically. Creates `dir` if needed.
/// Files of the other kind (and a stale Cvr.mtx) left in `dir` by an earlier write are removed.
/// \throws IoError naming the file that cannot be written; NumericalError for a non-finite entry.
ECMOR_API void write_reduced_model(const std::filesystem::path& dir, const ReducedModel& model);

/// One variable of write_mat_file(): its name in the file and its value.
struct NamedMatrix {
  std::string name;
  Matrix value;
};

/// Writes `matrices`, in this order, as dense double variables of a new MAT v5 file at `path`,
/// atomically (a temporary file renamed over `path`); `header` is the file's descriptive text
/// (MATLAB shows it with `whos -file`). For the tools that exchange other .mat files than models
/// (the reduced elastic body of ecmor/interop/flexible_body.hpp), without matio in their build.
/// \throws NumericalError for a non-finite entry (naming the variable), IoError naming `path` when
///         it cannot be written.
ECMOR_API void write_mat_file(const std::filesystem::path& path,
                              const std::vector<NamedMatrix>& matrices, const std::string& header);

/// Which files hold the reduced model and the bases in a run directory (YAML `output.format`).
///   Mtx:  the Matrix Market files of write_reduced_model, V.mtx and W.mtx (the default);
///   Mat:  one MAT v5 file, kReducedModelMatFile, instead;
///   Both: both.
enum class OutputFormat { Mtx, Mat, Both };
/// "mtx", "mat", "both": the names of YAML output.format and of the APIs.
inline const std::vector<std::pair<std::string, OutputFormat>>& output_format_names() {
  static const std::vector<std::pair<std::string, OutputFormat>> names = {
      {"mtx", OutputFormat::Mtx}, {"mat", OutputFormat::Mat}, {"both", OutputFormat::Both}};
  return names;
}

/// The name of the .mat file of OutputFormat::Mat in a run directory.
inline constexpr const char* kReducedModelMatFile = "reduced_model.mat";

/// Writes the reduced model and its bases V, W (N x n) into `dir` in `format`, each file
/// atomically; creates `dir` if needed. The .mat file holds the dense double variables Mr, Dr, Kr,
/// Br, Cr[, Cvr] (second order) or Er, Ar, Br, Cr (descriptor), V, and W unless W == V (Galerkin:
/// no W variable means W = V). Files of a format not written (the reduced .mtx files, V.mtx and
/// W.mtx, or kReducedModelMatFile) left in `dir` by an earlier run are removed, so that the
/// directory holds one model.
/// \throws IoError naming the file that cannot be written or removed; NumericalError for a
///         non-finite entry.
ECMOR_API void write_reduction(const std::filesystem::path& dir, const ReducedModel& model,
                               const Matrix& V, const Matrix& W, OutputFormat format);

/// Reads a reduced model and validates it: from a run directory's .mtx files (write_reduced_model;
/// Dr.mtx absent means Dr = 0, Er.mtx absent means Er = I), else from its kReducedModelMatFile, or
/// from a .mat file named by `path` (same variables as written by write_reduction).
/// \throws InputError naming the directory or file and the rule broken.
ECMOR_API ReducedModel read_reduced_model(const std::filesystem::path& path);

/// The projection bases of a run directory: V.mtx and W.mtx (either may be gzip'ed, V.mtx.gz),
/// else the variables V and W of its kReducedModelMatFile (no W there means W = V, as
/// write_reduction writes a Galerkin basis).
struct ProjectionBases {
  Matrix V, W;
};
/// \throws InputError naming the directory when neither is there, or the file and the rule broken.
ECMOR_API ProjectionBases read_projection_bases(const std::filesystem::path& run_dir);

/// Sizes, nnz, symmetry and definiteness of a model's matrices (for `ecmor info`).
struct MatrixSummary {
  std::string name;  ///< "M", "K", "E", ...
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
  /// Descriptor models only: n of the second-order form x = [q; q'] that second_order_form()
  /// recognises (model.hpp), 0 when it finds none.
  Index second_order_size = 0;
  /// ... and whether that form's M, D, K are all symmetric (relative asymmetry <= 1e-10, the
  /// threshold of `definiteness`), which the krylov plugin's `structure: auto` needs (with M
  /// positive definite) to reduce it as a second-order model.
  bool second_order_symmetric = false;
};
/// Matrices listed: M, D, K, B, C[, Cv] (second order) or E, A, B, C (descriptor).
ECMOR_API ModelSummary summarize(const Model& model);

}  // namespace ecmor
