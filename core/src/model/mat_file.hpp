#pragma once
// mat_file.hpp: MATLAB .mat files through matio: reading numeric matrices (MAT v4, v5 and v7.3,
// dense or sparse, any real numeric or logical class) and writing dense double matrices (MAT v5).
// Private to the core's sources: matio's types stay out of the public headers.
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <utility>

#include "ecmor/base/types.hpp"

struct _mat_t;  // matio's file handle (mat_t)

namespace ecmor::detail {

/// A MAT file open for reading. Every error is an InputError "<origin>: variable <name> ...: rule".
class MatReader {
 public:
  /// Opens `path` read-only and lists its variables.
  /// \throws InputError "<origin>: file does not exist", "...: not a MAT file (matio cannot open
  ///         it)".
  MatReader(const std::filesystem::path& path, std::string origin);
  ~MatReader();
  MatReader(const MatReader&) = delete;
  MatReader& operator=(const MatReader&) = delete;

  [[noreturn]] void fail(const std::string& rule) const;
  const std::string& origin() const { return m_origin; }

  bool has(const std::string& name) const { return m_names.count(name) > 0; }
  /// The variables in the file, sorted and comma-separated ("no variables" if none).
  std::string found_list() const;

  /// rows x cols read from the variable's header, before any data is read.
  /// \throws InputError for a variable that is missing, complex, not numeric (char, cell, struct,
  ///         object, ...) or not 2-D.
  std::pair<Index, Index> shape(const std::string& name) const;

  /// The variable as a sparse matrix (dense variables: their nonzeros; NaN is kept, for
  /// ecmor::validate to name). Integer and logical classes are converted to double.
  /// \throws InputError as shape(), and for malformed sparse data or a size beyond 32-bit indices.
  SparseMatrix sparse(const std::string& name) const;

  /// The variable as a dense matrix (sparse variables expanded).
  Matrix dense(const std::string& name) const;

 private:
  struct VarDeleter {
    void operator()(void* var) const;
  };
  using VarPtr = std::unique_ptr<void, VarDeleter>;
  /// The variable's header (with_data false) or the whole variable, its class, complexity and
  /// rank checked.
  VarPtr read(const std::string& name, bool with_data) const;
  SparseMatrix sparse_of(const void* var, const std::string& name) const;
  Matrix dense_of(const void* var, const std::string& name) const;
  std::string var(const std::string& name) const { return "variable " + name; }

  std::string m_origin;
  _mat_t* m_mat = nullptr;
  std::set<std::string> m_names;
};

/// Writes dense double matrices into a new MAT v5 file at `path`, replacing any file there.
/// Not atomic by itself: callers write to a temporary name (write_named_file_atomically) and give
/// the final name as `target`, which the messages name.
class MatWriter {
 public:
  /// \throws IoError naming the target when matio cannot create the file.
  /// `header` is the file's descriptive text (MATLAB shows it with `whos -file`).
  MatWriter(const std::filesystem::path& path, const std::filesystem::path& target,
            const char* header = "ecmor reduced model");
  ~MatWriter();
  MatWriter(const MatWriter&) = delete;
  MatWriter& operator=(const MatWriter&) = delete;

  /// \throws NumericalError for a non-finite entry (as write_matrix_market), IoError when matio
  ///         fails to write.
  void write(const std::string& name, const Matrix& A);
  /// Closes the file, reporting a failure to flush it.
  void close();

 private:
  std::filesystem::path m_target;
  _mat_t* m_mat = nullptr;
};

}  // namespace ecmor::detail
