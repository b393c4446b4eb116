#pragma once
/// \file test_support.hpp
/// Small helpers shared by the test suites.

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

namespace ecmor::test {

/// A fresh directory under the system temp dir, removed (with everything in it) at scope exit.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "ecmor_test") {
    static std::atomic<int> counter{0};
    const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
    m_path = std::filesystem::temp_directory_path() /
             (prefix + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + "_" +
              std::to_string(stamp));
    std::filesystem::create_directories(m_path);
  }
  ~TempDir() {
    std::error_code ec;
    // Tests may have removed write permission to provoke I/O errors.
    std::filesystem::permissions(m_path, std::filesystem::perms::owner_all,
                                 std::filesystem::perm_options::add, ec);
    std::filesystem::remove_all(m_path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return m_path; }
  std::filesystem::path operator/(const std::string& name) const { return m_path / name; }

 private:
  std::filesystem::path m_path;
};

/// The message of the exception of type E that f() throws; a test failure (and "") if f throws
/// nothing or another type.
template <class E, class F>
std::string message_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "unexpected exception type: " << e.what();
    return {};
  }
  ADD_FAILURE() << "no exception thrown";
  return {};
}

/// Writes `contents` to `p` byte for byte.
inline void write_raw(const std::filesystem::path& p, const std::string& contents) {
  std::ofstream out(p, std::ios::binary);
  out << contents;
  ASSERT_TRUE(out.good()) << p;
}

}  // namespace ecmor::test
