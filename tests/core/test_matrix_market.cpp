// Tests of the Matrix Market reader/writer and of atomic file output.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/gzip_text.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/matrix_market.hpp"

namespace fs = std::filesystem;
using namespace ecmor;

namespace {

using test::TempDir;
using test::write_raw;

std::string read_raw(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Writes `contents` to a file called `name` in `dir` and expects the reader to fail with an
/// InputError whose message holds the file path, "line <line>" and `rule`.
void expect_error(const TempDir& dir, const std::string& name, const std::string& contents,
                  int line, const std::string& rule, bool dense = false) {
  SCOPED_TRACE("file " + name);
  const fs::path p = dir / name;
  write_raw(p, contents);
  try {
    if (dense)
      (void)read_matrix_market_dense(p);
    else
      (void)read_matrix_market_sparse(p);
    ADD_FAILURE() << "no InputError for " << name;
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(p.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find("line " + std::to_string(line) + ":"), std::string::npos) << msg;
    EXPECT_NE(msg.find(rule), std::string::npos) << msg;
  }
}

Matrix to_dense(const SparseMatrix& A) { return Matrix(A); }

bool bitwise_equal(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

const std::string kGeneral = "%%MatrixMarket matrix coordinate real general\n";
const std::string kSymmetric = "%%MatrixMarket matrix coordinate real symmetric\n";

}  // namespace

// ---------------------------------------------------------------------------------------------
// Reading valid files
// ---------------------------------------------------------------------------------------------

TEST(MatrixMarketRead, CoordinateGeneralWithCommentsBlankLinesAndCrlf) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "A.mtx";
  write_raw(p,
            "%%MatrixMarket matrix coordinate real general\r\n"
            "% a comment\r\n"
            "\r\n"
            "%another comment\r\n"
            "  3 4 4  \r\n"
            "1 1 1.5\r\n"
            "\r\n"
            "% comment between entries\r\n"
            "3\t4\t-2e3\r\n"
            "2 1 +7\r\n"
            "  1 3 .25\r\n"
            "\r\n");
  const SparseMatrix A = read_matrix_market_sparse(p);
  ASSERT_EQ(A.rows(), 3);
  ASSERT_EQ(A.cols(), 4);
  EXPECT_EQ(A.nonZeros(), 4);
  EXPECT_TRUE(A.isCompressed());
  Matrix expected = Matrix::Zero(3, 4);
  expected(0, 0) = 1.5;
  expected(2, 3) = -2000.0;
  expected(1, 0) = 7.0;
  expected(0, 2) = 0.25;
  EXPECT_EQ(to_dense(A), expected);
  EXPECT_EQ(read_matrix_market_dense(p), expected);

  const MatrixMarketHeader h = read_matrix_market_header(p);
  EXPECT_EQ(h.format, "coordinate");
  EXPECT_EQ(h.field, "real");
  EXPECT_EQ(h.symmetry, "general");
  EXPECT_EQ(h.rows, 3);
  EXPECT_EQ(h.cols, 4);
  EXPECT_EQ(h.entries, 4);
}

TEST(MatrixMarketRead, NoNewlineAtEndAndCaseInsensitiveBanner) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "A.mtx";
  write_raw(p, "%%MatrixMarket MATRIX Coordinate Real General\n2 2 1\n2 2 3.0");
  const SparseMatrix A = read_matrix_market_sparse(p);
  EXPECT_EQ(A.coeff(1, 1), 3.0);
  EXPECT_EQ(A.nonZeros(), 1);
}

TEST(MatrixMarketRead, SymmetricStorageIsExpanded) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "S.mtx";
  write_raw(p, kSymmetric + "3 3 4\n1 1 2\n2 1 -1\n3 2 -1\n3 3 2\n");
  const SparseMatrix A = read_matrix_market_sparse(p);
  Matrix expected(3, 3);
  expected << 2, -1, 0, -1, 0, -1, 0, -1, 2;
  EXPECT_EQ(to_dense(A), expected);
  EXPECT_EQ(A.nonZeros(), 6);
  EXPECT_EQ(read_matrix_market_dense(p), expected);
  EXPECT_EQ(read_matrix_market_header(p).symmetry, "symmetric");
}

TEST(MatrixMarketRead, SkewSymmetricStorageIsExpanded) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "S.mtx";
  write_raw(p, "%%MatrixMarket matrix coordinate real skew-symmetric\n3 3 2\n2 1 5\n3 1 -4\n");
  Matrix expected(3, 3);
  expected << 0, -5, 4, 5, 0, 0, -4, 0, 0;
  EXPECT_EQ(to_dense(read_matrix_market_sparse(p)), expected);
  EXPECT_EQ(read_matrix_market_dense(p), expected);
}

TEST(MatrixMarketRead, PatternAndIntegerFields) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "P.mtx";
  write_raw(p, "%%MatrixMarket matrix coordinate pattern symmetric\n2 2 2\n1 1\n2 1\n");
  Matrix expected(2, 2);
  expected << 1, 1, 1, 0;
  EXPECT_EQ(to_dense(read_matrix_market_sparse(p)), expected);
  EXPECT_EQ(read_matrix_market_header(p).field, "pattern");

  const fs::path q = dir / "I.mtx";
  write_raw(q, "%%MatrixMarket matrix coordinate integer general\n2 2 2\n1 2 -7\n2 1 +12\n");
  Matrix expected_int(2, 2);
  expected_int << 0, -7, 12, 0;
  EXPECT_EQ(to_dense(read_matrix_market_sparse(q)), expected_int);
  EXPECT_EQ(read_matrix_market_header(q).field, "integer");

  // SciPy's mmwrite writes the field 'unsigned-integer' for unsigned integer arrays (here as
  // scipy.io.mmwrite writes an incidence matrix of dtype uint8: banner, its comment line, size).
  const fs::path u = dir / "U.mtx";
  write_raw(u,
            "%%MatrixMarket matrix coordinate unsigned-integer general\n%\n3 2 3\n1 1 1\n2 1 "
            "1\n3 2 18446744073709551615\n");
  Matrix expected_unsigned = Matrix::Zero(3, 2);
  expected_unsigned(0, 0) = 1;
  expected_unsigned(1, 0) = 1;
  expected_unsigned(2, 1) = 18446744073709551615.0;
  EXPECT_EQ(to_dense(read_matrix_market_sparse(u)), expected_unsigned);
  EXPECT_EQ(read_matrix_market_header(u).field, "unsigned-integer");
  const fs::path ua = dir / "UA.mtx";
  write_raw(ua, "%%MatrixMarket matrix array unsigned-integer symmetric\n2 2\n4\n1\n9\n");
  Matrix expected_array(2, 2);
  expected_array << 4, 1, 1, 9;
  EXPECT_EQ(to_dense(read_matrix_market_sparse(ua)), expected_array);
}

TEST(MatrixMarketRead, ArrayFormats) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path g = dir / "G.mtx";
  // Column-major: (1,1) (2,1) (1,2) (2,2) (1,3) (2,3)
  write_raw(g, "%%MatrixMarket matrix array real general\n% c\n2 3\n1\n2\n3\n4\n5\n6\n");
  Matrix expected(2, 3);
  expected << 1, 3, 5, 2, 4, 6;
  EXPECT_EQ(read_matrix_market_dense(g), expected);
  EXPECT_EQ(to_dense(read_matrix_market_sparse(g)), expected);
  const MatrixMarketHeader h = read_matrix_market_header(g);
  EXPECT_EQ(h.format, "array");
  EXPECT_EQ(h.entries, 6);

  const fs::path s = dir / "S.mtx";
  // Lower triangle, column-major: (1,1) (2,1) (3,1) (2,2) (3,2) (3,3)
  write_raw(s, "%%MatrixMarket matrix array real symmetric\n3 3\n1\n2\n3\n4\n5\n6\n");
  Matrix sym(3, 3);
  sym << 1, 2, 3, 2, 4, 5, 3, 5, 6;
  EXPECT_EQ(read_matrix_market_dense(s), sym);
  EXPECT_EQ(read_matrix_market_header(s).entries, 6);

  const fs::path k = dir / "K.mtx";
  // Strict lower triangle: (2,1) (3,1) (3,2)
  write_raw(k, "%%MatrixMarket matrix array integer skew-symmetric\n3 3\n1\n2\n3\n");
  Matrix skew(3, 3);
  skew << 0, -1, -2, 1, 0, -3, 2, 3, 0;
  EXPECT_EQ(read_matrix_market_dense(k), skew);
  EXPECT_EQ(read_matrix_market_header(k).entries, 3);
}

TEST(MatrixMarketRead, DuplicatesAreSummed) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "D.mtx";
  write_raw(p, kGeneral + "2 2 3\n1 1 1\n1 1 2.5\n2 2 1\n");
  EXPECT_EQ(read_matrix_market_sparse(p).coeff(0, 0), 3.5);
  EXPECT_EQ(read_matrix_market_dense(p)(0, 0), 3.5);
}

TEST(MatrixMarketRead, EmptyMatrices) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "Z.mtx";
  write_raw(p, kGeneral + "1 24 0\n");
  EXPECT_EQ(read_matrix_market_dense(p), Matrix::Zero(1, 24));
  const SparseMatrix A = read_matrix_market_sparse(p);
  EXPECT_EQ(A.rows(), 1);
  EXPECT_EQ(A.cols(), 24);
  EXPECT_EQ(A.nonZeros(), 0);

  const fs::path q = dir / "E.mtx";
  write_raw(q, "%%MatrixMarket matrix array real general\n0 3\n");
  EXPECT_EQ(read_matrix_market_dense(q).cols(), 3);
  EXPECT_EQ(read_matrix_market_dense(q).rows(), 0);
}

TEST(MatrixMarketRead, SubnormalAndUnderflowingValues) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "U.mtx";
  write_raw(p, kGeneral + "2 1 2\n1 1 4.9406564584124654e-324\n2 1 -1e-400\n");
  const Matrix A = read_matrix_market_dense(p);
  EXPECT_EQ(A(0, 0), std::numeric_limits<double>::denorm_min());
  EXPECT_EQ(A(1, 0), 0.0);  // underflows to (negative) zero: accepted
}

// A real 4.7 MB file (1.2 MB gzip'ed), read whole (its read rate is a benchmark: bench_core "read
// Matrix Market").
TEST(MatrixMarketRead, BenchmarkModelFileIsReadWhole) {
  const fs::path p = fs::path(ECMOR_TEST_SOURCE_DIR) / "models/rail_20209/A.mtx.gz";
  ASSERT_TRUE(fs::exists(p)) << p;
  const SparseMatrix A = read_matrix_market_sparse(p);
  EXPECT_EQ(A.rows(), 20209);
  EXPECT_EQ(A.cols(), 20209);
  EXPECT_EQ(A.nonZeros(), 139233);
  EXPECT_EQ(A.coeff(0, 0), -4.4356049786006052e-06);  // the file's first entry, bit for bit
}

// ---------------------------------------------------------------------------------------------
// gzip'ed files (.mtx.gz), written here by zlib's deflate (common/gzip_text.hpp)
// ---------------------------------------------------------------------------------------------

const std::string kGzText =
    "%%MatrixMarket matrix coordinate real symmetric\n% a comment\n4 4 6\n1 1 2.5\n2 1 -1\n"
    "2 2 3.25\n3 3 1e-300\n4 2 0.125\n4 4 7\n";

/// The InputError message of reading `p` as a sparse matrix ("" and a failure when it reads).
std::string read_error(const fs::path& p) {
  return test::message_of<InputError>([&] { (void)read_matrix_market_sparse(p); });
}

TEST(MatrixMarketGzip, ReadsAsThePlainFileDoes) {
  TempDir dir{"ecmor_test_mm_gz"};
  write_raw(dir / "A.mtx", kGzText);
  for (int level : {1, 6, 9}) {
    SCOPED_TRACE(level);
    write_raw(dir / "A.mtx.gz", test::gzip_text(kGzText, level));
    const MatrixMarketHeader hp = read_matrix_market_header(dir / "A.mtx");
    const MatrixMarketHeader hz = read_matrix_market_header(dir / "A.mtx.gz");
    EXPECT_EQ(hz.rows, hp.rows);
    EXPECT_EQ(hz.cols, hp.cols);
    EXPECT_EQ(hz.entries, hp.entries);
    EXPECT_EQ(hz.symmetry, "symmetric");
    const Matrix a = to_dense(read_matrix_market_sparse(dir / "A.mtx"));
    const Matrix b = to_dense(read_matrix_market_sparse(dir / "A.mtx.gz"));
    const Matrix c = read_matrix_market_dense(dir / "A.mtx.gz");
    ASSERT_EQ(b.rows(), 4);
    for (Index j = 0; j < 4; ++j)
      for (Index i = 0; i < 4; ++i) {
        EXPECT_TRUE(bitwise_equal(a(i, j), b(i, j))) << i << "," << j;
        EXPECT_TRUE(bitwise_equal(a(i, j), c(i, j))) << i << "," << j;
      }
    EXPECT_EQ(b(1, 3), 0.125);  // the symmetric storage expanded
  }
}

// gzip's content is recognised by its magic bytes, whatever the name; a .gz name must be gzip.
TEST(MatrixMarketGzip, RecognisedByContentAndNameMustMatch) {
  TempDir dir{"ecmor_test_mm_gz"};
  write_raw(dir / "renamed.mtx", test::gzip_text(kGzText));
  EXPECT_EQ(read_matrix_market_sparse(dir / "renamed.mtx").nonZeros(), 8);
  write_raw(dir / "plain.mtx.gz", kGzText);
  const std::string msg = read_error(dir / "plain.mtx.gz");
  EXPECT_NE(msg.find((dir / "plain.mtx.gz").string() + ": byte 0: not gzip data"),
            std::string::npos)
      << msg;
  EXPECT_EQ(
      test::message_of<InputError>([&] { (void)read_matrix_market_header(dir / "plain.mtx.gz"); }),
      msg);
}

// `cat a.gz b.gz` is one valid gzip file: the text is the concatenation, as gzip -d gives it.
TEST(MatrixMarketGzip, SeveralMembersAreOneText) {
  TempDir dir{"ecmor_test_mm_gz"};
  for (std::size_t split : {std::size_t{1}, kGzText.size() / 2, kGzText.size() - 1}) {
    SCOPED_TRACE(split);
    write_raw(dir / "m.mtx.gz",
              test::gzip_text(kGzText.substr(0, split)) + test::gzip_text(kGzText.substr(split)));
    const SparseMatrix A = read_matrix_market_sparse(dir / "m.mtx.gz");
    EXPECT_EQ(A.nonZeros(), 8);
    EXPECT_EQ(A.coeff(3, 1), 0.125);
  }
}

// A file cut anywhere is an error at the byte where it ends, never a short matrix.
TEST(MatrixMarketGzip, EveryTruncationIsANamedErrorAtTheEnd) {
  TempDir dir{"ecmor_test_mm_gz"};
  const std::string gz = test::gzip_text(kGzText);
  const fs::path p = dir / "cut.mtx.gz";
  for (std::size_t n = 0; n < gz.size(); ++n) {
    SCOPED_TRACE(n);
    write_raw(p, gz.substr(0, n));
    const std::string msg = read_error(p);
    const std::string where = p.string() + ": byte " + std::to_string(n) + ": ";
    if (n < 2) {  // not even the magic number
      EXPECT_NE(msg.find(p.string() + ": byte 0: not gzip data"), std::string::npos) << msg;
    } else {
      EXPECT_NE(msg.find(where + "truncated gzip data"), std::string::npos) << msg;
    }
  }
}

// Each single damaged byte is found (CRC-32, the length check, deflate's own rules), unless it
// lies where it does not change the text: a header field (flags' text bit, time stamp, extra
// flags, OS) or the padding bits after the last deflate block, in its last byte. Then the matrix
// read is the original one. Never another matrix.
TEST(MatrixMarketGzip, EveryDamagedByteIsFoundOrHarmless) {
  TempDir dir{"ecmor_test_mm_gz"};
  write_raw(dir / "A.mtx", kGzText);
  const Matrix original = to_dense(read_matrix_market_sparse(dir / "A.mtx"));
  const std::string gz = test::gzip_text(kGzText);
  const fs::path p = dir / "bad.mtx.gz";
  int refused = 0;
  for (std::size_t k = 0; k < gz.size(); ++k) {
    for (unsigned char flip : {0x01, 0x80, 0xff}) {
      SCOPED_TRACE(std::to_string(k) + " ^ " + std::to_string(flip));
      std::string bad = gz;
      bad[k] = static_cast<char>(static_cast<unsigned char>(bad[k]) ^ flip);
      write_raw(p, bad);
      try {
        const Matrix A = to_dense(read_matrix_market_sparse(p));
        ASSERT_EQ(A.rows(), original.rows());
        ASSERT_EQ(A.cols(), original.cols());
        EXPECT_TRUE(A.cwiseEqual(original).all());
        const std::size_t last_deflate_byte = gz.size() - 9;  // before CRC-32 and length
        EXPECT_TRUE((k >= 3 && k < 10) || k == last_deflate_byte)
            << "a change outside the header's free fields and the padding went unseen";
      } catch (const InputError& e) {
        ++refused;
        const std::string msg = e.what();
        EXPECT_EQ(msg.rfind(p.string() + ": ", 0), 0u) << msg;
        EXPECT_TRUE(msg.find(": byte ") != std::string::npos ||
                    msg.find(": line ") != std::string::npos)
            << msg;
      }
    }
  }
  EXPECT_GT(refused, static_cast<int>(2 * gz.size()));
}

TEST(MatrixMarketGzip, CorruptDataAndTrailingBytesAreNamed) {
  TempDir dir{"ecmor_test_mm_gz"};
  const std::string gz = test::gzip_text(kGzText);
  const fs::path p = dir / "c.mtx.gz";
  // The CRC-32 of the text, the last member's bytes size - 8 .. size - 5.
  std::string bad_crc = gz;
  bad_crc[gz.size() - 8] = static_cast<char>(bad_crc[gz.size() - 8] ^ 0x5a);
  write_raw(p, bad_crc);
  std::string msg = read_error(p);
  EXPECT_NE(msg.find("corrupt gzip data: incorrect data check"), std::string::npos) << msg;
  EXPECT_NE(msg.find(p.string() + ": byte "), std::string::npos) << msg;
  // A reserved block type (11) in the first deflate block header, right after the 10-byte header.
  std::string bad_block = gz;
  bad_block[10] = static_cast<char>(static_cast<unsigned char>(bad_block[10]) | 0x06);
  write_raw(p, bad_block);
  msg = read_error(p);
  EXPECT_NE(msg.find(p.string() + ": byte 11: "), std::string::npos) << msg;  // right after it
  EXPECT_NE(msg.find("corrupt gzip data: invalid block type"), std::string::npos) << msg;
  // Bytes after the stream that are not a member.
  write_raw(p, gz + "junk");
  msg = read_error(p);
  EXPECT_NE(msg.find(p.string() + ": byte " + std::to_string(gz.size()) +
                     ": unexpected data after the end of the gzip stream: 4 byte(s)"),
            std::string::npos)
      << msg;
}

// Errors in the decompressed text read as in a plain file: the line of the text.
TEST(MatrixMarketGzip, TextErrorsNameTheLine) {
  TempDir dir{"ecmor_test_mm_gz"};
  const fs::path p = dir / "t.mtx.gz";
  write_raw(p, test::gzip_text("%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1\n"));
  const std::string msg = read_error(p);
  EXPECT_NE(msg.find(p.string() + ": line 3: truncated data"), std::string::npos) << msg;
}

// ---------------------------------------------------------------------------------------------
// Malformed files: each error names the file, the line and the rule
// ---------------------------------------------------------------------------------------------

TEST(MatrixMarketErrors, MissingFile) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "nothere.mtx";
  try {
    (void)read_matrix_market_sparse(p);
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)read_matrix_market_header(p), InputError);
  EXPECT_THROW((void)read_matrix_market_dense(dir.path()), InputError);  // a directory
}

TEST(MatrixMarketErrors, Banner) {
  TempDir dir{"ecmor_test_mm"};
  expect_error(dir, "empty.mtx", "", 1, "empty");
  expect_error(dir, "blank.mtx", "\n3 3 0\n", 1, "missing Matrix Market banner");
  expect_error(dir, "nobanner.mtx", "3 3 1\n1 1 1\n", 1, "missing Matrix Market banner");
  expect_error(dir, "comment.mtx", "% just a comment\n3 3 0\n", 1, "missing Matrix Market banner");
  expect_error(dir, "short.mtx", "%%MatrixMarket matrix coordinate real\n1 1 0\n", 1,
               "bad Matrix Market banner");
  expect_error(dir, "glued.mtx", "%%MatrixMarketmatrix coordinate real general\n1 1 0\n", 1,
               "bad Matrix Market banner");
  expect_error(dir, "vector.mtx", "%%MatrixMarket vector coordinate real general\n1 1 0\n", 1,
               "object 'vector' is not supported");
  expect_error(dir, "format.mtx", "%%MatrixMarket matrix sparse real general\n1 1 0\n", 1,
               "unknown format 'sparse'");
  expect_error(dir, "field.mtx", "%%MatrixMarket matrix coordinate float general\n1 1 0\n", 1,
               "unknown field 'float'");
  expect_error(dir, "sym.mtx", "%%MatrixMarket matrix coordinate real upper\n1 1 0\n", 1,
               "unknown symmetry 'upper'");
  expect_error(dir, "patarray.mtx", "%%MatrixMarket matrix array pattern general\n1 1\n", 1,
               "'pattern' is only allowed with the 'coordinate' format");
}

TEST(MatrixMarketErrors, UnsupportedComplexAndHermitianSaidPlainly) {
  TempDir dir{"ecmor_test_mm"};
  expect_error(dir, "complex.mtx",
               "%%MatrixMarket matrix coordinate complex general\n1 1 1\n1 1 1 2\n", 1,
               "field 'complex' is not supported");
  expect_error(dir, "negative_unsigned.mtx",
               "%%MatrixMarket matrix coordinate unsigned-integer general\n2 2 1\n1 1 -3\n", 3,
               "bad value '-3': the field is 'unsigned-integer'");
  expect_error(dir, "skew_unsigned.mtx",
               "%%MatrixMarket matrix coordinate unsigned-integer skew-symmetric\n2 2 1\n2 1 3\n",
               1, "field 'unsigned-integer' cannot be skew-symmetric");
  expect_error(dir, "complex_array.mtx", "%%MatrixMarket matrix array complex general\n1 1\n1 2\n",
               1, "field 'complex' is not supported");
  expect_error(dir, "herm.mtx", "%%MatrixMarket matrix coordinate real hermitian\n1 1 1\n1 1 1\n",
               1, "symmetry 'hermitian' is not supported");
}

TEST(MatrixMarketErrors, SizeLine) {
  TempDir dir{"ecmor_test_mm"};
  expect_error(dir, "nosize.mtx", kGeneral + "% only comments\n\n", 3,
               "the file ends before the size line");
  expect_error(dir, "twotok.mtx", kGeneral + "% c\n3 3\n", 3, "bad size line '3 3'");
  expect_error(dir, "fourtok.mtx", kGeneral + "3 3 1 1\n1 1 1\n", 2, "bad size line");
  expect_error(dir, "arraythree.mtx",
               "%%MatrixMarket matrix array real general\n2 2 4\n1\n2\n3\n4\n", 2, "bad size line");
  expect_error(dir, "word.mtx", kGeneral + "3 x 3\n", 2, "bad column count 'x'");
  expect_error(dir, "frac.mtx", kGeneral + "3 3 1.5\n1 1 1\n", 2, "bad entry count '1.5'");
  expect_error(dir, "neg.mtx", kGeneral + "-3 3 1\n1 1 1\n", 2, "negative row count '-3'");
  expect_error(dir, "negc.mtx", kGeneral + "3 -3 1\n1 1 1\n", 2, "negative column count '-3'");
  expect_error(dir, "negn.mtx", kGeneral + "3 3 -1\n", 2, "negative entry count '-1'");
  // A sign after '+' once parsed as a negative count (found by fuzz_matrix_market).
  expect_error(dir, "plusneg.mtx", kGeneral + "3 3 +-1\n", 2, "bad entry count '+-1'");
  expect_error(dir, "plusnegr.mtx", kGeneral + "+-3 3 1\n1 1 1\n", 2, "bad row count '+-3'");
  expect_error(dir, "plusplus.mtx", kGeneral + "3 3 ++1\n1 1 1\n", 2, "bad entry count '++1'");
  expect_error(dir, "huge.mtx", kGeneral + "99999999999999999999 3 1\n1 1 1\n", 2, "too large");
  expect_error(dir, "nonsq.mtx", kSymmetric + "3 4 1\n1 1 1\n", 2, "must be square");
}

TEST(MatrixMarketErrors, SizeLinePromisesTooMuch) {
  TempDir dir{"ecmor_test_mm"};
  expect_error(dir, "toomany.mtx", kGeneral + "2 2 5\n1 1 1\n", 2,
               "promises 5 entries, more than a 2 x 2 matrix can hold (4)");
  expect_error(dir, "symtoomany.mtx", kSymmetric + "2 2 4\n1 1 1\n", 2,
               "promises 4 entries, more than a 2 x 2 symmetric matrix's stored triangle can "
               "hold (3)");
  // A hostile header: the promised entry count is checked against the file size before any
  // allocation happens (1e12 entries would need terabytes); the file is then reported as
  // truncated where it ends.
  expect_error(dir, "hostile.mtx", kGeneral + "1000000 1000000 1000000000000\n1 1 1\n", 3,
               "expected 1000000000000 entries, file ends after 1 at line 3 (the size line at "
               "line 2 promises more entries than the 6 bytes after it can hold)");
  expect_error(dir, "hostile_array.mtx",
               "%%MatrixMarket matrix array real general\n30000000 30000000\n1\n", 3,
               "expected 900000000000000 entries, file ends after 1 at line 3", /*dense=*/true);
  expect_error(dir, "hostile_garbage.mtx", kGeneral + "1000000 1000000 1000000\n1 1 x\n", 3,
               "cannot parse 'x'", /*dense=*/true);
  try {
    (void)read_matrix_market_header(dir / "hostile.mtx");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("file ends after 1 at line 3"), std::string::npos);
  }
  expect_error(dir, "hostile_dims.mtx", kGeneral + "4000000000 4000000000 0\n", 2,
               "exceeds the supported dimension");
  // Few entries but a huge dense shape: refused by the dense reader, fine for the sparse one.
  expect_error(dir, "hostile_dense.mtx", kGeneral + "100000 100000 1\n1 1 1\n", 2,
               "too large to read", /*dense=*/true);
  EXPECT_EQ(read_matrix_market_sparse(dir / "hostile_dense.mtx").nonZeros(), 1);
}

// The huge-header rule (docs/fuzzing.md): a header can only make the reader allocate what the file
// backs. Entries must fit in the bytes after the size line; rows and columns are capped at 2^25
// (a sparse result costs 4 bytes per column even when empty); a dense result read from a
// coordinate file, whose zeros the file does not hold, at 2^25 entries (256 MiB).
TEST(MatrixMarketErrors, HugeHeadersAreRefusedBeforeAllocating) {
  TempDir dir{"ecmor_test_mm"};
  const std::string kArray = "%%MatrixMarket matrix array real general\n";
  // 10^16 doubles (80 PB) promised by a 61-byte file: refused by every reader at the size line.
  const std::string huge_array = kArray + "100000000 100000000\n";
  expect_error(dir, "huge_array.mtx", huge_array, 2,
               "size 100000000 x 100000000 exceeds the supported dimension 33554432",
               /*dense=*/true);
  expect_error(dir, "huge_array.mtx", huge_array, 2, "exceeds the supported dimension");
  EXPECT_THROW((void)read_matrix_market_header(dir / "huge_array.mtx"), InputError);
  // Within the dimension limit, the entries promised must fit in the bytes that follow.
  expect_error(dir, "big_array.mtx", kArray + "30000 30000\n", 2,
               "expected 900000000 entries, file ends after 0 at line 2 (the size line at line 2 "
               "promises more entries than the 0 bytes after it can hold)",
               /*dense=*/true);
  expect_error(dir, "big_nnz.mtx", kGeneral + "1000 1000 1000000\n1 1 1\n2 2 2\n", 4,
               "expected 1000000 entries, file ends after 2 at line 4 (the size line at line 2 "
               "promises more entries than the 12 bytes after it can hold)");
  // A coordinate file with no entries and a 2 GiB dense shape (the dense reader allocated 2 GiB
  // for these 60 bytes; fuzz_matrix_market reports it as out-of-memory): refused for a dense
  // result ...
  const fs::path empty = dir / "empty_16384.mtx";
  expect_error(dir, "empty_16384.mtx", kGeneral + "16384 16384 0\n", 2,
               "a dense 16384 x 16384 matrix is too large to read from a coordinate file (limit "
               "33554432 entries; store it in the 'array' format, limit 268435456)",
               /*dense=*/true);
  // ... but read sparse, which costs one int per column.
  const SparseMatrix S = read_matrix_market_sparse(empty);
  EXPECT_EQ(S.rows(), 16384);
  EXPECT_EQ(S.nonZeros(), 0);
  // A tall, thin input matrix (B of a large model) within the budget reads dense.
  const fs::path tall = dir / "B.mtx";
  write_raw(tall, kGeneral + "100000 8 2\n1 1 1\n100000 8 -2\n");
  const Matrix B = read_matrix_market_dense(tall);
  EXPECT_EQ(B.rows(), 100000);
  EXPECT_EQ(B(99999, 7), -2.0);
  // A tall, nearly empty sparse matrix costs nothing per row (the previous assembly by
  // setFromTriplets needed row-sized work arrays: 1.4 s and 370 MB natively for this 68-byte file,
  // a timeout (> 10 s) in the sanitized fuzz target: found by fuzz_matrix_market).
  const fs::path tall_sparse = dir / "tall_sparse.mtx";
  write_raw(tall_sparse, kGeneral + "31361959 1000 1\n1 1 1\n");
  const SparseMatrix T = read_matrix_market_sparse(tall_sparse);
  EXPECT_EQ(T.rows(), 31361959);
  EXPECT_EQ(T.nonZeros(), 1);
  // The largest dimension, nearly empty: the sparse result costs 128 MiB for the column starts
  // and nothing else (setFromTriplets took 400 MB and 2 s).
  const fs::path widest = dir / "widest.mtx";
  write_raw(widest, kGeneral + "33554432 33554432 1\n33554432 33554432 5\n");
  const SparseMatrix W = read_matrix_market_sparse(widest);
  EXPECT_EQ(W.cols(), 33554432);
  EXPECT_EQ(W.nonZeros(), 1);
  EXPECT_EQ(W.coeff(33554431, 33554431), 5.0);
}

// Finite entries whose sum overflows gave an infinite matrix entry (both readers; found by review
// while writing fuzz_matrix_market, whose finiteness check reports it).
TEST(MatrixMarketErrors, DuplicatesWhoseSumOverflows) {
  TempDir dir{"ecmor_test_mm"};
  const std::string general = kGeneral + "2 2 3\n1 1 1e308\n2 2 1\n1 1 1e308\n";
  expect_error(dir, "sum.mtx", general, 5,
               "the duplicate entries at (1, 1) sum to a value that overflows double precision");
  expect_error(dir, "sum.mtx", general, 5, "the duplicate entries at (1, 1) sum", /*dense=*/true);
  const std::string mirrored = kSymmetric + "2 2 2\n2 1 -1.5e308\n% c\n2 1 -1.5e308\n";
  expect_error(dir, "mirrored.mtx", mirrored, 5, "the duplicate entries at (2, 1) sum");
  expect_error(dir, "mirrored.mtx", mirrored, 5, "the duplicate entries at (2, 1) sum",
               /*dense=*/true);
  // The overflow is reported at its line, before later errors, by both readers (found by
  // fuzz_matrix_market: the sparse reader summed after parsing and reported the garbage on line 5
  // of this file instead, the dense reader the overflow on line 4).
  const char kGarbage[] =
      "2 2 2\n2 1 -1.5e308\n2 1 -1.5e308\n\x01\0\0"
      "0";  // with NULs
  const std::string then_garbage = kSymmetric + std::string(kGarbage, sizeof kGarbage - 1);
  expect_error(dir, "then_garbage.mtx", then_garbage, 4, "the duplicate entries at (2, 1) sum");
  expect_error(dir, "then_garbage.mtx", then_garbage, 4, "the duplicate entries at (2, 1) sum",
               /*dense=*/true);
  const std::string then_bad = kGeneral + "3 3 4\n1 1 1\n2 2 1e308\n2 2 1e308\n3 3 abc\n";
  expect_error(dir, "then_bad.mtx", then_bad, 5, "the duplicate entries at (2, 2) sum");
  expect_error(dir, "then_bad.mtx", then_bad, 5, "the duplicate entries at (2, 2) sum",
               /*dense=*/true);
  // Large sums that stay finite are fine, and so is cancellation.
  write_raw(dir / "ok.mtx", kGeneral + "2 2 3\n1 1 1e308\n1 1 -1e308\n1 1 1e308\n");
  EXPECT_EQ(read_matrix_market_sparse(dir / "ok.mtx").coeff(0, 0), 1e308);
  EXPECT_EQ(read_matrix_market_dense(dir / "ok.mtx")(0, 0), 1e308);
}

TEST(MatrixMarketErrors, TruncatedData) {
  TempDir dir{"ecmor_test_mm"};
  std::string s = kGeneral + "120 1 120\n";                           // line 2
  for (int k = 1; k <= 97; ++k) s += std::to_string(k) + " 1 1.5\n";  // lines 3..99
  expect_error(dir, "trunc.mtx", s, 99, "expected 120 entries, file ends after 97 at line 99");
  expect_error(dir, "trunc_array.mtx",
               "%%MatrixMarket matrix array real general\n2 2\n1.0\n2.0\n3.0\n", 5,
               "expected 4 entries, file ends after 3 at line 5");
}

TEST(MatrixMarketErrors, IndicesOutOfRange) {
  TempDir dir{"ecmor_test_mm"};
  expect_error(dir, "row.mtx", kGeneral + "3 3 2\n1 1 1\n4 1 1\n", 4,
               "row index '4' is out of range 1..3");
  expect_error(dir, "col.mtx", kGeneral + "3 2 2\n1 1 1\n% c\n1 3 1\n", 5,
               "column index '3' is out of range 1..2");
  expect_error(dir, "zero.mtx", kGeneral + "3 3 1\n0 1 1\n", 3,
               "row index '0' is out of range 1..3");
  expect_error(dir, "negidx.mtx", kGeneral + "3 3 1\n1 -2 1\n", 3,
               "column index '-2' is out of range");
  expect_error(dir, "fracidx.mtx", kGeneral + "3 3 1\n1.0 1 1\n", 3,
               "bad row index '1.0': expected an integer");
}

TEST(MatrixMarketErrors, BadNumbers) {
  TempDir dir{"ecmor_test_mm"};
  expect_error(dir, "abc.mtx", kGeneral + "2 2 1\n1 1 abc\n", 3,
               "cannot parse 'abc' as a real number");
  expect_error(dir, "dots.mtx", kGeneral + "2 2 1\n1 1 1.2.3\n", 3, "cannot parse '1.2.3'");
  expect_error(dir, "fortran.mtx", kGeneral + "2 2 1\n1 1 1.0D+00\n", 3, "cannot parse '1.0D+00'");
  expect_error(dir, "nan.mtx", kGeneral + "2 2 2\n1 1 1\n2 2 NaN\n", 4,
               "value 'NaN' is not finite");
  expect_error(dir, "inf.mtx", kGeneral + "2 2 1\n1 1 -inf\n", 3, "value '-inf' is not finite");
  expect_error(dir, "overflow.mtx", kGeneral + "2 2 1\n1 1 1e400\n", 3,
               "value '1e400' overflows double precision");
  expect_error(dir, "intfield.mtx",
               "%%MatrixMarket matrix coordinate integer general\n2 2 1\n1 1 1.5\n", 3,
               "bad value '1.5': the field is 'integer'");
  expect_error(dir, "nan_array.mtx", "%%MatrixMarket matrix array real general\n2 1\n1\nnan\n", 4,
               "not finite", /*dense=*/true);
}

TEST(MatrixMarketErrors, ExtraTokensAndGarbage) {
  TempDir dir{"ecmor_test_mm"};
  expect_error(dir, "extra.mtx", kGeneral + "2 2 1\n1 1 1 7\n", 3, "extra tokens in entry");
  expect_error(dir, "few.mtx", kGeneral + "2 2 1\n1 1\n", 3, "too few tokens in entry");
  expect_error(dir, "pattern_extra.mtx",
               "%%MatrixMarket matrix coordinate pattern general\n2 2 1\n1 1 1\n", 3,
               "extra tokens");
  expect_error(dir, "garbage.mtx", kGeneral + "2 2 1\n1 1 1\n\n2 2 5\n", 5,
               "unexpected data '2 2 5' after the 1 entry the size line promised");
  expect_error(dir, "garbage2.mtx", kGeneral + "2 2 1\n1 1 1\nthe end\n", 4, "unexpected data");
  expect_error(dir, "array_two.mtx", "%%MatrixMarket matrix array real general\n2 1\n1 2\n", 3,
               "one value per line");
}

TEST(MatrixMarketErrors, SymmetricUpperTriangleEntry) {
  TempDir dir{"ecmor_test_mm"};
  expect_error(dir, "upper.mtx", kSymmetric + "3 3 2\n1 1 1\n1 2 5\n", 4,
               "entry (1, 2) is above the diagonal: a symmetric file stores only the lower "
               "triangle");
  expect_error(dir, "skewdiag.mtx",
               "%%MatrixMarket matrix coordinate real skew-symmetric\n2 2 1\n1 1 5\n", 3,
               "is on the diagonal");
}

// ---------------------------------------------------------------------------------------------
// Writing and round trips
// ---------------------------------------------------------------------------------------------

namespace {
const std::vector<double> kAwkwardValues = {1.0 / 3.0,
                                            -2.0 / 7.0,
                                            1e-300,
                                            std::numeric_limits<double>::denorm_min(),
                                            std::numeric_limits<double>::max(),
                                            -std::numeric_limits<double>::min(),
                                            0.1,
                                            -0.0,
                                            123456789.123456789,
                                            6.02214076e23};
}

TEST(MatrixMarketWrite, SparseRoundTripIsBitwise) {
  TempDir dir{"ecmor_test_mm"};
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> row(0, 49), col(0, 29);
  std::normal_distribution<double> val(0.0, 1e3);
  std::vector<Eigen::Triplet<double, int>> t;
  for (int k = 0; k < 300; ++k) t.emplace_back(row(rng), col(rng), val(rng));
  for (std::size_t k = 0; k < kAwkwardValues.size(); ++k)
    t.emplace_back(static_cast<int>(k), 29, kAwkwardValues[k]);
  SparseMatrix A(50, 30);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();

  const fs::path p = dir / "sub" / "dir" / "A.mtx";  // parent directories are created
  write_matrix_market(p, A, "a comment\nover two lines");
  const std::string text = read_raw(p);
  EXPECT_EQ(text.rfind("%%MatrixMarket matrix coordinate real general\n% a comment\n% over two "
                       "lines\n50 30 ",
                       0),
            0u)
      << text.substr(0, 200);

  const SparseMatrix B = read_matrix_market_sparse(p);
  ASSERT_EQ(B.rows(), A.rows());
  ASSERT_EQ(B.cols(), A.cols());
  ASSERT_EQ(B.nonZeros(), A.nonZeros());
  for (Index k = 0; k <= A.cols(); ++k) EXPECT_EQ(A.outerIndexPtr()[k], B.outerIndexPtr()[k]);
  for (Index k = 0; k < A.nonZeros(); ++k) {
    EXPECT_EQ(A.innerIndexPtr()[k], B.innerIndexPtr()[k]);
    EXPECT_TRUE(bitwise_equal(A.valuePtr()[k], B.valuePtr()[k]))
        << A.valuePtr()[k] << " vs " << B.valuePtr()[k];
  }
}

TEST(MatrixMarketWrite, DenseRoundTripIsBitwise) {
  TempDir dir{"ecmor_test_mm"};
  Matrix A = Matrix::Random(7, 5) * 1e5;
  for (std::size_t k = 0; k < kAwkwardValues.size(); ++k)
    A(static_cast<Index>(k % 7), static_cast<Index>(k / 7)) = kAwkwardValues[k];
  const fs::path p = dir / "A.mtx";
  write_matrix_market(p, A);
  EXPECT_EQ(read_raw(p).rfind("%%MatrixMarket matrix array real general\n7 5\n", 0), 0u);
  const Matrix B = read_matrix_market_dense(p);
  ASSERT_EQ(B.rows(), 7);
  ASSERT_EQ(B.cols(), 5);
  for (Index j = 0; j < 5; ++j)
    for (Index i = 0; i < 7; ++i) EXPECT_TRUE(bitwise_equal(A(i, j), B(i, j))) << i << "," << j;
  const MatrixMarketHeader h = read_matrix_market_header(p);
  EXPECT_EQ(h.format, "array");
  EXPECT_EQ(h.entries, 35);

  // Degenerate shapes survive too.
  write_matrix_market(p, Matrix(0, 3));
  EXPECT_EQ(read_matrix_market_dense(p).cols(), 3);
}

TEST(MatrixMarketWrite, NonFiniteValueIsRefusedAndOldFileKept) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "A.mtx";
  write_matrix_market(p, Matrix(Matrix::Identity(2, 2)));
  const std::string before = read_raw(p);
  Matrix bad = Matrix::Identity(2, 2);
  bad(1, 0) = std::numeric_limits<double>::quiet_NaN();
  try {
    write_matrix_market(p, bad);
    ADD_FAILURE();
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("entry (2, 1) is NaN"), std::string::npos) << e.what();
  }
  SparseMatrix sbad(2, 2);
  sbad.insert(0, 1) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(write_matrix_market(p, sbad), NumericalError);
  EXPECT_EQ(read_raw(p), before);
}

// ---------------------------------------------------------------------------------------------
// Atomic files
// ---------------------------------------------------------------------------------------------

namespace {
std::size_t count_entries(const fs::path& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}
}  // namespace

TEST(AtomicFile, WritesAndReplaces) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "out.txt";
  write_text_atomically(p, "first");
  EXPECT_EQ(read_raw(p), "first");
  write_text_atomically(p, "second, longer");
  EXPECT_EQ(read_raw(p), "second, longer");
  write_file_atomically(p, [](std::ostream& out) { out << "third " << 3; });
  EXPECT_EQ(read_raw(p), "third 3");
  EXPECT_EQ(count_entries(dir.path()), 1u);  // no temporary left behind
}

TEST(AtomicFile, FailingWriterLeavesOldFileIntact) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path p = dir / "out.txt";
  write_text_atomically(p, "old contents");
  try {
    write_file_atomically(p, [](std::ostream& out) {
      out << "partial new contents";
      out.flush();
      throw std::runtime_error("disk on fire");
    });
    ADD_FAILURE() << "no exception";
  } catch (const IoError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(p.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find("disk on fire"), std::string::npos) << msg;
  }
  EXPECT_EQ(read_raw(p), "old contents");
  EXPECT_EQ(count_entries(dir.path()), 1u);

  // An ecmor error from the writer keeps its type.
  EXPECT_THROW(write_file_atomically(p, [](std::ostream&) { throw InputError("bad"); }),
               InputError);
  EXPECT_EQ(read_raw(p), "old contents");
  EXPECT_EQ(count_entries(dir.path()), 1u);
}

TEST(AtomicFile, FailuresNameThePath) {
  TempDir dir{"ecmor_test_mm"};
  // Target is an existing directory.
  fs::create_directories(dir / "adir");
  try {
    write_text_atomically(dir / "adir", "x");
    ADD_FAILURE();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "adir").string()), std::string::npos);
  }
  // A parent "directory" that is a regular file.
  write_raw(dir / "afile", "x");
  const fs::path under_file = dir / "afile" / "out.txt";
  try {
    write_text_atomically(under_file, "x");
    ADD_FAILURE();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(under_file.string()), std::string::npos) << e.what();
  }
  EXPECT_THROW(write_text_atomically("", "x"), IoError);
}

TEST(AtomicFile, UnwritableDirectory) {
  TempDir dir{"ecmor_test_mm"};
  const fs::path ro = dir / "ro";
  fs::create_directories(ro);
  write_text_atomically(ro / "keep.txt", "kept");
  const fs::perms read_only = fs::perms::owner_read | fs::perms::owner_exec |
                              fs::perms::group_read | fs::perms::group_exec |
                              fs::perms::others_read | fs::perms::others_exec;
  fs::permissions(ro, read_only);
  // The write is attempted in a child process; root (as CI runs) ignores permissions, so there the
  // child first becomes "nobody". Exit 0: an IoError naming the target.
  const fs::path target = ro / "keep.txt";
  auto attempt = [&target] {
    if (::geteuid() == 0 && (::setgid(65534) != 0 || ::setuid(65534) != 0)) std::_Exit(3);
    try {
      write_text_atomically(target, "new");
    } catch (const IoError& e) {
      std::_Exit(std::string(e.what()).find(target.string()) != std::string::npos ? 0 : 2);
    } catch (...) {
      std::_Exit(4);
    }
    std::_Exit(1);
  };
  EXPECT_EXIT(attempt(), ::testing::ExitedWithCode(0), "");
  fs::permissions(ro, fs::perms::owner_all);
  EXPECT_EQ(read_raw(target), "kept");
  EXPECT_EQ(count_entries(ro), 1u);  // no temporary file left behind
}
