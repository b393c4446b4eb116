#include "signals.hpp"

#include <unistd.h>

#include <atomic>
#include <csignal>

namespace ecmor::app {
namespace {

std::atomic<int> g_signals{0};
static_assert(std::atomic<int>::is_always_lock_free, "the handler needs a lock-free counter");

template <std::size_t N>
void say(const char (&text)[N]) {
  // write(2) is async-signal-safe; a failed write has nowhere to be reported.
  [[maybe_unused]] const ssize_t written = ::write(STDERR_FILENO, text, N - 1);
}

extern "C" void on_stop_signal(int) {
  if (g_signals.fetch_add(1) == 0) {
    say("\necmor: stopping after the current step (the history and the best model so far are "
        "written); signal again to quit at once\n");
    return;
  }
  say("\necmor: quit at once on a second signal; the history holds the iterations completed so "
      "far\n");
  ::_exit(130);
}

}  // namespace

void install_stop_signals() {
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
}

bool stop_signalled() { return g_signals.load() > 0; }

}  // namespace ecmor::app
