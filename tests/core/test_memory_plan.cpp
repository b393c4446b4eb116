// The memory plan of the shifted solver (memory_plan.hpp): predicted from the symbolic analysis
// before any numeric factorisation, fitted under a limit or refused; the headroom probe under an
// address-space limit (`ulimit -v`).
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "../../bench/solid.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/threads.hpp"
#include "ecmor/linalg/shifted_solver.hpp"

namespace ecmor {
namespace {

constexpr double kGiB = 1073741824.0;

/// A clamped solid of 2 520 DOF (30 x 3 x 3 elements): a 3-D pattern, factors of a few MiB.
const SecondOrderModel& small_solid() {
  static const SecondOrderModel model = [] {
    bench::SolidOptions o;
    o.nx = 30;
    o.ny = 3;
    o.nz = 3;
    return bench::solid(o);
  }();
  return model;
}

/// A clamped block of 12 x 12 x 12 elements (6 084 DOF): factors of 50-150 MiB, large against what
/// the process allocates around them (a solver's pattern: about 16 MiB), so that a limit placed
/// between one factor and two is not crossed by that.
const SecondOrderModel& block_solid() {
  static const SecondOrderModel model = [] {
    bench::SolidOptions o;
    o.nx = o.ny = o.nz = 12;
    o.ly = o.lz = 1.0;
    return bench::solid(o);
  }();
  return model;
}

/// The complex shift the tests factorise at (inside the solid's band, off its poles).
constexpr Complex kShift(0.0, 2.0 * 3.141592653589793 * 500.0);

double relative_residual(const SecondOrderModel& m, const ComplexMatrix& X) {
  const ComplexSparseMatrix P =
      (kShift * kShift) * m.M.cast<Complex>() + kShift * m.D.cast<Complex>() + m.K.cast<Complex>();
  const ComplexMatrix B = m.B.cast<Complex>();
  return (P * X - B).norm() / B.norm();
}

TEST(MemoryPlan, WithAmpleMemoryTheFirstChoiceStandsAndNothingIsFactorised) {
  const SecondOrderModel& m = small_solid();
  auto solver = make_shifted_solver(m);
  EXPECT_EQ(solver->reuse_limit(), ShiftedSolver::kUnlimitedReuse);  // before a plan
  const MemoryPlan plan = solver->plan_memory(1);
  ASSERT_TRUE(plan.predicted);
  EXPECT_TRUE(plan.fits()) << plan.describe();
  EXPECT_EQ(plan.method, "umfpack");  // small: the LUs of all threads fit easily
  EXPECT_EQ(plan.concurrent, std::max(1, thread_budget().limit));
  EXPECT_EQ(plan.kept, 1);
  EXPECT_TRUE(plan.adjustments.empty()) << plan.adjustments;
  EXPECT_EQ(plan.reuse_limit, 64);  // a small factor: the cap, not the headroom, bounds it
  EXPECT_EQ(solver->reuse_limit(), 64);
  // nnz(L) of a 3-D pattern: more than the matrix's lower triangle, less than a dense factor.
  const double n = static_cast<double>(m.K.rows());
  EXPECT_GT(plan.factor_entries, 0.5 * static_cast<double>(m.K.nonZeros()));
  EXPECT_LT(plan.factor_entries, 0.5 * n * (n + 1.0));
  EXPECT_GT(plan.factor_bytes, 0.0);
  EXPECT_GT(plan.headroom.resident_bytes, 0.0);
  EXPECT_DOUBLE_EQ(plan.peak_bytes(), plan.headroom.resident_bytes + plan.added_bytes());
  EXPECT_NE(plan.describe().find("predicted peak"), std::string::npos) << plan.describe();
  EXPECT_EQ(solver->counters().factorizations, 0);
}

TEST(MemoryPlan, ALimitBelowOneFactorRefusesBeforeAnyFactorisation) {
  const SecondOrderModel& m = small_solid();
  SolverOptions o;
  o.memory_limit_gib = 1e-6;  // 1 KiB: below the process as it stands
  auto solver = make_shifted_solver(m, o);
  const MemoryPlan plan = solver->plan_memory(1);
  EXPECT_FALSE(plan.fits());
  EXPECT_EQ(plan.headroom.limit, "solver.memory_limit_gib");
  EXPECT_EQ(plan.headroom.bytes, 0.0);
  EXPECT_EQ(plan.factors_alive(), 1);  // the last, most frugal choice is the one reported
  const std::string why = plan.refusal();
  for (const char* part : {"solver.memory_limit_gib", "nnz(L)", "Options:", "solver.out_of_core",
                           "backend: {name: petsc}"})
    EXPECT_NE(why.find(part), std::string::npos) << part << " in: " << why;
  EXPECT_EQ(solver->counters().factorizations, 0);
}

TEST(MemoryPlan, ALimitForOneFactorGivesOneFactorisationAtATimeAndStillExactSolves) {
  const SecondOrderModel& m = block_solid();
  // The sizes the plan chooses between, from plans without a limit of their own.
  SolverOptions lu_options, ldlt_options;
  ldlt_options.complex_symmetric = "ldlt";
  const double lu = make_shifted_solver(m, lu_options)->plan_memory(1).factor_bytes;
  const double ldlt = make_shifted_solver(m, ldlt_options)->plan_memory(1).factor_bytes;
  ASSERT_GT(lu, 0.0);
  ASSERT_GT(ldlt, 0.0);
  // Room for 1.5 of the smaller factor beside the process as it stands: one fits, two do not.
  const double smaller = std::min(lu, ldlt);
  SolverOptions o;
  o.memory_limit_gib = (memory_headroom().resident_bytes + 1.5 * smaller) / kGiB;
  auto solver = make_shifted_solver(m, o);
  const MemoryPlan plan = solver->plan_memory(1);
  ASSERT_TRUE(plan.fits()) << plan.describe();
  EXPECT_EQ(plan.factors_alive(), 1);
  EXPECT_EQ(plan.kept, 0);
  EXPECT_FALSE(plan.adjustments.empty());
  EXPECT_FALSE(solver->concurrent());  // the solver follows the plan
  EXPECT_EQ(plan.reuse_limit, 0);      // half of what is left is less than a factor
  EXPECT_EQ(solver->reuse_limit(), 0);
  EXPECT_EQ(plan.method, ldlt < lu ? "mumps-ldlt" : "umfpack");
  // What the plan chose factorises and solves as the default does.
  const auto f = solver->factorize(kShift);
  EXPECT_EQ(f->method(), plan.method);
  EXPECT_LT(relative_residual(m, f->solve(ComplexMatrix(m.B.cast<Complex>()))), 1e-10);
}

TEST(MemoryPlan, OutOfCoreFactorsSolveAsInCoreOnesAndPlanLessMemory) {
  const SecondOrderModel& m = small_solid();
  SolverOptions in_core, out_of_core;
  in_core.complex_symmetric = "ldlt";
  out_of_core.out_of_core = true;
  auto a = make_shifted_solver(m, in_core);
  auto b = make_shifted_solver(m, out_of_core);
  const MemoryPlan pa = a->plan_memory(1), pb = b->plan_memory(1);
  EXPECT_EQ(pa.method, "mumps-ldlt");
  EXPECT_EQ(pb.method, "mumps-ldlt out-of-core");
  EXPECT_LT(pb.factor_bytes, pa.factor_bytes);  // MUMPS's own estimates, INFOG(27) < INFOG(17)
  // The factors go to $TMPDIR while the factorisation lives, and are gone after it.
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("ecmor_ooc_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const char* old_tmpdir = std::getenv("TMPDIR");
  const std::string restore = old_tmpdir != nullptr ? old_tmpdir : "";
  ::setenv("TMPDIR", dir.c_str(), 1);
  const ComplexMatrix B = m.B.cast<Complex>();
  const ComplexMatrix Xa = a->factorize(kShift)->solve(B);
  ComplexMatrix Xb;
  {
    const auto f = b->factorize(kShift);
    EXPECT_FALSE(std::filesystem::is_empty(dir)) << "no factor files in " << dir;
    Xb = f->solve(B);
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir)) << "factor files left in " << dir;
  if (old_tmpdir != nullptr)
    ::setenv("TMPDIR", restore.c_str(), 1);
  else
    ::unsetenv("TMPDIR");
  std::filesystem::remove_all(dir);
  EXPECT_LT(relative_residual(m, Xb), 1e-10);
  EXPECT_LT((Xa - Xb).norm() / Xa.norm(), 1e-12);
}

TEST(MemoryPlan, OutOfCoreOnUnsymmetricCoefficientsIsAConfigErrorNamingTheMatrix) {
  SecondOrderModel m = small_solid();
  m.K.coeffRef(1, 0) += 1e3;  // K(1, 0) != K(0, 1) beyond symmetry_tol
  SolverOptions o;
  o.out_of_core = true;
  try {
    make_shifted_solver(m, o);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    const std::string why = e.what();
    EXPECT_NE(why.find("solver.out_of_core"), std::string::npos) << why;
    EXPECT_NE(why.find("K is not symmetric"), std::string::npos) << why;
  }
  o.out_of_core = false;
  EXPECT_NO_THROW(make_shifted_solver(m, o));
}

/// VmSize of this process, in bytes.
double virtual_size() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmSize:", 0) == 0) return std::stod(line.substr(7)) * 1024.0;
  return 0.0;
}

TEST(MemoryHeadroom, AnAddressSpaceLimitIsTheHeadroomAndNamedUlimit) {
  // In a child process: its own limit, 64 MiB above its present virtual size.
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const double room = 64.0 * 1048576.0;
    struct rlimit limit {};
    limit.rlim_cur = limit.rlim_max = static_cast<rlim_t>(virtual_size() + room);
    if (setrlimit(RLIMIT_AS, &limit) != 0) _exit(2);
    const MemoryHeadroom h = memory_headroom();
    const bool named = h.limit == "ulimit -v";
    const bool sized = h.bytes > 0.5 * room && h.bytes < 1.1 * room;
    _exit(named && sized ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "1: the limit was not the headroom named 'ulimit -v'";
}

TEST(MemoryHeadroom, TheUsersLimitCountsAgainstTheResidentSize) {
  const MemoryHeadroom free = memory_headroom();
  EXPECT_FALSE(free.limit.empty());
  EXPECT_GT(free.bytes, 0.0);
  // 32 MiB above the process now: tighter than any machine that runs the tests has free.
  const double room = 32.0 * 1048576.0;
  const MemoryHeadroom h = memory_headroom((free.resident_bytes + room) / kGiB);
  EXPECT_EQ(h.limit, "solver.memory_limit_gib");
  EXPECT_NEAR(h.bytes, room, 8.0 * 1048576.0);
}

}  // namespace
}  // namespace ecmor
