// subprocess.cpp: fork/exec with the child's failures reported back through a close-on-exec pipe,
// so that "program not found" is told apart from a program that exits with 127 itself.
#include "ecmor/interop/subprocess.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "ecmor/base/error.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;

// What the child failed at before exec replaced it, sent through the pipe.
enum Stage : int { kChdir = 1, kOpenLog = 2, kExec = 3 };
struct ChildFailure {
  int stage;
  int error;
};

}  // namespace

std::string ProgramExit::describe() const {
  return fmt::format("{} {}", signalled ? "signal" : "exit status", code);
}

ProgramExit run_program(const std::string& program, const std::vector<std::string>& args,
                        const fs::path& dir, const fs::path& log, bool stdout_to_log) {
  // The child changes into `dir` first: paths it uses afterwards must not depend on that.
  const std::string exe =
      program.find('/') == std::string::npos ? program : fs::absolute(program).string();
  const std::string log_path = fs::absolute(log).string();
  std::vector<const char*> argv{exe.c_str()};
  for (const std::string& a : args) argv.push_back(a.c_str());
  argv.push_back(nullptr);

  int report[2];
  if (::pipe2(report, O_CLOEXEC) != 0)
    throw IoError(fmt::format("cannot start {}: pipe: {}", exe, std::strerror(errno)));
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(report[0]);
    ::close(report[1]);
    throw IoError(fmt::format("cannot start {}: fork: {}", exe, std::strerror(errno)));
  }
  if (pid == 0) {
    // Child: only async-signal-safe calls until exec.
    ::close(report[0]);
    ChildFailure failure{0, 0};
    const int out = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int null = ::open("/dev/null", O_RDWR);
    if (out < 0 || null < 0) {
      failure = {kOpenLog, errno};
    } else if (::chdir(dir.c_str()) != 0) {
      failure = {kChdir, errno};
    } else {
      ::dup2(null, STDIN_FILENO);
      ::dup2(stdout_to_log ? out : null, STDOUT_FILENO);
      ::dup2(out, STDERR_FILENO);
      ::execvp(exe.c_str(), const_cast<char* const*>(argv.data()));
      failure = {kExec, errno};
    }
    [[maybe_unused]] const ssize_t n = ::write(report[1], &failure, sizeof failure);
    ::_exit(127);
  }
  ::close(report[1]);
  ChildFailure failure{0, 0};
  ssize_t got = 0;
  do {
    got = ::read(report[0], &failure, sizeof failure);
  } while (got < 0 && errno == EINTR);
  ::close(report[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw IoError(fmt::format("waiting for {} failed", exe));
  }
  if (got == static_cast<ssize_t>(sizeof failure)) {
    const char* why = std::strerror(failure.error);
    switch (failure.stage) {
      case kChdir:
        throw IoError(fmt::format("cannot run {}: cannot enter {}: {}", exe, dir.string(), why));
      case kOpenLog:
        throw IoError(fmt::format("cannot run {}: cannot open its log {}: {}", exe, log_path, why));
      default:
        throw IoError(fmt::format("cannot run '{}': {}", exe, why));
    }
  }
  ProgramExit result;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.signalled = !WIFEXITED(status);
  result.code = WIFEXITED(status) ? WEXITSTATUS(status) : WTERMSIG(status);
  return result;
}

}  // namespace ecmor
