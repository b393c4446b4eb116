#include "stop_policy.hpp"

#include <fmt/format.h>

#include "ecmor/linalg/parallel.hpp"
#include "ecmor/run/driver.hpp"

namespace ecmor::run {

StopPolicy::StopPolicy(std::chrono::steady_clock::time_point start, double time_limit_s,
                       RunObserver* observer)
    : m_start(start), m_limit_s(time_limit_s), m_observer(observer) {}

bool StopPolicy::time_is_up() {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
  if (m_limit_s > 0.0 && elapsed > m_limit_s) m_out_of_time = true;
  return m_out_of_time;
}

void StopPolicy::poll_observer() {
  if (m_observer != nullptr && m_observer->stop_requested()) m_user_stop = true;
}

bool StopPolicy::requested() {
  poll_observer();
  const bool local = time_is_up() || m_user_stop;
  // Another rank stopped: to this rank that is a request from outside, not its own time limit.
  if (any_process(local) && !local) m_user_stop = true;
  const bool member_local = m_member_over && m_member_over();
  if (any_process(member_local)) m_member_out = true;
  return m_out_of_time || m_user_stop || m_member_out;
}

void StopPolicy::begin_member(std::function<bool()> over_budget) {
  m_member_over = std::move(over_budget);
  m_member_out = false;
}

bool StopPolicy::signalled() {
  poll_observer();
  if (any_process(m_user_stop)) m_user_stop = true;
  return m_user_stop;
}

std::string StopPolicy::time_limit_text() const {
  return fmt::format("time limit strategy.time_limit_s = {} s used up", m_limit_s);
}

}  // namespace ecmor::run
