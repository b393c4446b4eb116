#pragma once
/// \file run_ecmor.hpp
/// Runs the built `ecmor` executable for the end-to-end tests: arguments quoted for the shell,
/// ECMOR_PLUGIN_PATH unset (only the build tree's plugins load), stdout and stderr captured in
/// files of a scratch directory.

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace ecmor::test {

struct CliResult {
  int exit_code = -1;
  std::string out, err;
};

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

inline std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

/// `ecmor ARGS...` from the working directory with its output in SCRATCH/stdout.txt and
/// SCRATCH/stderr.txt; `env`, when given, is put before the executable (e.g. "PATH=/nonexistent").
/// Built with append: GCC 12 gives a false -Wrestrict on `" " + std::string`.
inline CliResult run_ecmor(const std::vector<std::string>& args,
                           const std::filesystem::path& scratch, const std::string& env = "") {
  const std::filesystem::path out = scratch / "stdout.txt", err = scratch / "stderr.txt";
  std::string cmd = "env -u ECMOR_PLUGIN_PATH ";
  if (!env.empty()) cmd.append(env).append(" ");
  cmd.append(shell_quote(std::string(ECMOR_TEST_BINARY_DIR) + "/bin/ecmor"));
  for (const std::string& a : args) cmd.append(" ").append(shell_quote(a));
  cmd.append(" </dev/null >").append(shell_quote(out.string()));
  cmd.append(" 2>").append(shell_quote(err.string()));
  const int status = std::system(cmd.c_str());
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

}  // namespace ecmor::test
