// libFuzzer target: the Matrix Market reader (core/src/model/matrix_market.cpp) on arbitrary bytes.
//
// The input is written to a file (the reader's public API takes paths) and read three ways:
// header only (stream reader), as a sparse matrix and as a dense matrix (buffer reader). Besides
// the sanitizers, the harness checks the reader's contract and aborts, i.e. reports a crash, when
//  * anything but an ecmor::Error escapes a reader;
//  * an error message does not read "<path>: line <n>: <rule>" (or, for damaged gzip data, which
//    the reader recognises by its magic bytes whatever the file's name, "<path>: byte <n>:
//    <rule>");
//  * the readers disagree: a header the header reader refuses must make the full readers fail with
//    the same message; a matrix read sparse must have the shape the header reader reports; a
//    matrix read dense must equal the sparse one; only the dense-size rule may refuse a dense read
//    of a file the sparse reader accepts;
//  * a matrix read holds a non-finite value;
//  * writing a matrix read and reading it back does not reproduce it bitwise.
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "ecmor/base/error.hpp"
#include "ecmor/model/matrix_market.hpp"

namespace fs = std::filesystem;
using namespace ecmor;

namespace {

fs::path g_dir;
fs::path g_input;
fs::path g_sparse_copy;
fs::path g_dense_copy;

[[noreturn]] void contract(const std::string& what) {
  std::fprintf(stderr, "\n*** fuzz_matrix_market: contract violated: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

/// Runs f; returns the ecmor::Error message, or nullopt when f succeeds. Any other exception
/// breaks the reader's contract.
template <class F>
std::optional<std::string> error_of(const char* reader, F&& f) {
  try {
    f();
    return std::nullopt;
  } catch (const Error& e) {
    return std::string(e.what());
  } catch (const std::exception& e) {
    contract(std::string(reader) + " threw a non-ecmor exception: " + e.what());
  } catch (...) {
    contract(std::string(reader) + " threw a non-std exception");
  }
}

/// "<path>: line <n>: <rule>" for the text, "<path>: byte <offset>: <rule>" for damaged gzip data.
void check_message(const char* reader, const std::string& msg, const fs::path& path) {
  std::size_t i = std::string::npos;
  for (const char* where : {": line ", ": byte "}) {
    const std::string prefix = path.string() + where;
    if (msg.rfind(prefix, 0) == 0) i = prefix.size();
  }
  if (i == std::string::npos)
    contract(std::string(reader) + ": message does not start with '<path>: line ' or " +
             "'<path>: byte ': " + msg);
  std::size_t digits = 0;
  while (i < msg.size() && msg[i] >= '0' && msg[i] <= '9') ++i, ++digits;
  if (digits == 0 || msg.compare(i, 2, ": ") != 0 || msg.size() <= i + 2)
    contract(std::string(reader) +
             ": message lacks 'line <n>: <rule>' or 'byte <n>: <rule>': " + msg);
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void write_input(const uint8_t* data, size_t size) {
  std::FILE* f = std::fopen(g_input.c_str(), "wb");
  if (!f) contract("cannot create " + g_input.string());
  if (size > 0 && std::fwrite(data, 1, size, f) != size) contract("cannot write the input");
  if (std::fclose(f) != 0) contract("cannot close the input");
}

void round_trip_sparse(const SparseMatrix& A, const std::string& comment) {
  write_matrix_market(g_sparse_copy, A, comment);
  const SparseMatrix B = read_matrix_market_sparse(g_sparse_copy);
  if (B.rows() != A.rows() || B.cols() != A.cols() || B.nonZeros() != A.nonZeros())
    contract("sparse round trip changed the shape or the number of stored entries");
  for (Index j = 0; j < A.outerSize(); ++j) {
    SparseMatrix::InnerIterator a(A, j), b(B, j);
    for (; a && b; ++a, ++b)
      if (a.row() != b.row() || !same_bits(a.value(), b.value()))
        contract("sparse round trip is not bitwise");
  }
}

void round_trip_dense(const Matrix& A, const std::string& comment) {
  write_matrix_market(g_dense_copy, A, comment);
  const Matrix B = read_matrix_market_dense(g_dense_copy);
  if (B.rows() != A.rows() || B.cols() != A.cols()) contract("dense round trip changed the shape");
  for (Index j = 0; j < A.cols(); ++j)
    for (Index i = 0; i < A.rows(); ++i)
      if (!same_bits(A(i, j), B(i, j))) contract("dense round trip is not bitwise");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // tmpfs when there is one: the writer fsyncs, which costs nothing there.
  std::error_code ec;
  const fs::path base =
      fs::is_directory("/dev/shm", ec) ? fs::path("/dev/shm") : fs::temp_directory_path();
  // Directories of earlier runs that ended in a crash (no atexit then) are removed, once their
  // process is gone.
  const std::string prefix = "ecmor_fuzz_mm_";
  for (const fs::directory_entry& e : fs::directory_iterator(base, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const long pid = std::strtol(name.c_str() + prefix.size(), nullptr, 10);
    if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
      std::error_code ec2;
      fs::remove_all(e.path(), ec2);
    }
  }
  g_dir = base / (prefix + std::to_string(::getpid()));
  fs::create_directories(g_dir);
  g_input = g_dir / "input.mtx";
  g_sparse_copy = g_dir / "sparse.mtx";
  g_dense_copy = g_dir / "dense.mtx";
  std::atexit([] {
    std::error_code ec2;
    fs::remove_all(g_dir, ec2);
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  write_input(data, size);

  MatrixMarketHeader header;
  const auto header_error =
      error_of("read_matrix_market_header", [&] { header = read_matrix_market_header(g_input); });
  // (Swapped in: Eigen 3.4's SparseMatrix has no move assignment, and a copy of a 2^25-column
  // result would cost the fuzzer more than the read.)
  SparseMatrix sparse;
  const auto sparse_error = error_of("read_matrix_market_sparse", [&] {
    SparseMatrix read = read_matrix_market_sparse(g_input);
    sparse.swap(read);
  });
  Matrix dense;
  const auto dense_error =
      error_of("read_matrix_market_dense", [&] { dense = read_matrix_market_dense(g_input); });

  if (header_error) check_message("read_matrix_market_header", *header_error, g_input);
  if (sparse_error) check_message("read_matrix_market_sparse", *sparse_error, g_input);
  if (dense_error) check_message("read_matrix_market_dense", *dense_error, g_input);

  if (header_error) {
    // The stream (header) and buffer (full) readers share the parser: same verdict, same words.
    if (!sparse_error || *sparse_error != *header_error)
      contract("header reader failed (" + *header_error + ") but the sparse reader said " +
               (sparse_error ? *sparse_error : std::string("nothing")));
    if (!dense_error || *dense_error != *header_error)
      contract("header reader failed (" + *header_error + ") but the dense reader said " +
               (dense_error ? *dense_error : std::string("nothing")));
    return 0;
  }
  if (sparse_error) {
    // The dense reader adds a size rule only; otherwise it fails where the sparse one does.
    if (!dense_error)
      contract("the dense reader accepted what the sparse reader refused: " + *sparse_error);
    if (*dense_error != *sparse_error && dense_error->find("too large") == std::string::npos)
      contract("sparse and dense readers disagree: '" + *sparse_error + "' vs '" + *dense_error +
               "'");
    return 0;
  }

  if (sparse.rows() != header.rows || sparse.cols() != header.cols)
    contract("the sparse matrix's shape differs from the header's");
  for (Index k = 0; k < sparse.nonZeros(); ++k)
    if (!std::isfinite(sparse.valuePtr()[k]))
      contract("the sparse matrix holds a non-finite value");
  if (dense_error) {
    if (dense_error->find("too large") == std::string::npos)
      contract("the dense reader refused what the sparse reader accepted: " + *dense_error);
  } else {
    if (dense.rows() != sparse.rows() || dense.cols() != sparse.cols())
      contract("dense and sparse shapes differ");
    // One plain pass over up to 2^25 entries (Eigen's allFinite() and count() take seconds under
    // the coverage instrumentation).
    Index dense_nonzeros = 0;
    const double* d = dense.data();
    for (Index k = 0, n = dense.size(); k < n; ++k) {
      if (!std::isfinite(d[k])) contract("the dense matrix holds a non-finite value");
      dense_nonzeros += d[k] != 0.0;
    }
    // Equal up to rounding (duplicates may be summed in another order): at the sparse entries,
    // and no nonzero elsewhere.
    Index sparse_nonzeros = 0;
    for (Index j = 0; j < sparse.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(sparse, j); it; ++it) {
        const double a = dense(it.row(), it.col()), b = it.value();
        if (std::abs(a - b) > 1e-12 * std::max(std::abs(a), std::abs(b)))
          contract("dense and sparse values differ at (" + std::to_string(it.row() + 1) + ", " +
                   std::to_string(it.col() + 1) + ")");
        if (b != 0.0) ++sparse_nonzeros;
      }
    if (dense_nonzeros != sparse_nonzeros)
      contract("the dense matrix has nonzeros where the sparse one has none");
  }

  // Round trips through the writer, on matrices small enough to keep the fuzzer fast. The comment
  // is taken from the input, so the writer's comment handling is fuzzed too.
  const std::string comment(reinterpret_cast<const char*>(data), std::min<size_t>(size, 48));
  const auto rt_sparse = error_of("sparse round trip", [&] {
    if (sparse.nonZeros() <= 4096 && sparse.cols() <= 65536) round_trip_sparse(sparse, comment);
  });
  if (rt_sparse) contract("sparse round trip failed: " + *rt_sparse);
  if (!dense_error) {
    const auto rt_dense = error_of("dense round trip", [&] {
      if (dense.size() <= 4096) round_trip_dense(dense, comment);
    });
    if (rt_dense) contract("dense round trip failed: " + *rt_dense);
  }
  return 0;
}
