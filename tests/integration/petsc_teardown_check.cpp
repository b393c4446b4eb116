// petsc_teardown_check: run on two MPI ranks by
// PetscBackend.FactorizationsOutliveTheirSolverOnTwoRanks (test_petsc_backend.cpp), which bounds it
// with a timeout.
//
// The pattern that deadlocked ecmor reduce on two ranks, without the reducer and the driver: the
// PETSc solver makes several MUMPS factorisations, some released at once (their analysed objects
// are parked in the solver's pool), some kept, as the modal reducer's spectrum slicer keeps them;
// then the solver is destroyed first (run_reduction destroys it before the reducers), and only
// then are the kept factorisations used and released. shifted_solver.hpp promises that a
// factorisation stays valid after its solver is destroyed; every release is a collective MUMPS
// teardown, so both ranks must destroy the same instances in the same order.
//
// The memory the solver freed is then reused with contents that differ by rank (glibc hands a
// freed small block back to the next request of its size class): a factorisation that still read
// its destroyed solver would read these bytes instead of stale values that happen to agree across
// ranks, so the fault shows at once (a crash, a wrong solve, or a hang that the caller's timeout
// turns into a failure) instead of now and then.
//
// Prints one line per rank and exits 0 when every solve after the solver's destruction had a
// small residual and every rank got through the releases; 1 otherwise.
#include <cmath>
#include <complex>
#include <cstdio>
#include <exception>
#include <iterator>
#include <memory>
#include <vector>

#include "common/dense_reference.hpp"
#include "ecmor/linalg/parallel.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model.hpp"

namespace {

using namespace ecmor;

// Takes back the blocks freed last, in every size class, filled with a byte that differs by rank
// (see the top of this file); they stay allocated until the process ends.
std::vector<std::vector<unsigned char>> reuse_freed_memory(int rank) {
  std::vector<std::vector<unsigned char>> blocks;
  const unsigned char fill = rank == 0 ? 0x00 : 0xff;
  // Every small size class (request 16 k + 8 bytes), more blocks than glibc caches per class.
  for (std::size_t size = 24; size <= 4104; size += 16)
    for (int k = 0; k < 8; ++k) blocks.emplace_back(size, fill);
  return blocks;
}

int run() {
  const Index n = 300;
  // K SPD (fixed at both ends), Rayleigh damping: every combination below is nonsingular.
  const SecondOrderModel model = test::spring_chain(n, 100.0, 0.001, 0.01);
  SolverOptions options;
  options.backend = "petsc";
  std::unique_ptr<ShiftedSolver> solver = make_shifted_solver(model, options);
  const int rank = process_rank();

  // Weights (w_K, w_D, w_M): shifted stiffnesses K - sigma M as the slicer makes them, and
  // P(i omega) as the band error does.
  using W = std::vector<Complex>;
  const W kept_weights[] = {{1.0, 0.0, 2.0},
                            {1.0, Complex(0.0, 3.0), -9.0},
                            {1.0, 0.0, 20.0},
                            {1.0, Complex(0.0, 0.5), -0.25}};
  const W dropped_weights[] = {{1.0, 0.0, 5.0}, {1.0, Complex(0.0, 7.0), -49.0}};
  std::vector<std::shared_ptr<const Factorization>> kept;
  kept.push_back(solver->factorize_combination(kept_weights[0]));
  solver->factorize_combination(dropped_weights[0]);  // released at once: parked in the pool
  kept.push_back(solver->factorize_combination(kept_weights[1]));  // takes the parked slot
  kept.push_back(solver->factorize_combination(kept_weights[2]));
  kept.push_back(solver->factorize_combination(kept_weights[3]));
  solver->factorize_combination(dropped_weights[1]);  // parked again, so the pool is full

  solver.reset();
  const auto blocks = reuse_freed_memory(rank);

  // Solves after the solver's destruction (collective too), checked against the model's matrices.
  ComplexMatrix rhs(n, 2);
  for (Index i = 0; i < n; ++i) rhs.row(i) << Complex(1.0, 0.0), Complex(std::sin(0.1 * i), 0.5);
  double worst = 0.0;
  for (std::size_t j = 0; j < kept.size(); ++j) {
    const W& w = kept_weights[j];
    const ComplexMatrix x = kept[j]->solve(rhs);
    const ComplexMatrix p_x = w[0] * (model.K.cast<Complex>() * x) +
                              w[1] * (model.D.cast<Complex>() * x) +
                              w[2] * (model.M.cast<Complex>() * x);
    worst = std::max(worst, (p_x - rhs).norm() / rhs.norm());
  }
  kept.clear();  // front to back, as ~ModalReducer releases its slicer's factorisations

  // Both ranks got through the releases (a collective call: it returns only when every rank has
  // made it).
  const bool bad_here = !(worst <= 1e-10);
  const bool bad = any_process(bad_here);
  std::printf(
      "petsc_teardown_check: rank %d of %d released %zu factorisations after their "
      "solver; worst relative residual %.3g%s\n",
      rank, process_count(), std::size(kept_weights), worst, bad ? " (FAILED on some rank)" : "");
  std::fflush(stdout);
  return bad ? 1 : 0;
}

}  // namespace

int main() {
  try {
    return run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "petsc_teardown_check: %s\n", e.what());
    abort_all_processes(1);
  }
}
