#pragma once
/// \file gzip_text.hpp
/// gzip compression for tests, straight through zlib's deflate (ecmor itself only decompresses):
/// the `.mtx.gz` files the tests read are written here, independently of the reader under test.
/// Link the test with ZLIB::ZLIB.

#include <zlib.h>

#include <stdexcept>
#include <string>
#include <string_view>

namespace ecmor::test {

/// `text` as one gzip member (deflate level `level`, no file name or time stamp in the header).
inline std::string gzip_text(std::string_view text, int level = 9) {
  z_stream z{};
  if (deflateInit2(&z, level, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("deflateInit2 failed");
  std::string out(deflateBound(&z, static_cast<uLong>(text.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (rc != Z_STREAM_END) throw std::runtime_error("deflate did not finish");
  return out;
}

}  // namespace ecmor::test
