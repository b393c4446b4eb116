#pragma once
/// \file signals.hpp
/// SIGINT and SIGTERM for the commands that run reductions (reduce, bench, check). The first
/// signal asks the run to stop at its next poll: the history, the best model so far and the
/// summary are written, and the command exits 130. A second signal ends the process at once
/// (exit 130), for a run that sits inside a step it cannot leave early (one sparse factorisation of
/// a large model can take minutes); the history on disk then holds the iterations completed so far.

#include "ecmor/run/driver.hpp"

namespace ecmor::app {

/// Installs the handlers (idempotent).
void install_stop_signals();

/// True once a stop signal has arrived.
bool stop_signalled();

/// Observes a run only to stop it once a stop signal has arrived; prints nothing.
class StopOnSignal final : public RunObserver {
 public:
  bool on_iteration(const IterationRecord&) override { return !stop_signalled(); }
  bool stop_requested() override { return stop_signalled(); }
};

}  // namespace ecmor::app
