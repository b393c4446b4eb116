// run_program (subprocess.hpp): exit status, where the output goes, and the failures to start
// that it must tell apart from a program's own exit status.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/interop/subprocess.hpp"

namespace ecmor {
namespace {

using test::message_of;
using test::TempDir;

std::string text_of(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(RunProgram, ReportsExitStatusAndRoutesOutput) {
  TempDir dir;
  const std::string script = "pwd; echo err >&2; exit 127";  // 127 is the program's own
  const ProgramExit both = run_program("sh", {"-c", script}, dir.path(), dir / "both.log", true);
  EXPECT_FALSE(both.ok());
  EXPECT_FALSE(both.signalled);
  EXPECT_EQ(both.code, 127);
  EXPECT_EQ(both.describe(), "exit status 127");
  EXPECT_EQ(text_of(dir / "both.log"), dir.path().string() + "\nerr\n") << "runs in dir";
  const ProgramExit err_only = run_program("sh", {"-c", script}, dir.path(), dir / "e.log", false);
  EXPECT_EQ(err_only.code, 127);
  EXPECT_EQ(text_of(dir / "e.log"), "err\n");
  EXPECT_TRUE(run_program("true", {}, dir.path(), dir / "t.log", true).ok());
  const ProgramExit killed =
      run_program("sh", {"-c", "kill -9 $$"}, dir.path(), dir / "k.log", true);
  EXPECT_TRUE(killed.signalled);
  EXPECT_EQ(killed.describe(), "signal 9");
}

TEST(RunProgram, FailuresToStartAreIoErrorsNamingTheCause) {
  TempDir dir;
  EXPECT_NE(message_of<IoError>([&] {
              run_program("ecmor-no-such-program", {}, dir.path(), dir / "l.log", true);
            }).find("cannot run 'ecmor-no-such-program': No such file or directory"),
            std::string::npos);
  EXPECT_NE(message_of<IoError>([&] {
              run_program("true", {}, dir / "missing", dir / "l.log", true);
            }).find("cannot enter " + (dir / "missing").string()),
            std::string::npos);
  EXPECT_NE(message_of<IoError>([&] {
              run_program("true", {}, dir.path(), dir / "missing" / "l.log", true);
            }).find("cannot open its log"),
            std::string::npos);
}

}  // namespace
}  // namespace ecmor
