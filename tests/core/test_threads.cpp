// The thread budget (threads.hpp): its pieces against hand-made /proc and cgroup texts, explicit
// limits, and the adaptive count beside real busy processes.
#include <gtest/gtest.h>
#include <omp.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <thread>
#include <vector>

#include "base/loop_threads.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/threads.hpp"

namespace ecmor {
namespace {

TEST(Threads, QuotaCoresRoundUpAndNoQuotaIsZero) {
  EXPECT_EQ(detail::quota_cores("max 100000\n"), 0);
  EXPECT_EQ(detail::quota_cores("200000 100000\n"), 2);
  EXPECT_EQ(detail::quota_cores("150000 100000"), 2);
  EXPECT_EQ(detail::quota_cores("50000 100000"), 1);
  EXPECT_EQ(detail::quota_cores("-1 100000"), 0);  // cgroup v1: no quota
  EXPECT_EQ(detail::quota_cores(""), 0);
  EXPECT_EQ(detail::quota_cores("garbage"), 0);
  EXPECT_EQ(detail::quota_cores("100000 0"), 0);
}

TEST(Threads, RunnableTasksFromLoadavg) {
  EXPECT_EQ(detail::runnable_tasks("0.64 1.61 1.86 3/79 8540\n"), 3);
  EXPECT_EQ(detail::runnable_tasks("0.00 0.00 0.00 1/120 1"), 1);
  EXPECT_EQ(detail::runnable_tasks("0.64 1.61"), -1);
  EXPECT_EQ(detail::runnable_tasks("0.64 1.61 1.86 x/79 8540"), -1);
  EXPECT_EQ(detail::runnable_tasks("0.64 1.61 1.86 /79 8540"), -1);
  EXPECT_EQ(detail::runnable_tasks("0.64 1.61 1.86 379 8540"), -1);
}

TEST(Threads, TheCountIsTheCoresOthersLeaveWithinOneAndTheLimit) {
  EXPECT_EQ(detail::threads_for_load(2, 2, 0), 2);
  EXPECT_EQ(detail::threads_for_load(2, 2, 1), 1);
  EXPECT_EQ(detail::threads_for_load(2, 2, 2), 1);
  EXPECT_EQ(detail::threads_for_load(2, 2, 7), 1);
  EXPECT_EQ(detail::threads_for_load(8, 8, 3), 5);
  EXPECT_EQ(detail::threads_for_load(8, 4, 0), 4);
  EXPECT_EQ(detail::threads_for_load(1, 1, 0), 1);
  EXPECT_EQ(detail::threads_for_load(4, 4, -1), 4);
}

TEST(Threads, SettingsAreWholeNumbersOrAutoAndBadOnesAreNamed) {
  EXPECT_EQ(detail::parse_thread_setting("ECMOR_THREADS", "4"), 4);
  EXPECT_EQ(detail::parse_thread_setting("ECMOR_THREADS", "auto"), 0);
  EXPECT_EQ(detail::parse_thread_setting("ECMOR_THREADS", ""), 0);
  for (const char* bad : {"0", "-3", "two", "3x", " 3", "99999999999999999999", "1.5"}) {
    try {
      detail::parse_thread_setting("ECMOR_THREADS", bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("ECMOR_THREADS=\"") + bad + "\""),
                std::string::npos)
          << e.what();
    }
  }
}

// Runs with the environment as the test sets it, restored after.
class ThreadEnvironment : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const char* name : {"ECMOR_THREADS", "OMP_NUM_THREADS"}) {
      const char* value = std::getenv(name);
      m_saved.push_back({name, value ? value : "", value != nullptr});
      unsetenv(name);
    }
    detail::reinitialise_thread_budget();
  }
  void TearDown() override {
    for (const Saved& s : m_saved) {
      if (s.set)
        setenv(s.name, s.value.c_str(), 1);
      else
        unsetenv(s.name);
    }
    detail::reinitialise_thread_budget();
  }

 private:
  struct Saved {
    const char* name;
    std::string value;
    bool set;
  };
  std::vector<Saved> m_saved;
};

TEST_F(ThreadEnvironment, WithoutSettingsTheBudgetIsTheCoresAndAdaptive) {
  const ThreadBudget b = thread_budget();
  EXPECT_EQ(b.source, "cores");
  EXPECT_TRUE(b.adaptive);
  EXPECT_EQ(b.limit, b.cores);
  EXPECT_GE(b.cores, 1);
  EXPECT_LE(b.cores, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));
  const int n = parallel_threads();
  EXPECT_GE(n, 1);
  EXPECT_LE(n, b.limit);
  EXPECT_EQ(omp_get_max_threads(), n);  // what OpenBLAS's OpenMP build follows
}

TEST_F(ThreadEnvironment, EnvironmentAndScopesFixTheCount) {
  setenv("OMP_NUM_THREADS", "3", 1);
  detail::reinitialise_thread_budget();
  EXPECT_EQ(thread_budget().source, "OMP_NUM_THREADS");
  setenv("ECMOR_THREADS", "5", 1);  // takes precedence
  detail::reinitialise_thread_budget();
  ThreadBudget b = thread_budget();
  EXPECT_EQ(b.source, "ECMOR_THREADS");
  EXPECT_FALSE(b.adaptive);
  EXPECT_EQ(b.limit, 5);
  EXPECT_EQ(parallel_threads(), 5);
  {
    const ThreadLimitScope run(2, "solver.threads");  // a run's own setting takes precedence
    reset_thread_use();
    b = thread_budget();
    EXPECT_EQ(b.source, "solver.threads");
    EXPECT_EQ(b.limit, 2);
    EXPECT_EQ(parallel_threads(), 2);
    EXPECT_EQ(omp_get_max_threads(), 2);
    const ThreadLimitScope nothing(0, "unused");  // 0 changes nothing
    EXPECT_EQ(thread_budget().source, "solver.threads");
    b = thread_budget();
    EXPECT_EQ(b.fewest_used, 2);
    EXPECT_EQ(b.most_used, 2);
  }
  b = thread_budget();
  EXPECT_EQ(b.source, "ECMOR_THREADS");
  EXPECT_EQ(b.limit, 5);
  setenv("ECMOR_THREADS", "many", 1);
  detail::reinitialise_thread_budget();
  EXPECT_THROW(thread_budget(), ConfigError);
}

TEST_F(ThreadEnvironment, InsideAParallelRegionTheCountIsOne) {
  std::vector<int> seen(2, 0);
#pragma omp parallel num_threads(2)
  seen[static_cast<std::size_t>(omp_get_thread_num())] = parallel_threads();
  for (int n : seen) EXPECT_TRUE(n == 0 || n == 1) << n;  // 0: the team had one thread
  EXPECT_EQ(seen[0], 1);
}

// Two busy processes leave at most cores - 2 cores free: the count falls to that (at least one)
// within two samples (a single busy sample is not trusted). Other load (ctest -j) can only lower
// the count further.
TEST_F(ThreadEnvironment, BusyProcessesBesideItLowerTheCount) {
  const int cores = thread_budget().cores;
  std::vector<pid_t> busy;
  for (int i = 0; i < 2; ++i) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      volatile unsigned long k = 0;
      while (true) k = k + 1;
    }
    busy.push_back(pid);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  int n = parallel_threads();
  for (int sample = 0; sample < 3; ++sample) {
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    n = parallel_threads();
  }
  for (pid_t pid : busy) kill(pid, SIGKILL);
  for (pid_t pid : busy) waitpid(pid, nullptr, 0);
  EXPECT_LE(n, std::max(1, cores - 2));
  EXPECT_GE(n, 1);
  const ThreadBudget b = thread_budget();
  if (cores > 1) {
    EXPECT_GT(b.load_reductions, 0);
  }
}

// Under load a loop measures both counts and keeps the faster, trying the other every 8th time;
// without load (low = high) it runs with the limit and learns nothing.
TEST(LoopThreads, UnderLoadTheFasterCountWinsAndTheOtherIsRetried) {
  detail::LoopThreads loop;
  EXPECT_EQ(loop.choose(2, 2), 2);
  loop.record(2, 100, 1.0);  // not under load: ignored
  std::vector<int> picks;
  auto step = [&](double seconds_low, double seconds_high) {
    const int n = loop.choose(1, 2);
    picks.push_back(n);
    loop.record(n, 10, n == 1 ? seconds_low : seconds_high);
    return n;
  };
  // Two runs of each first, then the faster: here two threads (a coarse loop).
  for (int i = 0; i < 4; ++i) step(1.0, 0.6);
  EXPECT_EQ(picks, (std::vector<int>{1, 1, 2, 2}));
  int low = 0, high = 0;
  for (int i = 0; i < 32; ++i) (step(1.0, 0.6) == 1 ? low : high)++;
  EXPECT_EQ(low, 4);  // every 8th choice tries the slower count
  EXPECT_EQ(high, 28);
  // The loop's grain changes (two threads now wait at the join): the smoothed times follow, and
  // one thread takes over.
  for (int i = 0; i < 64; ++i) step(1.0, 3.0);
  picks.clear();
  for (int i = 0; i < 8; ++i) step(1.0, 3.0);
  EXPECT_EQ(std::count(picks.begin(), picks.end(), 1), 7);
}

// A loop whose runs take less than a trial of the limit costs (a time slice at the join) keeps
// the load's count and is never tried with more; once its runs grow past that, it is.
TEST(LoopThreads, AShortLoopIsNotTriedWithMoreThreads) {
  detail::LoopThreads loop;
  const double short_run = detail::LoopThreads::kTrialSeconds / 4;
  for (int i = 0; i < 40; ++i) {
    ASSERT_EQ(loop.choose(1, 2), 1) << "run " << i;
    loop.record(1, 10, short_run);
  }
  // The same loop over many more items: its smoothed run time passes the bar, the limit is tried.
  std::vector<int> picks;
  for (int i = 0; i < 12; ++i) {
    const int n = loop.choose(1, 2);
    picks.push_back(n);
    loop.record(n, 1000, n == 1 ? 100 * short_run : 60 * short_run);
  }
  EXPECT_GE(std::count(picks.begin(), picks.end(), 2), 2);
  EXPECT_EQ(picks.back(), 2);  // two threads were faster here
}

TEST(Threads, TheBlasSaysWhatItIs) {
  const BlasInfo blas = blas_info();
  ASSERT_FALSE(blas.name.empty());
  if (blas.name.rfind("OpenBLAS", 0) == 0) {
    EXPECT_TRUE(blas.threading == "OpenMP" || blas.threading == "pthreads" ||
                blas.threading == "sequential")
        << blas.threading;
  } else {
    EXPECT_EQ(blas.name, "not OpenBLAS");
  }
}

}  // namespace
}  // namespace ecmor
