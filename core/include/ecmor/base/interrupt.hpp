#pragma once
/// \file interrupt.hpp
/// Cooperative interruption of long computations inside one call (an ARPACK run, an IRKA or ADI
/// iteration), so that a run's time limit and SIGINT/SIGTERM take effect within a fraction of a
/// second instead of after the current reducer call returns (which can take minutes: the modal
/// reducer's general eigenproblem on mna5).
///
/// The driver installs an InterruptScope around each strategy run with its stop condition; long
/// loops call check_interrupt() at safe points, which throws ecmor::Interrupted when the condition
/// holds. Only the thread that installed the scope evaluates the condition (worker threads of
/// parallel loops never do), and the condition may be a collective operation under MPI: every
/// rank reaches the same check points in the same order, because they run the same computation.

#include <functional>
#include <string>

#include "ecmor/base/error.hpp"
#include "ecmor/export.hpp"

namespace ecmor {

/// A long computation stopped at a safe point because the run's stop condition holds (the time
/// limit strategy.time_limit_s, SIGINT or SIGTERM). Strategies end the run as interrupted with
/// the best model so far; it is not a failure of the model or of the method.
class ECMOR_API Interrupted : public Error {
 public:
  using Error::Error;
  ~Interrupted() override;
};

/// Installs `stop` as the stop condition until destruction (scopes nest: the previous one comes
/// back). `stop` must not throw.
class ECMOR_API InterruptScope {
 public:
  explicit InterruptScope(std::function<bool()> stop);
  ~InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  void* m_previous;
};

/// Throws Interrupted("interrupted in <where>") when called on the thread that installed the
/// innermost scope and its stop condition holds; otherwise returns at once.
ECMOR_API void check_interrupt(const std::string& where);

/// The same test without throwing, for callbacks of C libraries that must not see a C++
/// exception (SLEPc's stopping test): true when the stop condition holds.
ECMOR_API bool interrupt_requested();

}  // namespace ecmor
