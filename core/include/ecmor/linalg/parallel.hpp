#pragma once
/// \file parallel.hpp
/// ecmor under MPI (`mpirun -n P ecmor reduce config.yaml`, backend petsc). Every rank runs the
/// same driver on the same configuration; the PETSc backend distributes the factorisations and
/// solves over the ranks. Rank 0 writes the outputs and prints; the other ranks only compute.

#include "ecmor/export.hpp"

namespace ecmor {

/// This process's rank and the number of ranks of its MPI job: from MPI once the PETSc backend
/// has started it, before that from the launcher's environment (OMPI_COMM_WORLD_RANK, PMI_RANK,
/// PMIX_RANK and their _SIZE counterparts); 0 and 1 outside MPI.
ECMOR_API int process_rank();
ECMOR_API int process_count();

/// True on every rank when `local` is true on any rank (a collective OR once MPI runs; `local`
/// itself before). Decisions that could differ between ranks (a time limit, a signal) go through
/// it, so that every rank takes the same path through the collective solves.
ECMOR_API bool any_process(bool local);

/// Whether this build has the PETSc backend (ECMOR_WITH_PETSC at build time).
ECMOR_API bool petsc_backend_available();

/// Ends every rank of the job with `code` (MPI_Abort once MPI runs; std::exit otherwise): for an
/// error on one rank that the others cannot know about.
[[noreturn]] ECMOR_API void abort_all_processes(int code);

}  // namespace ecmor
