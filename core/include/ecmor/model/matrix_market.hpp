#pragma once
/// \file matrix_market.hpp
/// Matrix Market (https://math.nist.gov/MatrixMarket/formats.html) reading and writing.
/// Supported on read: `matrix coordinate|array real|integer|pattern
/// general|symmetric|skew-symmetric`. Every malformed file gives an InputError naming the file, the
/// line and the rule broken: bad or missing header, bad size line, truncated data, out-of-range
/// index, duplicate entry in a symmetric file's upper triangle, non-finite value (NaN, Inf),
/// duplicate entries whose sum overflows, trailing garbage, sizes that promise more than the file
/// can hold. Writing is atomic (temporary file + rename).
///
/// Messages read "<path>: line <n>: <rule>", e.g.
///   "A.mtx: line 99: truncated data: expected 120 entries, file ends after 97 at line 99".
/// Comment lines (starting with %) and blank lines are allowed anywhere after the banner; CRLF line
/// endings are accepted; banner words are case-insensitive; an 'array' file holds one value per
/// line. Sanity limits, checked before anything is allocated: rows, cols <= 2^25; the promised
/// entry count must fit both the matrix (rows * cols, or the stored triangle) and the bytes left in
/// the file (at least 2 bytes per token); a dense result may have at most 2^28 entries, and at
/// most 2^25 when read from a coordinate file (whose zeros the file does not hold). So memory is
/// bounded by the file's size, plus 4 bytes per column of a sparse result and at most 256 MiB of
/// zeros of a dense one. Values that underflow read as zero; NaN, Inf and overflowing values (also
/// sums of duplicates) are errors. A missing or unreadable file is an InputError.
///
/// Compressed files: a gzip'ed Matrix Market file (`K.mtx.gz`, as the SuiteSparse Matrix
/// Collection and many FE exports ship them) is read by the same functions. It is recognised by
/// its first two bytes (1f 8b); a file whose name ends in `.gz` must be gzip data. The text is
/// decompressed whole before it is parsed (one or more gzip members), so the limits above apply
/// to the decompressed size, line numbers count its lines, and memory is that of the plain file.
/// Damaged compressed data are an InputError "<path>: byte <offset>: <rule>", with the 0-based
/// offset in the compressed file: a truncated stream, corrupt data or a CRC-32 mismatch (with
/// zlib's reason), or bytes after the last member that are not another member.

#include <filesystem>
#include <string>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"

namespace ecmor {

/// What the header of a Matrix Market file declares.
struct MatrixMarketHeader {
  std::string format;    ///< "coordinate" or "array"
  std::string field;     ///< "real", "integer" or "pattern"
  std::string symmetry;  ///< "general", "symmetric" or "skew-symmetric"
  Index rows = 0;
  Index cols = 0;
  Index entries = 0;  ///< stored entries for coordinate; rows*cols (or the triangle) for array
};

/// The file of the matrix named `stem` in `dir`: `stem.mtx` or `stem.mtx.gz`, or an empty path
/// when there is neither.
/// \throws InputError naming both files when both exist (which one holds the model is ambiguous).
ECMOR_API std::filesystem::path find_matrix_market_file(const std::filesystem::path& dir,
                                                        const std::string& stem);

/// Reads only the header and size line (cheap for a plain file, used to check sizes before
/// loading; a gzip'ed file is decompressed to find them).
ECMOR_API MatrixMarketHeader read_matrix_market_header(const std::filesystem::path& path);

/// Reads a Matrix Market file as a sparse matrix (symmetric storage expanded to the full pattern;
/// duplicate coordinate entries are summed, as in the format's convention).
ECMOR_API SparseMatrix read_matrix_market_sparse(const std::filesystem::path& path);

/// Reads a Matrix Market file (coordinate or array) as a dense matrix.
ECMOR_API Matrix read_matrix_market_dense(const std::filesystem::path& path);

/// Writes a sparse matrix as `coordinate real general` (17 significant digits), atomically.
/// `comment` (may span lines) is written as % lines after the banner. Reading the file back
/// reproduces the matrix bitwise.
/// \throws NumericalError for a non-finite entry (nothing is written); IoError (see
///         write_file_atomically).
ECMOR_API void write_matrix_market(const std::filesystem::path& path, const SparseMatrix& A,
                                   const std::string& comment = {});

/// Writes a dense matrix as `array real general` (column-major, one value per line, 17 significant
/// digits), atomically; same comment, round-trip and error rules as the sparse writer.
ECMOR_API void write_matrix_market(const std::filesystem::path& path, const Matrix& A,
                                   const std::string& comment = {});

}  // namespace ecmor
