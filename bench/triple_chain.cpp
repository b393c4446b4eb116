// triple_chain.cpp: the triple chain oscillator generator (see triple_chain.hpp).
#include "triple_chain.hpp"

#include <fmt/format.h>

#include <cmath>
#include <string>
#include <vector>

#include "ecmor/base/error.hpp"

namespace ecmor::bench {

namespace {

void require_damping_parameter(const char* name, double value) {
  if (!std::isfinite(value)) {
    throw ConfigError(fmt::format("triple_chain: {} = {}: must be finite", name, value));
  }
  if (value < 0.0) {
    throw ConfigError(fmt::format(
        "triple_chain: {} = {}: must be >= 0 (negative damping makes the model unstable)", name,
        value));
  }
}

}  // namespace

SecondOrderModel triple_chain(Index n1, double alpha, double beta, double v) {
  if (n1 < 1 || n1 > kTripleChainMaxN1) {
    throw ConfigError(fmt::format(
        "triple_chain: n1 = {}: must be in [1, {}] (N = 3 n1 + 1 and nnz = 9 n1 + 1 must fit "
        "32-bit sparse indices)",
        n1, kTripleChainMaxN1));
  }
  require_damping_parameter("alpha", alpha);
  require_damping_parameter("beta", beta);
  require_damping_parameter("v", v);

  constexpr double kMass[3] = {1.0, 2.0, 3.0};
  constexpr double kSpring[3] = {10.0, 20.0, 1.0};
  constexpr double kMass0 = 10.0;
  constexpr double kSpring0 = 50.0;

  const Index N = 3 * n1 + 1;
  const Index last = N - 1;  // 0-based index of m0
  using Triplet = Eigen::Triplet<double, int>;

  // K is assembled entry by entry (not spring by spring) so that every stored value is written
  // once: no duplicate summation, so D = alpha M + beta K + v P can be formed per entry with the
  // same rounding as the sparse sum alpha*M + beta*K + v*P of the reference implementation.
  std::vector<Triplet> k_entries;
  std::vector<Triplet> d_entries;
  const std::size_t nnz = static_cast<std::size_t>(9 * n1 + 1);
  k_entries.reserve(nnz);
  d_entries.reserve(nnz);
  Eigen::VectorXd mass(N);

  // 0-based positions of the grounded dampers: e_1, e_n1, e_(2n1+1) in 1-based terms. For n1 = 1
  // the first two coincide and that mass carries 2 v, as the sum of outer products says.
  auto damper = [&](Index i) {
    return v * static_cast<double>((i == 0) + (i == n1 - 1) + (i == 2 * n1));
  };
  auto add = [&](Index i, Index j, double m_ij, double k_ij) {
    k_entries.emplace_back(static_cast<int>(i), static_cast<int>(j), k_ij);
    double d = alpha * m_ij + beta * k_ij;
    if (i == j) d += damper(i);
    d_entries.emplace_back(static_cast<int>(i), static_cast<int>(j), d);
  };

  for (int c = 0; c < 3; ++c) {
    const double m = kMass[c];
    const double k = kSpring[c];
    const Index first = c * n1;
    for (Index i = first; i < first + n1; ++i) {
      mass(i) = m;
      // Every chain mass has two springs of stiffness k: its left neighbour (ground for the
      // first one) and its right neighbour (m0 for the last one).
      if (i > first) add(i, i - 1, 0.0, -k);
      add(i, i, m, 2.0 * k);
      if (i + 1 < first + n1) add(i, i + 1, 0.0, -k);
    }
    add(first + n1 - 1, last, 0.0, -k);
    add(last, first + n1 - 1, 0.0, -k);
  }
  mass(last) = kMass0;
  add(last, last, kMass0, kSpring[0] + kSpring[1] + kSpring[2] + kSpring0);

  SecondOrderModel model;
  model.M.resize(N, N);
  model.M.reserve(Eigen::VectorXi::Ones(N));
  for (Index i = 0; i < N; ++i) model.M.insert(i, i) = mass(i);
  model.M.makeCompressed();
  model.K.resize(N, N);
  model.K.setFromTriplets(k_entries.begin(), k_entries.end());
  k_entries = {};  // release before the next assembly: keeps the peak at O(one matrix)
  model.D.resize(N, N);
  model.D.setFromTriplets(d_entries.begin(), d_entries.end());
  model.B = Matrix::Ones(N, 1);
  model.C = Matrix::Ones(1, N);
  return model;
}

}  // namespace ecmor::bench
