#pragma once
// gzip.hpp: decompression of gzip files held in memory (zlib). Private to core: the Matrix
// Market reader uses it, so that every model directory may hold `.mtx.gz` beside `.mtx`.
#include <string>
#include <string_view>

namespace ecmor::detail {

/// True when `bytes` starts with the gzip magic number 1f 8b. No Matrix Market file can: its
/// first line is a banner of printable characters.
bool is_gzip(std::string_view bytes);

/// The decompressed contents of a gzip file, whose bytes are `compressed`. Several members one
/// after the other (`cat a.gz b.gz`) decompress to their concatenation, as gzip(1) does.
/// \throws InputError "<name>: byte <offset>: <rule>", where offset is the 0-based position in the
///         compressed file at which decompression stopped:
///         * the stream ends before its end marker and checksum (a truncated file);
///         * corrupt data, with zlib's reason ("invalid block type", "incorrect data check" for a
///           CRC-32 mismatch, "incorrect length check", ...);
///         * bytes after a complete member that are not another gzip member.
/// The memory used is that of the decompressed text (the plain file would cost the same).
std::string gunzip(std::string_view compressed, const std::string& name);

}  // namespace ecmor::detail
