// gzip.cpp: whole-file gzip decompression with zlib, every failure named with its byte offset.
#include "base/gzip.hpp"

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <new>

#include "ecmor/base/error.hpp"

namespace ecmor::detail {
namespace {

// zlib counts input and output in 32-bit unsigned ints: larger buffers are fed in pieces.
constexpr std::size_t kMaxPiece = std::size_t{1} << 30;
// Deflate expands by at most 1032:1, so the size a trailer claims is capped by that; the first
// output buffer is never larger than the file could hold.
constexpr std::size_t kMaxRatio = 1032;
constexpr std::size_t kMinOutput = std::size_t{1} << 16;

[[noreturn]] void fail(const std::string& name, std::size_t offset, const std::string& rule) {
  throw InputError(name + ": byte " + std::to_string(offset) + ": " + rule);
}

/// A z_stream set up to read gzip members (not raw deflate, not zlib), released on every path.
class GzipStream {
 public:
  GzipStream() {
    // 16 + MAX_WBITS: gzip wrapper only, with its CRC-32 and length checked at each member's end.
    if (inflateInit2(&m_stream, 16 + MAX_WBITS) != Z_OK) throw std::bad_alloc();
  }
  ~GzipStream() { inflateEnd(&m_stream); }
  GzipStream(const GzipStream&) = delete;
  GzipStream& operator=(const GzipStream&) = delete;
  z_stream* operator->() { return &m_stream; }
  z_stream* get() { return &m_stream; }

 private:
  z_stream m_stream{};
};

/// The last member's ISIZE trailer (its decompressed size modulo 2^32): a first guess at the
/// output size, right for every single-member file below 4 GiB, bounded by what deflate allows.
std::size_t size_hint(std::string_view compressed) {
  if (compressed.size() < 18) return kMinOutput;  // smaller than an empty member
  const auto* end = reinterpret_cast<const unsigned char*>(compressed.data() + compressed.size());
  const std::uint32_t isize = std::uint32_t{end[-4]} | std::uint32_t{end[-3]} << 8 |
                              std::uint32_t{end[-2]} << 16 | std::uint32_t{end[-1]} << 24;
  const std::size_t bound = compressed.size() * kMaxRatio;
  return std::max<std::size_t>(kMinOutput, std::min<std::size_t>(isize, bound) + 1);
}

}  // namespace

bool is_gzip(std::string_view bytes) {
  return bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f &&
         static_cast<unsigned char>(bytes[1]) == 0x8b;
}

std::string gunzip(std::string_view compressed, const std::string& name) {
  if (!is_gzip(compressed))
    fail(name, 0,
         "not gzip data: the file does not start with the gzip magic number 1f 8b (a .gz name "
         "needs gzip-compressed contents)");
  const auto* in = reinterpret_cast<const Bytef*>(compressed.data());
  const std::size_t in_size = compressed.size();
  std::size_t fed = 0;  // bytes handed to zlib so far; the offset is fed - avail_in
  std::string out(size_hint(compressed), '\0');
  std::size_t produced = 0;
  GzipStream z;
  z->next_in = const_cast<Bytef*>(in);  // zlib's API is not const-correct; it never writes input
  z->avail_in = 0;
  while (true) {
    if (z->avail_in == 0 && fed < in_size) {
      z->next_in = const_cast<Bytef*>(in + fed);
      z->avail_in = static_cast<uInt>(std::min(kMaxPiece, in_size - fed));
      fed += z->avail_in;
    }
    if (produced == out.size()) out.resize(out.size() + std::max(out.size() / 2, kMinOutput));
    z->next_out = reinterpret_cast<Bytef*>(out.data() + produced);
    z->avail_out = static_cast<uInt>(std::min(kMaxPiece, out.size() - produced));
    const int rc = inflate(z.get(), Z_NO_FLUSH);
    produced = static_cast<std::size_t>(reinterpret_cast<char*>(z->next_out) - out.data());
    const std::size_t offset = fed - z->avail_in;
    if (rc == Z_STREAM_END) {
      if (offset == in_size) break;
      // Another member may follow; anything else after a complete member is refused (gzip(1)
      // would warn and drop it, which hides a damaged or mislabelled file).
      if (!is_gzip(compressed.substr(offset)))
        fail(name, offset,
             "unexpected data after the end of the gzip stream: " +
                 std::to_string(in_size - offset) + " byte(s) that are not a gzip member");
      if (inflateReset(z.get()) != Z_OK) throw std::bad_alloc();
      continue;
    }
    if (rc == Z_MEM_ERROR) throw std::bad_alloc();
    if (rc == Z_DATA_ERROR || rc == Z_NEED_DICT || rc == Z_STREAM_ERROR)
      fail(name, offset,
           std::string("corrupt gzip data: ") + (z->msg ? z->msg : "invalid compressed data"));
    // Z_OK or Z_BUF_ERROR: more output space or more input is needed. With all input given and
    // room left for output, the stream ended before its end marker.
    if (fed == in_size && z->avail_in == 0 && z->avail_out > 0)
      fail(name, in_size,
           "truncated gzip data: the file ends before the end of the compressed stream (" +
               std::to_string(produced) + " bytes decompressed)");
  }
  out.resize(produced);  // no shrink_to_fit: the text is parsed and dropped, a copy costs more
  return out;
}

}  // namespace ecmor::detail
