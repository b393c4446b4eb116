// matrix_market.cpp: Matrix Market reading (buffer + std::from_chars, no iostream per token) and
// atomic writing. Every malformed input gives an InputError "<path>: line <n>: <rule>", and a
// gzip'ed file whose compressed data are damaged "<path>: byte <offset>: <rule>".
#include "ecmor/model/matrix_market.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <vector>

#include "base/gzip.hpp"
#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;

// Sanity limits against hostile headers (checked before anything is allocated).
// A sparse matrix costs 4 (cols + 1) bytes even when empty, plus its entries, which the file must
// hold; a dense one rows * cols doubles. An array file stores every one of them (>= 2 bytes each),
// a coordinate file only the nonzeros: the zeros a dense read of it materialises are not backed by
// the file, so they get a smaller budget of their own.
constexpr std::int64_t kMaxDimension = std::int64_t{1} << 25;     // 33,554,432 rows or columns
constexpr std::int64_t kMaxDenseEntries = std::int64_t{1} << 28;  // 2 GiB of doubles
constexpr std::int64_t kMaxDenseFromCoordinate = std::int64_t{1} << 25;  // 256 MiB of doubles
// Eigen's sparse storage indexes entries with int.
constexpr std::int64_t kMaxSparseEntries = std::numeric_limits<int>::max();

std::string quoted(std::string_view s) {
  constexpr std::size_t kMax = 40;
  std::string out = "'";
  if (s.size() > kMax) {
    out.append(s.substr(0, kMax));
    out += "...";
  } else {
    out.append(s);
  }
  out += "'";
  return out;
}

std::string to_lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string count(std::int64_t n, const char* singular, const char* plural) {
  return std::to_string(n) + " " + (n == 1 ? singular : plural);
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

/// Splits `line` on blanks into at most `max_tokens` tokens; returns the number of tokens found
/// (which may exceed max_tokens: the extra ones are counted, not stored).
std::size_t split(std::string_view line, std::string_view* tokens, std::size_t max_tokens) {
  std::size_t n = 0;
  std::size_t i = 0;
  const std::size_t len = line.size();
  while (true) {
    while (i < len && is_space(line[i])) ++i;
    if (i >= len) break;
    std::size_t start = i;
    while (i < len && !is_space(line[i])) ++i;
    if (n < max_tokens) tokens[n] = line.substr(start, i - start);
    ++n;
  }
  return n;
}

/// Source of lines with their 1-based numbers and the count of bytes consumed so far.
class LineSource {
 public:
  virtual ~LineSource() = default;
  /// Next line without its terminator ("\n" or "\r\n"); false at the end of the file.
  virtual bool next(std::string_view& line) = 0;
  std::int64_t line_number() const { return line_; }
  std::int64_t consumed() const { return consumed_; }

 protected:
  std::int64_t line_ = 0;
  std::int64_t consumed_ = 0;
};

class BufferLines final : public LineSource {
 public:
  explicit BufferLines(std::string_view buffer) : buf_(buffer) {}
  bool next(std::string_view& line) override {
    if (pos_ >= buf_.size()) return false;
    const char* begin = buf_.data() + pos_;
    const std::size_t rest = buf_.size() - pos_;
    const void* nl = std::memchr(begin, '\n', rest);
    std::size_t len = nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - begin) : rest;
    pos_ += nl ? len + 1 : len;
    consumed_ = static_cast<std::int64_t>(pos_);
    if (len > 0 && begin[len - 1] == '\r') --len;
    line = std::string_view(begin, len);
    ++line_;
    return true;
  }

 private:
  std::string_view buf_;
  std::size_t pos_ = 0;
};

class StreamLines final : public LineSource {
 public:
  explicit StreamLines(std::istream& in) : in_(in) {}
  bool next(std::string_view& line) override {
    if (!std::getline(in_, current_)) return false;
    consumed_ += static_cast<std::int64_t>(current_.size()) + (in_.eof() ? 0 : 1);
    if (!current_.empty() && current_.back() == '\r') current_.pop_back();
    line = current_;
    ++line_;
    return true;
  }

 private:
  std::istream& in_;
  std::string current_;
};

enum class Format { Coordinate, Array };
enum class Field { Real, Integer, Unsigned, Pattern };
enum class Symmetry { General, Symmetric, Skew };

struct Header {
  MatrixMarketHeader pub;
  Format format = Format::Coordinate;
  Field field = Field::Real;
  Symmetry symmetry = Symmetry::General;
  std::int64_t file_size = 0;
  std::int64_t size_line = 0;  ///< 1-based line number of the size line
  /// Set (>= 0) when the size line promises more entries than the bytes after it can hold.
  std::int64_t bytes_after_size_line = -1;
};

class Parser {
 public:
  Parser(const fs::path& path, LineSource& lines, std::int64_t file_size)
      : path_(path.string()), lines_(lines), file_size_(file_size) {}

  [[noreturn]] void fail(std::int64_t line, const std::string& rule) const {
    throw InputError(path_ + ": line " + std::to_string(line) + ": " + rule);
  }
  [[noreturn]] void fail(const std::string& rule) const { fail(lines_.line_number(), rule); }

  Header parse_header();

  /// Calls sink(row, col, value) (0-based, symmetric storage expanded) for every stored entry.
  template <class Sink>
  void parse_data(const Header& h, Sink&& sink);

 private:
  [[noreturn]] void truncated(const Header& h, std::int64_t found) const {
    std::string rule = "truncated data: expected " + count(h.pub.entries, "entry", "entries") +
                       ", file ends after " + std::to_string(found) + " at line " +
                       std::to_string(lines_.line_number());
    if (h.bytes_after_size_line >= 0)
      rule += " (the size line at line " + std::to_string(h.size_line) +
              " promises more entries than the " + std::to_string(h.bytes_after_size_line) +
              " bytes after it can hold)";
    fail(rule);
  }
  /// The banner line: format, field and symmetry, with the combinations refused.
  Header parse_banner();
  /// The size line after the banner: dimensions and entry count, checked against the storage's
  /// capacity and the bytes left in the file.
  void parse_size_line(Header& h);
  std::int64_t parse_index(std::string_view tok, const char* what, std::int64_t max);
  double parse_value(std::string_view tok, Field field);
  std::int64_t parse_size(std::string_view tok, const char* what);
  /// Next line that is neither blank nor a comment; false at end of file.
  bool next_data_line(std::string_view& line) {
    while (lines_.next(line)) {
      std::string_view t = trim(line);
      if (t.empty() || t.front() == '%') continue;
      line = t;
      return true;
    }
    return false;
  }

  std::string path_;
  LineSource& lines_;
  std::int64_t file_size_;
};

Header Parser::parse_header() {
  Header h = parse_banner();
  parse_size_line(h);
  return h;
}

Header Parser::parse_banner() {
  static constexpr std::string_view kExpected =
      "expected the banner '%%MatrixMarket matrix <coordinate|array> "
      "<real|integer|unsigned-integer|pattern> "
      "<general|symmetric|skew-symmetric>'";
  std::string_view line;
  if (!lines_.next(line)) fail(1, "the file is empty: " + std::string(kExpected));
  std::string_view tok[6];
  const std::size_t n = split(line, tok, 6);
  if (n == 0)
    fail("missing Matrix Market banner: the first line is blank; " + std::string(kExpected));
  if (to_lower(tok[0]) != "%%matrixmarket") {
    if (to_lower(tok[0]).rfind("%%matrixmarket", 0) == 0)
      fail("bad Matrix Market banner " + quoted(trim(line)) + ": " + std::string(kExpected));
    fail("missing Matrix Market banner: the first line is " + quoted(trim(line)) + "; " +
         std::string(kExpected));
  }
  if (n != 5)
    fail("bad Matrix Market banner " + quoted(trim(line)) + ": it has " + std::to_string(n) +
         " words, " + std::string(kExpected));
  const std::string object = to_lower(tok[1]);
  const std::string format = to_lower(tok[2]);
  const std::string field = to_lower(tok[3]);
  const std::string symmetry = to_lower(tok[4]);
  Header h;
  if (object != "matrix")
    fail("object " + quoted(tok[1]) + " is not supported: only 'matrix' can be read");
  if (format == "coordinate") {
    h.format = Format::Coordinate;
  } else if (format == "array") {
    h.format = Format::Array;
  } else {
    fail("unknown format " + quoted(tok[2]) + ": expected 'coordinate' or 'array'");
  }
  if (field == "real") {
    h.field = Field::Real;
  } else if (field == "integer") {
    h.field = Field::Integer;
  } else if (field == "unsigned-integer") {
    // SciPy's mmwrite writes it for arrays of unsigned integers (incidence matrices, counts).
    h.field = Field::Unsigned;
  } else if (field == "pattern") {
    h.field = Field::Pattern;
  } else if (field == "complex") {
    fail(
        "field 'complex' is not supported: complex matrices cannot be read (only real, integer, "
        "unsigned-integer and pattern)");
  } else {
    fail("unknown field " + quoted(tok[3]) +
         ": expected 'real', 'integer', 'unsigned-integer' or 'pattern'");
  }
  if (symmetry == "general") {
    h.symmetry = Symmetry::General;
  } else if (symmetry == "symmetric") {
    h.symmetry = Symmetry::Symmetric;
  } else if (symmetry == "skew-symmetric") {
    h.symmetry = Symmetry::Skew;
  } else if (symmetry == "hermitian") {
    fail(
        "symmetry 'hermitian' is not supported: hermitian matrices are complex (only general, "
        "symmetric and skew-symmetric)");
  } else {
    fail("unknown symmetry " + quoted(tok[4]) +
         ": expected 'general', 'symmetric' or 'skew-symmetric'");
  }
  if (h.format == Format::Array && h.field == Field::Pattern)
    fail("field 'pattern' is only allowed with the 'coordinate' format");
  if (h.field == Field::Pattern && h.symmetry == Symmetry::Skew)
    fail("field 'pattern' cannot be skew-symmetric");
  if (h.field == Field::Unsigned && h.symmetry == Symmetry::Skew)
    fail("field 'unsigned-integer' cannot be skew-symmetric: the mirrored entries are negative");
  h.pub.format = format;
  h.pub.field = h.field == Field::Real ? "real" : field;
  h.pub.symmetry = symmetry;
  return h;
}

void Parser::parse_size_line(Header& h) {
  const std::string symmetry = h.pub.symmetry;
  std::string_view line;
  // Size line: first line that is neither a comment nor blank.
  if (!next_data_line(line))
    fail(
        "the file ends before the size line ('rows cols entries' for coordinate, 'rows cols' "
        "for array)");
  const std::size_t want = h.format == Format::Coordinate ? 3 : 2;
  const char* shape = h.format == Format::Coordinate ? "'rows cols entries'" : "'rows cols'";
  std::string_view st[4];
  const std::size_t ns = split(line, st, 4);
  h.size_line = lines_.line_number();
  if (ns != want)
    fail("bad size line " + quoted(line) + ": expected " + shape + " (" + std::to_string(want) +
         " integers), found " + std::to_string(ns) + " tokens");
  const std::int64_t rows = parse_size(st[0], "row count");
  const std::int64_t cols = parse_size(st[1], "column count");
  if (rows > kMaxDimension || cols > kMaxDimension)
    fail("size " + std::to_string(rows) + " x " + std::to_string(cols) +
         " exceeds the supported dimension " + std::to_string(kMaxDimension));
  if (h.symmetry != Symmetry::General && rows != cols)
    fail("a " + symmetry + " matrix must be square, but the size line says " +
         std::to_string(rows) + " x " + std::to_string(cols));
  // Capacity: how many entries the declared storage can hold (rows, cols <= 2^25: no overflow).
  std::int64_t capacity = rows * cols;
  if (h.symmetry == Symmetry::Symmetric) capacity = rows * (rows + 1) / 2;
  if (h.symmetry == Symmetry::Skew) capacity = rows * (rows - (rows > 0 ? 1 : 0)) / 2;
  std::int64_t entries = capacity;
  if (h.format == Format::Coordinate) {
    entries = parse_size(st[2], "entry count");
    if (entries > capacity)
      fail("the size line promises " + count(entries, "entry", "entries") + ", more than a " +
           std::to_string(rows) + " x " + std::to_string(cols) +
           (h.symmetry == Symmetry::General ? std::string(" matrix")
                                            : " " + symmetry + " matrix's stored triangle") +
           " can hold (" + std::to_string(capacity) + ")");
  }
  // Every entry needs at least one byte per token plus a separator: check the promise against
  // the bytes left in the file before anything is allocated. A promise the file cannot keep is
  // reported below, after the header is complete, as truncated data at the line where it ends.
  const std::int64_t tokens_per_entry =
      h.format == Format::Array ? 1 : (h.field == Field::Pattern ? 2 : 3);
  const std::int64_t min_bytes = entries > 0 ? entries * 2 * tokens_per_entry - 1 : 0;
  const std::int64_t left = file_size_ - lines_.consumed();
  h.pub.rows = rows;
  h.pub.cols = cols;
  h.pub.entries = entries;
  h.file_size = file_size_;
  if (min_bytes > left) {
    // The data cannot be complete. Scan it without storing anything (nothing has been
    // allocated): this fails at the first malformed line or where the file ends, with the
    // precise message. The fallback below is unreachable by construction.
    h.bytes_after_size_line = left;
    parse_data(h, [](std::int64_t, std::int64_t, double) {});
    fail(h.size_line, "the size line promises " + count(entries, "entry", "entries") + " (" +
                          std::to_string(rows) + " x " + std::to_string(cols) +
                          "), which need at least " + std::to_string(min_bytes) +
                          " bytes, but only " + std::to_string(left) + " bytes follow");
  }
}

std::int64_t Parser::parse_size(std::string_view tok, const char* what) {
  std::int64_t v = 0;
  if (!tok.empty() && tok.front() == '-') {
    auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (ec == std::errc() && p == tok.data() + tok.size())
      fail(std::string("negative ") + what + " " + quoted(tok) + " in the size line");
  }
  std::string_view t = tok;
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  // from_chars accepts a leading '-': after a '+' it would let "+-5" through as -5.
  const bool signed_twice = !t.empty() && (t.front() == '-' || t.front() == '+');
  auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (signed_twice) ec = std::errc::invalid_argument;
  if (ec == std::errc::result_out_of_range)
    fail(std::string(what) + " " + quoted(tok) + " in the size line is too large");
  if (ec != std::errc() || p != t.data() + t.size() || t.empty())
    fail(std::string("bad ") + what + " " + quoted(tok) +
         " in the size line: expected a non-negative integer");
  return v;
}

std::int64_t Parser::parse_index(std::string_view tok, const char* what, std::int64_t max) {
  std::int64_t v = 0;
  auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
  if (ec == std::errc::result_out_of_range ||
      (ec == std::errc() && p == tok.data() + tok.size() && (v < 1 || v > max)))
    fail(std::string(what) + " index " + quoted(tok) + " is out of range 1.." +
         std::to_string(max));
  if (ec != std::errc() || p != tok.data() + tok.size())
    fail(std::string("bad ") + what + " index " + quoted(tok) + ": expected an integer");
  return v;
}

double Parser::parse_value(std::string_view tok, Field field) {
  std::string_view t = tok;
  if (t.size() > 1 && t.front() == '+' && t[1] != '-' && t[1] != '+') t.remove_prefix(1);
  if (field == Field::Integer || field == Field::Unsigned) {
    const bool is_unsigned = field == Field::Unsigned;
    const char* name = is_unsigned ? "'unsigned-integer'" : "'integer'";
    std::int64_t v = 0;
    auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    if (ec == std::errc() && p == t.data() + t.size()) {
      if (is_unsigned && v < 0) fail("bad value " + quoted(tok) + ": the field is " + name);
      return static_cast<double>(v);
    }
    if (is_unsigned && ec == std::errc::result_out_of_range && t.front() != '-') {
      // Above 2^63 - 1: still an unsigned 64-bit integer.
      std::uint64_t u = 0;
      auto [pu, ecu] = std::from_chars(t.data(), t.data() + t.size(), u);
      if (ecu == std::errc() && pu == t.data() + t.size()) return static_cast<double>(u);
    }
    if (ec == std::errc::result_out_of_range)
      fail("integer value " + quoted(tok) + " is out of range");
    fail("bad value " + quoted(tok) + ": the field is " + name);
  }
  double v = 0.0;
  auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (p != t.data() + t.size() || (ec != std::errc() && ec != std::errc::result_out_of_range))
    fail("cannot parse " + quoted(tok) + " as a real number");
  if (ec == std::errc::result_out_of_range) {
    // Distinguish underflow (accepted: rounds to zero) from overflow (an error).
    std::string copy(t);
    errno = 0;
    v = std::strtod(copy.c_str(), nullptr);
    if (std::isinf(v)) fail("value " + quoted(tok) + " overflows double precision");
  }
  if (!std::isfinite(v)) fail("value " + quoted(tok) + " is not finite (NaN or Inf)");
  return v;
}

template <class Sink>
void Parser::parse_data(const Header& h, Sink&& sink) {
  const std::int64_t rows = h.pub.rows;
  const std::int64_t cols = h.pub.cols;
  const std::int64_t entries = h.pub.entries;
  std::string_view line;
  std::string_view tok[3];
  if (h.format == Format::Coordinate) {
    const std::size_t want = h.field == Field::Pattern ? 2 : 3;
    const char* shape = h.field == Field::Pattern ? "'row column'" : "'row column value'";
    for (std::int64_t k = 0; k < entries; ++k) {
      if (!next_data_line(line)) truncated(h, k);
      const std::size_t n = split(line, tok, 3);
      if (n != want)
        fail(std::string(n > want ? "extra tokens in entry " : "too few tokens in entry ") +
             quoted(line) + ": expected " + shape);
      const std::int64_t i = parse_index(tok[0], "row", rows);
      const std::int64_t j = parse_index(tok[1], "column", cols);
      const double v = h.field == Field::Pattern ? 1.0 : parse_value(tok[2], h.field);
      if (h.symmetry == Symmetry::General) {
        sink(i - 1, j - 1, v);
      } else if (i < j) {
        fail("entry (" + std::to_string(i) + ", " + std::to_string(j) +
             ") is above the diagonal: a " + h.pub.symmetry +
             " file stores only the lower triangle");
      } else if (i == j) {
        if (h.symmetry == Symmetry::Skew)
          fail("entry (" + std::to_string(i) + ", " + std::to_string(j) +
               ") is on the diagonal: a skew-symmetric file stores only the strict lower "
               "triangle");
        sink(i - 1, j - 1, v);
      } else {
        sink(i - 1, j - 1, v);
        sink(j - 1, i - 1, h.symmetry == Symmetry::Skew ? -v : v);
      }
    }
  } else {
    // Column-major, one value per line; symmetric: lower triangle with the diagonal; skew: strict.
    std::int64_t k = 0;
    for (std::int64_t j = 0; j < cols; ++j) {
      const std::int64_t first =
          h.symmetry == Symmetry::General ? 0 : (h.symmetry == Symmetry::Symmetric ? j : j + 1);
      for (std::int64_t i = first; i < rows; ++i, ++k) {
        if (!next_data_line(line)) truncated(h, k);
        const std::size_t n = split(line, tok, 3);
        if (n != 1)
          fail("extra tokens in " + quoted(line) + ": an 'array' file holds one value per line");
        const double v = parse_value(tok[0], h.field);
        sink(i, j, v);
        if (i != j && h.symmetry != Symmetry::General)
          sink(j, i, h.symmetry == Symmetry::Skew ? -v : v);
      }
    }
  }
  if (next_data_line(line))
    fail("unexpected data " + quoted(line) + " after the " + count(entries, "entry", "entries") +
         " the size line promised");
}

std::int64_t file_size_of(const fs::path& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw InputError(path.string() + ": cannot open: file does not exist");
  if (fs::is_directory(st)) throw InputError(path.string() + ": cannot read: is a directory");
  const auto size = fs::file_size(path, ec);
  if (ec) throw InputError(path.string() + ": cannot read: " + ec.message());
  return static_cast<std::int64_t>(size);
}

bool has_gz_name(const fs::path& path) { return path.extension() == ".gz"; }

/// The first bytes of a file (fewer if it is shorter).
std::string read_prefix(const fs::path& path, std::size_t n) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw InputError(path.string() + ": cannot open: " + std::strerror(errno));
  std::string buf(n, '\0');
  buf.resize(std::fread(buf.data(), 1, n, f));
  std::fclose(f);
  return buf;
}

/// The text of a Matrix Market file: its bytes, or their decompression when the file is gzip'ed
/// (recognised by its first bytes, whatever its name; a name ending in .gz must be gzip data).
std::string read_whole_file(const fs::path& path) {
  const std::int64_t size = file_size_of(path);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw InputError(path.string() + ": cannot open: " + std::strerror(errno));
  std::string buf(static_cast<std::size_t>(size), '\0');
  const std::size_t got = size > 0 ? std::fread(buf.data(), 1, buf.size(), f) : 0;
  const bool error = std::ferror(f) != 0;
  std::fclose(f);
  if (error) throw InputError(path.string() + ": read error");
  buf.resize(got);  // a file that shrank while being read is parsed as it was read
  if (detail::is_gzip(buf) || has_gz_name(path)) return detail::gunzip(buf, path.string());
  return buf;
}

/// Parses the whole file, calling on_header(header, parser) once the sizes are known, then sink
/// per entry.
template <class OnHeader, class Sink>
void parse_file(const fs::path& path, OnHeader&& on_header, Sink&& sink) {
  const std::string buf = read_whole_file(path);
  BufferLines lines(buf);
  Parser parser(path, lines, static_cast<std::int64_t>(buf.size()));
  const Header h = parser.parse_header();
  on_header(h, parser);
  parser.parse_data(h, sink);
}

std::string overflowing_sum_rule(std::int64_t i, std::int64_t j) {
  return "the duplicate entries at (" + std::to_string(i + 1) + ", " + std::to_string(j + 1) +
         ") sum to a value that overflows double precision";
}

void write_comment(std::ostream& out, const std::string& comment) {
  if (comment.empty()) return;
  std::size_t start = 0;
  while (start <= comment.size()) {
    std::size_t end = comment.find('\n', start);
    if (end == std::string::npos) end = comment.size();
    std::string_view line(comment.data() + start, end - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    out << '%';
    if (!line.empty()) out << ' ' << line;
    out << '\n';
    if (end == comment.size()) break;
    start = end + 1;
  }
}

void check_finite_for_write(const fs::path& path, Index i, Index j, double v) {
  if (!std::isfinite(v))
    throw NumericalError("cannot write " + path.string() + ": entry (" + std::to_string(i + 1) +
                         ", " + std::to_string(j + 1) + ") is " +
                         (std::isnan(v) ? "NaN" : "infinite") +
                         " (Matrix Market files hold finite values only)");
}

}  // namespace

fs::path find_matrix_market_file(const fs::path& dir, const std::string& stem) {
  std::error_code ec;
  const fs::path plain = dir / (stem + ".mtx");
  const fs::path gz = dir / (stem + ".mtx.gz");
  const bool has_plain = fs::is_regular_file(plain, ec);
  const bool has_gz = fs::is_regular_file(gz, ec);
  if (has_plain && has_gz)
    throw InputError(dir.string() + ": " + plain.filename().string() + " and " +
                     gz.filename().string() + " are both present: keep one (which of them holds " +
                     stem + " is ambiguous)");
  return has_plain ? plain : (has_gz ? gz : fs::path());
}

MatrixMarketHeader read_matrix_market_header(const fs::path& path) {
  const std::int64_t size = file_size_of(path);
  if (has_gz_name(path) || detail::is_gzip(read_prefix(path, 2))) {
    // The whole file is decompressed, as the full readers do: the header then gets the same
    // verdict and the same message from both (an error in the compressed data is found before
    // the text is parsed), and the size line's promise is checked against the text's real size.
    const std::string text = read_whole_file(path);
    BufferLines lines(text);
    Parser parser(path, lines, static_cast<std::int64_t>(text.size()));
    return parser.parse_header().pub;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot open: " + std::strerror(errno));
  StreamLines lines(in);
  Parser parser(path, lines, size);
  return parser.parse_header().pub;
}

SparseMatrix read_matrix_market_sparse(const fs::path& path) {
  struct Entry {
    int row;
    int col;
    double value;
  };
  std::vector<Entry> entries;
  Index rows = 0, cols = 0;
  const Parser* parser = nullptr;
  // Duplicates are summed after parsing, but an overflowing sum must be reported at its line, in
  // file order like every other error (and like the dense reader). While the sum of all |values|
  // so far is finite no partial sum can overflow; from the entry that makes it infinite on (only
  // in files with values near the largest double), the sums are tracked per position.
  double abs_total = 0.0;
  bool exact = false;
  std::unordered_map<std::uint64_t, double> sums;
  const auto key = [](std::int64_t i, std::int64_t j) {
    return (static_cast<std::uint64_t>(i) << 32) | static_cast<std::uint64_t>(j);
  };
  parse_file(
      path,
      [&](const Header& h, const Parser& p) {
        parser = &p;
        rows = h.pub.rows;
        cols = h.pub.cols;
        // Entries were checked against the file size: reserving is safe.
        std::int64_t n = h.pub.entries;
        if (h.symmetry != Symmetry::General) n *= 2;
        if (n > kMaxSparseEntries)
          p.fail(h.size_line, "the size line promises " + count(h.pub.entries, "entry", "entries") +
                                  ", more than a sparse matrix can store (" +
                                  std::to_string(kMaxSparseEntries) + ")");
        if (h.format == Format::Array) n = 0;  // array files: grow as needed
        entries.reserve(static_cast<std::size_t>(n));
      },
      [&](std::int64_t i, std::int64_t j, double v) {
        if (!exact) {
          abs_total += std::abs(v);
          if (std::isfinite(abs_total)) {
            entries.push_back({static_cast<int>(i), static_cast<int>(j), v});
            return;
          }
          exact = true;  // every partial sum so far is finite: start tracking them
          for (const Entry& e : entries) sums[key(e.row, e.col)] += e.value;
        }
        double& sum = sums[key(i, j)];
        sum += v;
        if (!std::isfinite(sum)) parser->fail(overflowing_sum_rule(i, j));
        entries.push_back({static_cast<int>(i), static_cast<int>(j), v});
      });
  // Compressed column storage filled directly from the entries sorted by (column, row): memory is
  // the entries plus one int per column, even for a huge, nearly empty matrix (Eigen's
  // setFromTriplets needs several rows- and cols-sized work arrays: 400 MB and 2 s for an empty
  // 2^25 x 2^25 file). The sort is stable, so duplicates are summed in file order.
  std::stable_sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.col != b.col ? a.col < b.col : a.row < b.row;
  });
  std::size_t unique = 0;
  for (std::size_t k = 0; k < entries.size(); ++k)
    if (k == 0 || entries[k].col != entries[k - 1].col || entries[k].row != entries[k - 1].row)
      ++unique;
  SparseMatrix A(rows, cols);  // compressed, every column start 0
  A.resizeNonZeros(static_cast<Index>(unique));
  int* const start = A.outerIndexPtr();
  int* const inner = A.innerIndexPtr();
  double* const value = A.valuePtr();
  std::size_t p = 0;
  for (std::size_t k = 0; k < entries.size();) {
    const int i = entries[k].row;
    const int j = entries[k].col;
    double sum = entries[k].value;
    for (++k; k < entries.size() && entries[k].col == j && entries[k].row == i; ++k)
      sum += entries[k].value;
    if (!std::isfinite(sum))  // unreachable: checked in file order while parsing
      throw InputError(path.string() + ": " + overflowing_sum_rule(i, j));
    inner[p] = i;
    value[p] = sum;
    ++p;
    ++start[j + 1];  // count per column, turned into starts below
  }
  if (p > 0)
    for (Index j = 0; j < cols; ++j) start[j + 1] += start[j];
  return A;
}

Matrix read_matrix_market_dense(const fs::path& path) {
  Matrix A;
  const Parser* parser = nullptr;
  parse_file(
      path,
      [&](const Header& h, const Parser& p) {
        parser = &p;
        const std::int64_t total = h.pub.rows * h.pub.cols;
        if (total > kMaxDenseEntries)
          p.fail(h.size_line, "a dense " + std::to_string(h.pub.rows) + " x " +
                                  std::to_string(h.pub.cols) +
                                  " matrix is too large to read (limit " +
                                  std::to_string(kMaxDenseEntries) + " entries)");
        // A coordinate file does not store the zeros: refuse to materialise more of them than
        // a separate, smaller budget allows (an array file pays for its entries in bytes).
        if (h.format == Format::Coordinate && total > kMaxDenseFromCoordinate)
          p.fail(h.size_line, "a dense " + std::to_string(h.pub.rows) + " x " +
                                  std::to_string(h.pub.cols) +
                                  " matrix is too large to read from a coordinate file (limit " +
                                  std::to_string(kMaxDenseFromCoordinate) +
                                  " entries; store it in the 'array' format, limit " +
                                  std::to_string(kMaxDenseEntries) + ")");
        A.setZero(h.pub.rows, h.pub.cols);
      },
      [&](std::int64_t i, std::int64_t j, double v) {
        double& a = A(i, j);
        a = a == 0.0 ? v : a + v;  // duplicates are summed; a lone -0.0 keeps its sign
        if (!std::isfinite(a)) parser->fail(overflowing_sum_rule(i, j));
      });
  return A;
}

void write_matrix_market(const fs::path& path, const SparseMatrix& A, const std::string& comment) {
  for (Index j = 0; j < A.outerSize(); ++j)
    for (SparseMatrix::InnerIterator it(A, j); it; ++it)
      check_finite_for_write(path, it.row(), it.col(), it.value());
  write_file_atomically(path, [&](std::ostream& out) {
    out << "%%MatrixMarket matrix coordinate real general\n";
    write_comment(out, comment);
    out << A.rows() << ' ' << A.cols() << ' ' << A.nonZeros() << '\n';
    char buf[96];
    for (Index j = 0; j < A.outerSize(); ++j) {
      for (SparseMatrix::InnerIterator it(A, j); it; ++it) {
        const int len = std::snprintf(buf, sizeof buf, "%lld %lld %.17g\n",
                                      static_cast<long long>(it.row() + 1),
                                      static_cast<long long>(it.col() + 1), it.value());
        out.write(buf, len);
      }
    }
  });
}

void write_matrix_market(const fs::path& path, const Matrix& A, const std::string& comment) {
  for (Index j = 0; j < A.cols(); ++j)
    for (Index i = 0; i < A.rows(); ++i) check_finite_for_write(path, i, j, A(i, j));
  write_file_atomically(path, [&](std::ostream& out) {
    out << "%%MatrixMarket matrix array real general\n";
    write_comment(out, comment);
    out << A.rows() << ' ' << A.cols() << '\n';
    char buf[64];
    for (Index j = 0; j < A.cols(); ++j) {
      for (Index i = 0; i < A.rows(); ++i) {
        const int len = std::snprintf(buf, sizeof buf, "%.17g\n", A(i, j));
        out.write(buf, len);
      }
    }
  });
}

}  // namespace ecmor
