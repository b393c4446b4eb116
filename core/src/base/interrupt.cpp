#include "ecmor/base/interrupt.hpp"

#include <utility>

#include "ecmor/base/error.hpp"

namespace ecmor {
namespace {

struct Scope {
  std::function<bool()> stop;
  Scope* previous = nullptr;
};

// The innermost scope of this thread: worker threads of parallel loops have none, so they never
// evaluate the stop condition.
thread_local Scope* t_scope = nullptr;

}  // namespace

Interrupted::~Interrupted() = default;

InterruptScope::InterruptScope(std::function<bool()> stop) : m_previous(t_scope) {
  t_scope = new Scope{std::move(stop), t_scope};
}

InterruptScope::~InterruptScope() {
  Scope* s = t_scope;
  t_scope = static_cast<Scope*>(m_previous);
  delete s;
}

bool interrupt_requested() {
  const Scope* s = t_scope;
  return s != nullptr && s->stop && s->stop();
}

void check_interrupt(const std::string& where) {
  if (interrupt_requested()) throw Interrupted("interrupted in " + where);
}

}  // namespace ecmor
