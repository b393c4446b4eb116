#pragma once
// text_fields.hpp: line-oriented text input shared by the small text readers (fe_geometry.cpp,
// calculix_deck.cpp, calculix_import.cpp, sid.cpp): whole-file lines with their numbers, trimming,
// splitting, and numbers that must parse completely. Private to the interop library's sources.
// Every failure is an InputError that names the file and the line, so the readers only add the
// rule.
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "ecmor/base/error.hpp"

namespace ecmor::detail {

/// "path: line n: " (the prefix of every message about a line of a text file).
inline std::string at_line(const std::filesystem::path& path, std::size_t line) {
  return path.string() + ": line " + std::to_string(line) + ": ";
}

/// Calls fn(line, number) for each line of a text file (number 1-based, the CR of CRLF endings
/// removed), streaming: large files (ccx's matrices) are never held whole. A missing or
/// unreadable file is an InputError naming `what` ("node file", "CalculiX deck") and the path.
template <class Fn>
void for_each_line(const std::filesystem::path& path, const std::string& what, Fn&& fn) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path.string() + ": " + what + " not found");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot open " + what);
  std::size_t number = 0;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    fn(line, ++number);
  }
  if (in.bad()) throw InputError(path.string() + ": read error in " + what);
}

/// All lines of a text file (see for_each_line).
inline std::vector<std::string> read_lines(const std::filesystem::path& path,
                                           const std::string& what) {
  std::vector<std::string> lines;
  for_each_line(path, what,
                [&](std::string& line, std::size_t) { lines.push_back(std::move(line)); });
  return lines;
}

inline std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t");
  return s.substr(first, last - first + 1);
}

/// Fields separated by `sep`, each trimmed; "a,,b" gives an empty middle field.
inline std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (true) {
    const auto pos = s.find(sep, start);
    out.push_back(trim(s.substr(start, pos == std::string_view::npos ? pos : pos - start)));
    if (pos == std::string_view::npos) return out;
    start = pos + 1;
  }
}

/// The integer `s` spells completely (an optional leading '+' allowed), or nothing.
inline std::optional<long long> parse_integer(std::string_view s) {
  if (s.size() > 1 && s[0] == '+') s.remove_prefix(1);
  long long v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || p != s.data() + s.size()) return std::nullopt;
  return v;
}

/// The finite real `s` spells completely (an optional leading '+' allowed), or nothing: NaN, Inf
/// and out-of-range values are not numbers a mesh or a matrix may hold.
inline std::optional<double> parse_real(std::string_view s) {
  if (s.size() > 1 && s[0] == '+') s.remove_prefix(1);
  double v = 0.0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v))
    return std::nullopt;
  return v;
}

}  // namespace ecmor::detail
