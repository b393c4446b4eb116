#pragma once
/// \file memory_plan.hpp
/// What a run's factorisations will take, predicted before the first numeric factorisation, and
/// what the process may still take. A sparse direct factorisation of a 3-D solid is by far the
/// largest allocation of a run (docs/benchmarks.md: 1.9 GiB for one complex LU at N = 102 600,
/// against 0.6 GiB for the model), and the operating system answers too much of it by killing the
/// process, with nothing written. So the shifted solver predicts the factors' size from its
/// symbolic analysis (ShiftedSolver::plan_memory), chooses how many may be alive at once, and the
/// run refuses, with the options that would fit, before it starts one it cannot finish.

#include <string>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"

namespace ecmor {

/// The memory the process may still allocate: the tightest of the available physical memory
/// (/proc/meminfo MemAvailable), the address-space limit (`ulimit -v`, RLIMIT_AS, against the
/// process's present virtual size), the cgroup's memory.max (containers, systemd slices) and a
/// limit the user gave (solver.memory_limit_gib, on the process's resident size).
struct ECMOR_API MemoryHeadroom {
  double bytes = 0.0;           ///< what may still be allocated
  double resident_bytes = 0.0;  ///< the process's resident size now (VmRSS)
  /// The limit that set `bytes`: "available memory", "ulimit -v", "cgroup memory.max" or
  /// "solver.memory_limit_gib".
  std::string limit;
};

/// The headroom now. `limit_gib` > 0 adds the user's limit on the resident size (GiB, 2^30).
ECMOR_API MemoryHeadroom memory_headroom(double limit_gib = 0.0);

/// A shifted solver's plan for the memory of its factorisations, made from the symbolic analysis
/// before any numeric factorisation (ShiftedSolver::plan_memory).
struct ECMOR_API MemoryPlan {
  /// False when the backend cannot predict its memory (the PETSc backend); then nothing below
  /// but `method` is set and the run goes on without a prediction.
  bool predicted = false;
  /// The method of the largest factorisations the run makes (complex shifts): "umfpack",
  /// "mumps-ldlt", "mumps-ldlt out-of-core" or "cholmod".
  std::string method;
  double factor_bytes = 0.0;    ///< one such factorisation, in memory
  double factor_entries = 0.0;  ///< nnz(L) of the analysis the prediction rests on
  /// Symmetric coefficients: MUMPS's LDL^T, in or out of core, is possible.
  bool symmetric = false;
  Index concurrent = 1;  ///< factorisations made at once (ecmor's loops over frequencies)
  Index kept = 0;        ///< factorisations kept for reuse beyond their callers' need
  /// Factorisations callers may keep beyond these (a reducer's cache of its expansion points,
  /// ShiftedSolver::reuse_limit): half of the headroom left after added_bytes(), in factors.
  Index reuse_limit = 0;
  MemoryHeadroom headroom;  ///< what the process may still take, when planned
  /// The choices the plan made to fit, in words ("LDL^T instead of LU", "one factorisation at a
  /// time", "no factorisation kept for reuse"); empty when the first choice fit.
  std::string adjustments;

  /// Factorisations alive at once: the concurrent ones and the kept one(s).
  Index factors_alive() const { return concurrent + kept; }
  /// What the factorisations add to the process: factors_alive() * factor_bytes.
  double added_bytes() const;
  /// The predicted peak of the process: its resident size now plus added_bytes().
  double peak_bytes() const;
  /// True when added_bytes() fits the headroom (or nothing was predicted).
  bool fits() const;
  /// One line for the console: "predicted peak 6.7 GiB (3 x 2.1 GiB umfpack factors), reducers
  /// may keep 3 more (+6.3 GiB); 22.6 GiB more may be taken (available memory)".
  std::string describe() const;
  /// Why the run cannot go on and what would fit (when !fits()), naming the YAML options.
  std::string refusal() const;
};

/// Bytes as "1.9 GiB", "750 MiB" or "96 KiB".
ECMOR_API std::string format_bytes(double bytes);

}  // namespace ecmor
