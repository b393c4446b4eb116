#include "ecmor/linalg/parallel.hpp"

#include <dlfcn.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>

#include "ecmor/base/error.hpp"
#include "linalg/petsc_solver.hpp"

namespace ecmor {
namespace detail {

// Set by make_petsc_solver once the module has started MPI: from then on rank, size and
// any_process() come from MPI.
std::atomic<const PetscBackendApi*> g_mpi{nullptr};

namespace {

int from_environment(const char* const* names, int fallback) {
  for (const char* const* n = names; *n != nullptr; ++n) {
    if (const char* v = std::getenv(*n)) {
      try {
        return std::stoi(v);
      } catch (...) {
      }
    }
  }
  return fallback;
}

// libecmor_petsc.so next to this library (the build tree and the install tree alike).
std::filesystem::path module_path() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&process_rank), &info) != 0 && info.dli_fname != nullptr)
    return std::filesystem::path(info.dli_fname).parent_path() / "libecmor_petsc.so";
  return "libecmor_petsc.so";
}

const PetscBackendApi* load_module() {
  static std::once_flag once;
  static const PetscBackendApi* api = nullptr;
  static std::string problem;
  std::call_once(once, [] {
    const std::filesystem::path path = module_path();
    // RTLD_DEEPBIND: PETSc, MUMPS and MPI bind to each other before anything already loaded (the
    // sequential MUMPS of Ipopt and its stub MPI); see petsc_solver.hpp.
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_DEEPBIND);
    if (handle == nullptr) {
      const char* e = dlerror();
      problem = std::string("cannot load the PETSc backend module ") + path.string() + ": " +
                (e ? e : "unknown error");
      return;
    }
    using Entry = const PetscBackendApi* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(handle, "ecmor_petsc_backend"));
    if (entry == nullptr) {
      problem = path.string() + " has no entry point ecmor_petsc_backend";
      return;
    }
    const PetscBackendApi* a = entry();
    if (a == nullptr || a->version != kPetscBackendApiVersion) {
      problem = path.string() + " is from another ecmor version (backend API version mismatch)";
      return;
    }
    api = a;
  });
  if (api == nullptr) {
    throw ConfigError(
        "backend 'petsc': " + problem +
        ". This ecmor was built without the PETSc backend (PETSc with complex scalars and MUMPS "
        "was not found at build time, or ECMOR_WITH_PETSC=OFF): install libpetsc-complex-dev "
        "(scripts/setup.sh does) and rebuild, or use backend 'suitesparse'");
  }
  return api;
}

}  // namespace

std::unique_ptr<ShiftedSolver> make_petsc_solver(const Model& model) {
  const PetscBackendApi* api = load_module();
  std::unique_ptr<ShiftedSolver> solver = api->make_solver(model);
  g_mpi.store(api);
  return solver;
}

bool petsc_has_eigensolver(const Factorization& factorization) {
  const auto* api = g_mpi.load();
  return api != nullptr && api->symmetric_eigs != nullptr && factorization.method() == "mumps";
}

SymmetricEigenResult petsc_symmetric_eigs(const Factorization& factorization, const SparseMatrix& M,
                                          double sigma, const EigenOptions& options) {
  return g_mpi.load()->symmetric_eigs(factorization, M, sigma, options);
}

}  // namespace detail

int process_rank() {
  if (const auto* mpi = detail::g_mpi.load()) return mpi->rank();
  static const char* const names[] = {"OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK", nullptr};
  return detail::from_environment(names, 0);
}

int process_count() {
  if (const auto* mpi = detail::g_mpi.load()) return mpi->size();
  static const char* const names[] = {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", nullptr};
  return detail::from_environment(names, 1);
}

bool any_process(bool local) {
  if (const auto* mpi = detail::g_mpi.load()) return mpi->any(local);
  return local;
}

bool petsc_backend_available() {
#ifdef ECMOR_HAVE_PETSC
  return std::filesystem::exists(detail::module_path());
#else
  return false;
#endif
}

void abort_all_processes(int code) {
  if (const auto* mpi = detail::g_mpi.load(); mpi != nullptr && mpi->size() > 1) mpi->abort(code);
  std::exit(code);
}

}  // namespace ecmor
