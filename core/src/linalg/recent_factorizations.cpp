#include "ecmor/linalg/recent_factorizations.hpp"

#include <algorithm>

#include "ecmor/base/error.hpp"

namespace ecmor {

RecentFactorizations::RecentFactorizations(ShiftedSolver& inner, Index keep)
    : m_inner(inner), m_keep(keep) {
  if (keep < 0)
    throw ConfigError("RecentFactorizations: keep = " + std::to_string(keep) + ": must be >= 0");
}

MemoryPlan RecentFactorizations::plan_memory(Index /*kept*/) {
  MemoryPlan plan = m_inner.plan_memory(m_keep);
  if (plan.fits()) m_keep = std::min(m_keep, plan.kept);
  return plan;
}

std::shared_ptr<const Factorization> RecentFactorizations::factorize_combination(
    std::span<const Complex> weights) {
  auto same = [&](const Kept& k) {
    return std::equal(k.weights.begin(), k.weights.end(), weights.begin(), weights.end());
  };
  {
    const std::lock_guard<std::mutex> lock(m_mutex);
    const auto it = std::find_if(m_kept.begin(), m_kept.end(), same);
    if (it != m_kept.end()) {
      ++m_reuses;
      m_kept.splice(m_kept.begin(), m_kept, it);
      return m_kept.front().factorization;
    }
  }
  // Outside the lock: factorisations of different combinations run concurrently.
  std::shared_ptr<const Factorization> f = m_inner.factorize_combination(weights);
  if (m_keep > 0) {
    const std::lock_guard<std::mutex> lock(m_mutex);
    m_kept.push_front(Kept{std::vector<Complex>(weights.begin(), weights.end()), f});
    while (static_cast<Index>(m_kept.size()) > m_keep) m_kept.pop_back();
  }
  return f;
}

std::int64_t RecentFactorizations::reuses() const {
  const std::lock_guard<std::mutex> lock(m_mutex);
  return m_reuses;
}

}  // namespace ecmor
