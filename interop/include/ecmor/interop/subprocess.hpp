#pragma once
/// \file subprocess.hpp
/// Running an external program (ccx for the CalculiX import, gnuplot for the plots): fork/exec,
/// no shell, so that no path or argument is ever parsed by one.

#include <filesystem>
#include <string>
#include <vector>

#include "ecmor/interop/export.hpp"

namespace ecmor {

/// How a program run ended.
struct ECMOR_INTEROP_API ProgramExit {
  bool signalled = false;  ///< killed by a signal (then `code` is the signal number)
  int code = 0;            ///< exit status (0..255), or the signal number
  double seconds = 0.0;    ///< wall time
  bool ok() const { return !signalled && code == 0; }
  /// "exit status 201" or "signal 9", for messages.
  std::string describe() const;
};

/// Runs `program args...` with `dir` as its working directory; stdin reads /dev/null, stderr goes
/// to `log` (created or truncated; an absolute path, or relative to the caller's directory), and
/// stdout to `log` as well when `stdout_to_log`, else to /dev/null. A `program` without '/' is
/// searched on PATH; one with '/' is taken relative to the caller's directory.
/// \throws IoError naming the program and the cause when it cannot be started: not found or not
///         executable, `dir` cannot be entered, `log` cannot be opened, fork fails. What the
///         program itself does (its exit status) is the caller's to judge.
ECMOR_INTEROP_API ProgramExit run_program(const std::string& program,
                                          const std::vector<std::string>& args,
                                          const std::filesystem::path& dir,
                                          const std::filesystem::path& log, bool stdout_to_log);

}  // namespace ecmor
