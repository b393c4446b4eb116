#pragma once
/// \file atomic_file.hpp
/// Atomic output: write to a temporary file in the target's directory, flush, then rename over the
/// target, so that a reader (or an interrupted run) sees either the old or the new complete file.

#include <filesystem>
#include <functional>
#include <ostream>
#include <string_view>

#include "ecmor/export.hpp"

namespace ecmor {

/// Calls writer(stream) on a temporary file next to `path`, then renames it to `path`.
/// Creates missing parent directories.
/// \throws IoError naming the path if the file cannot be created, written or renamed; the
///         temporary file is removed and `path` is left untouched. An ecmor::Error thrown by
///         `writer` propagates unchanged (after the same clean-up); any other exception from
///         `writer` becomes an IoError naming the path.
ECMOR_API void write_file_atomically(const std::filesystem::path& path,
                                     const std::function<void(std::ostream&)>& writer);

/// The same for a library that writes a file by name (matio): calls writer(tmp) with the path of
/// a temporary file next to `path`, which the writer creates, then syncs and renames it to `path`.
/// Same errors and clean-up as above.
ECMOR_API void write_named_file_atomically(
    const std::filesystem::path& path,
    const std::function<void(const std::filesystem::path& tmp)>& writer);

/// Convenience: atomically replace `path` with `contents`.
ECMOR_API void write_text_atomically(const std::filesystem::path& path, std::string_view contents);

}  // namespace ecmor
