#pragma once
// stop_policy.hpp: when a run ends early. The time limit (strategy.time_limit_s) acts as an
// interrupt: strategies poll it and finish with their best model so far. A stop request (SIGINT,
// SIGTERM through RunObserver::stop_requested) does the same. Under MPI both are collective: a
// limit or a signal seen on one rank stops every rank at the same point, since the solves are
// collective operations entered by all ranks in the same order.
#include <chrono>
#include <functional>
#include <string>

namespace ecmor {

class RunObserver;

namespace run {

class StopPolicy {
 public:
  /// time_limit_s <= 0: no limit. observer may be null (no stop requests).
  StopPolicy(std::chrono::steady_clock::time_point start, double time_limit_s,
             RunObserver* observer);

  /// This rank's clock has passed the time limit (latched once true). Not collective.
  bool time_is_up();
  /// A time limit or a stop request on any rank (collective): the strategies' and reducers' stop
  /// condition.
  bool requested();
  /// A stop request on any rank (collective), ignoring the time limit: it ends the estimator's
  /// first sampling of the full model, which the time limit does not (the limit bounds the
  /// search for a model, and without that sampling there is none).
  bool signalled();

  bool out_of_time() const { return m_out_of_time; }
  bool user_stop() const { return m_user_stop; }

  /// A portfolio member's own budget (the race, portfolio.cpp): from now on requested() is also
  /// true once `over_budget` returns true on any rank, until the next begin_member(); an empty
  /// function: none.
  void begin_member(std::function<bool()> over_budget);
  /// The member's budget is used up (set by requested()).
  bool member_over_budget() const { return m_member_out; }
  /// "time limit strategy.time_limit_s = T s used up", for messages.
  std::string time_limit_text() const;

 private:
  void poll_observer();

  std::chrono::steady_clock::time_point m_start;
  double m_limit_s;
  RunObserver* m_observer;
  bool m_out_of_time = false;
  bool m_user_stop = false;
  std::function<bool()> m_member_over;
  bool m_member_out = false;
};

}  // namespace run
}  // namespace ecmor
