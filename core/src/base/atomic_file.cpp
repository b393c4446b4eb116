// atomic_file.cpp: write to a uniquely named temporary file beside the target, flush, fsync,
// rename over the target. On any failure the temporary is removed and the target is untouched.
#include "ecmor/base/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>

#include "ecmor/base/error.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;

std::atomic<unsigned long> g_counter{0};

fs::path temporary_name(const fs::path& target) {
  const unsigned long n = g_counter.fetch_add(1, std::memory_order_relaxed);
  // Built with append (GCC 12 gives a false -Wrestrict on `"." + std::string`).
  std::string name(1, '.');
  name.append(target.filename().string());
  name.append(".tmp.");
  name.append(std::to_string(static_cast<long>(::getpid())));
  name.push_back('.');
  name.append(std::to_string(n));
  return target.parent_path() / name;
}

void remove_quietly(const fs::path& p) {
  std::error_code ec;
  fs::remove(p, ec);
}

/// Flushes the file's data to stable storage (best effort: failure to fsync is not fatal on
/// file systems that do not support it, but a reported I/O error is).
void sync_file(const fs::path& p) {
  const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0 && err == EIO) throw std::system_error(err, std::generic_category(), "fsync");
}

/// Checks the target, then fill(tmp) writes the temporary file (and reports its own failures);
/// then fsync and rename. The temporary is removed on any failure.
void commit_atomically(const fs::path& path, const std::function<void(const fs::path&)>& fill) {
  const std::string where = path.string();
  if (path.empty()) throw IoError("cannot write a file with an empty path");
  if (!path.has_filename()) throw IoError("cannot write " + where + ": the path names a directory");

  const fs::path parent = path.parent_path();
  if (!parent.empty()) {
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec)
      throw IoError("cannot write " + where + ": cannot create directory " + parent.string() +
                    ": " + ec.message());
  }
  {
    std::error_code ec;
    if (fs::is_directory(path, ec))
      throw IoError("cannot write " + where + ": a directory of that name exists");
  }

  const fs::path tmp = temporary_name(path);
  try {
    fill(tmp);
  } catch (const Error&) {
    remove_quietly(tmp);
    throw;  // already a complete ecmor message: keep its type
  } catch (const std::exception& e) {
    remove_quietly(tmp);
    throw IoError("cannot write " + where + ": " + e.what());
  } catch (...) {
    remove_quietly(tmp);
    throw IoError("cannot write " + where + ": unknown error while writing");
  }
  try {
    sync_file(tmp);
  } catch (const std::system_error& e) {
    remove_quietly(tmp);
    throw IoError("cannot write " + where + ": " + e.what());
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    remove_quietly(tmp);
    throw IoError("cannot write " + where + ": cannot rename " + tmp.string() +
                  " to it: " + ec.message());
  }
}

}  // namespace

void write_file_atomically(const fs::path& path, const std::function<void(std::ostream&)>& writer) {
  commit_atomically(path, [&](const fs::path& tmp) {
    const std::string where = path.string();
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      const int err = errno;
      throw IoError("cannot write " + where + ": cannot create temporary file " + tmp.string() +
                    ": " + std::strerror(err));
    }
    writer(out);  // on a throw, `out` closes while unwinding, before the temporary is removed
    out.flush();
    const bool ok_before_close = static_cast<bool>(out);
    out.close();
    if (!ok_before_close || out.fail()) {
      const int err = errno;
      throw IoError("cannot write " + where + ": write to " + tmp.string() + " failed" +
                    (err != 0 ? std::string(": ") + std::strerror(err) : std::string()));
    }
  });
}

void write_named_file_atomically(const fs::path& path,
                                 const std::function<void(const fs::path& tmp)>& writer) {
  commit_atomically(path, [&](const fs::path& tmp) {
    writer(tmp);
    std::error_code ec;
    if (!fs::is_regular_file(tmp, ec))
      throw IoError("cannot write " + path.string() + ": the writer did not create " +
                    tmp.string());
  });
}

void write_text_atomically(const fs::path& path, std::string_view contents) {
  write_file_atomically(path, [&](std::ostream& out) {
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
  });
}

}  // namespace ecmor
