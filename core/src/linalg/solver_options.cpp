// solver_options.cpp: the shifted solver's options, stated once: the YAML reader
// (run/src/config.cpp, sections `solver` and `backend`) and SolverOptions::validate() apply these
// specs.
#include "ecmor/base/options.hpp"
#include "ecmor/linalg/shifted_solver.hpp"

namespace ecmor {

const OptionSpecs<SolverOptions>& SolverOptions::specs() {
  using S = SolverOptions;
  static const OptionSpecs<S> specs({
      option("use_cholesky", &S::use_cholesky,
             "try CHOLMOD for real symmetric combinations (else UMFPACK LU)"),
      option("symmetry_tol", &S::symmetry_tol,
             "relative asymmetry below which a coefficient matrix counts as symmetric")
          .range(Range::closed_open(0, 1)),
      option("singular_rcond", &S::singular_rcond,
             "a factorisation whose reciprocal condition estimate is below this is reported "
             "singular")
          .range(Range::closed_open(0, 1)),
      option("refinement_steps", &S::refinement_steps,
             "UMFPACK iterative refinement steps per solve (each a residual and a solve; raise it "
             "for badly scaled or nearly singular shifts when accuracy matters more than speed)")
          .range(Range::closed(0, 10)),
      choice("ordering", &S::ordering, {{"auto", "auto"}, {"amd", "amd"}, {"metis", "metis"}},
             "fill-reducing ordering: `auto` takes AMD, or METIS nested dissection where AMD's "
             "predicted fill is large (3-D solids); the choice is made once per model from the "
             "symbolic analyses"),
      choice("complex_symmetric", &S::complex_symmetric,
             {{"auto", "auto"}, {"ldlt", "ldlt"}, {"lu", "lu"}},
             "complex shifts of symmetric M, D, K (or E, A): `ldlt` = MUMPS's LDL^T (about half "
             "the memory and flops of an LU; one factorisation at a time, using the cores "
             "inside it, so the loops over frequencies run serially), `lu` = UMFPACK (several "
             "at once, one per thread), `auto` = `lu` while the LUs of all threads fit in "
             "`ldlt_memory_fraction` of the physical memory (predicted from the symbolic "
             "analysis), `ldlt` above ([benchmarks.md](benchmarks.md#sparse-factorisation-of-"
             "3-d-solids-issue-27))"),
      option("ldlt_memory_fraction", &S::ldlt_memory_fraction, "see `complex_symmetric`")
          .range(Range::closed(0, 1)),
      option(
          "memory_limit_gib", &S::memory_limit_gib,
          "the most memory the process may take, in GiB; 0: no limit of its own (the "
          "available memory, `ulimit -v` and a cgroup's memory.max always hold). Before the "
          "first numeric factorisation the run predicts its factors' memory from the symbolic "
          "analysis, fits them under the limit (no factorisation kept for reuse, LDL^T instead of "
          "LU, one at a time) or refuses with the options that would fit")
          .range(Range::at_least(0)),
      option("out_of_core", &S::out_of_core,
             "MUMPS's LDL^T keeps the factors on disk, in `$TMPDIR` (else /tmp), and reads them "
             "back for every solve: memory for the largest frontal matrices only. Implies "
             "`complex_symmetric: ldlt`; needs symmetric M, D, K (or E, A)"),
  });
  return specs;
}

const OptionSpecs<SolverOptions>& SolverOptions::backend_specs() {
  using S = SolverOptions;
  static const OptionSpecs<S> specs({
      choice("name", &S::backend, {{"suitesparse", "suitesparse"}, {"petsc", "petsc"}},
             "`suitesparse`: the embedded CHOLMOD/UMFPACK solver, one process. `petsc`: PETSc "
             "with MUMPS, the factorisations distributed over the MPI ranks of `mpirun -n P "
             "ecmor reduce config.yaml` (builds with the PETSc backend only; see "
             "[cluster.md](cluster.md))"),
  });
  return specs;
}

void SolverOptions::validate() const {
  specs().validate(*this, "SolverOptions");
  backend_specs().validate(*this, "SolverOptions (backend)");
}

}  // namespace ecmor
