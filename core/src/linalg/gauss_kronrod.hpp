#pragma once
// gauss_kronrod.hpp: the Gauss-Kronrod 7/15 rule shared by the core's adaptive quadratures
// (h2_norm.cpp for scalar integrands, quadrature.cpp for matrix-valued ones). Private to core.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace ecmor::detail {

// Gauss-Kronrod 7/15 on [-1, 1] (Kronrod nodes; the odd-indexed ones, 1, 3, 5, and the centre 7,
// are the Gauss nodes). Piessens et al., QUADPACK (1983), routine qk15.
inline constexpr double kXgk[8] = {
    0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
    0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
    0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
    0.207784955007898467600689403773245, 0.000000000000000000000000000000000};
inline constexpr double kWgk[8] = {
    0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
    0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
    0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
    0.204432940075298892414161999234649, 0.209482141084727828012999174891714};
inline constexpr double kWg[4] = {
    0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
    0.381830050505118944950369775488975, 0.417959183673469387755102040816327};
inline constexpr int kNodes = 15;

/// The 15 nodes of [a, b] in the order: centre, then +-x_k for k = 0..6.
inline void nodes_of(double a, double b, double* out) {
  const double c = 0.5 * (a + b), h = 0.5 * (b - a);
  out[0] = c;
  for (int k = 0; k < 7; ++k) {
    out[1 + 2 * k] = c - h * kXgk[k];
    out[2 + 2 * k] = c + h * kXgk[k];
  }
}

struct Piece {
  double a = 0.0, b = 0.0;
  double kronrod = 0.0, gauss = 0.0, error = 0.0;
  bool splittable = true;
};

/// Kronrod and Gauss sums of one interval from the integrand at nodes_of(a, b), and the error
/// estimate of QUADPACK's qk15: |K - G| scaled by (200 |K - G| / resasc)^1.5 (resasc: the
/// integral of |f - mean f|), since K15 is far more accurate than G7 once the interval resolves
/// the integrand; never below 50 eps |K|.
inline void rule(Piece& p, const double* f) {
  const double h = 0.5 * (p.b - p.a);
  double k = kWgk[7] * f[0], g = kWg[3] * f[0], k_abs = kWgk[7] * std::abs(f[0]);
  for (int j = 0; j < 7; ++j) {
    const double pair = f[1 + 2 * j] + f[2 + 2 * j];
    k += kWgk[j] * pair;
    k_abs += kWgk[j] * (std::abs(f[1 + 2 * j]) + std::abs(f[2 + 2 * j]));
    if (j % 2 == 1) g += kWg[j / 2] * pair;
  }
  const double mean = 0.5 * k;
  double asc = kWgk[7] * std::abs(f[0] - mean);
  for (int j = 0; j < 7; ++j)
    asc += kWgk[j] * (std::abs(f[1 + 2 * j] - mean) + std::abs(f[2 + 2 * j] - mean));
  p.kronrod = h * k;
  p.gauss = h * g;
  const double resasc = h * asc, resabs = h * k_abs;
  double err = std::abs(p.kronrod - p.gauss);
  if (resasc != 0.0 && err != 0.0)
    err = resasc * std::min(1.0, std::pow(200.0 * err / resasc, 1.5));
  p.error = std::max(50.0 * std::numeric_limits<double>::epsilon() * resabs, err);
  // An interval this narrow cannot be bisected into distinct nodes any more.
  p.splittable = (p.b - p.a) > 64.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, p.b);
}

/// One round of adaptive bisection over `pieces` (each with a, b, error and splittable): bisects
/// the splittable piece of largest error and, in the same round, every other one whose error
/// exceeds its equal share of `tol` (they must be split anyway), at most 16 pieces (parallel work
/// without overshooting) and no more than `evaluations_left` integrand values pay for (2 kNodes
/// per bisection). `evaluate(std::vector<P>&)` fills the new halves, which then replace their
/// parents. Returns false, changing nothing, when no piece is splittable or affordable.
template <class P, class Evaluate>
bool bisect_worst(std::vector<P>& pieces, double tol, long long evaluations_left,
                  Evaluate&& evaluate) {
  constexpr long long kMaxBatch = 16;
  const long long affordable = evaluations_left / (2 * kNodes);
  if (affordable <= 0) return false;
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < pieces.size(); ++i)
    if (pieces[i].splittable) order.push_back(i);
  if (order.empty()) return false;
  std::sort(order.begin(), order.end(),
            [&](std::size_t x, std::size_t y) { return pieces[x].error > pieces[y].error; });
  const double share = tol / static_cast<double>(pieces.size());
  long long count = 1;
  while (count < static_cast<long long>(order.size()) && count < std::min(affordable, kMaxBatch) &&
         pieces[order[count]].error > share)
    ++count;
  std::vector<P> batch;
  std::vector<std::size_t> replaced(order.begin(), order.begin() + count);
  for (std::size_t idx : replaced) {
    const double mid = 0.5 * (pieces[idx].a + pieces[idx].b);
    P left{}, right{};
    left.a = pieces[idx].a;
    left.b = mid;
    right.a = mid;
    right.b = pieces[idx].b;
    batch.push_back(std::move(left));
    batch.push_back(std::move(right));
  }
  evaluate(batch);
  std::sort(replaced.begin(), replaced.end());
  for (auto it = replaced.rbegin(); it != replaced.rend(); ++it)
    pieces.erase(pieces.begin() + static_cast<std::ptrdiff_t>(*it));
  pieces.insert(pieces.end(), batch.begin(), batch.end());
  return true;
}

/// How one round of an adaptive loop ends (adaptive_round).
enum class Round { Converged, Refined, Stopped };

/// One round of an adaptive quadrature loop: Converged when `error` <= max(relative * scale,
/// absolute); else the pieces are bisected (bisect_worst, Refined), or nothing splittable or
/// affordable is left (Stopped).
template <class P, class Evaluate>
Round adaptive_round(std::vector<P>& pieces, double error, double scale, double relative,
                     double absolute, long long evaluations_left, Evaluate&& evaluate) {
  const double tol = std::max(relative * scale, absolute);
  if (error <= tol) return Round::Converged;
  return bisect_worst(pieces, tol, evaluations_left, evaluate) ? Round::Refined : Round::Stopped;
}

}  // namespace ecmor::detail
