// next_shifts.cpp: IRKA's fixed-point map (next_shifts.hpp).
#include "next_shifts.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "ecmor/base/error.hpp"

namespace ecmor::irka {

Interpolation next_shifts(const PoleResidues& pr, Index r, Index& reflected) {
  const Index n = pr.poles.size();
  std::vector<Index> chosen;
  if (n == r) {
    for (Index i = 0; i < n; ++i) chosen.push_back(i);
  } else {
    chosen = dominant(pr, r);
  }
  std::vector<Complex> shifts;
  ComplexMatrix b(pr.b.rows(), r), c(pr.c.rows(), r);
  Index k = 0;
  for (Index i : chosen) {
    Complex lambda = pr.poles(i);
    if (lambda.real() >= 0.0) {
      lambda = -std::conj(lambda);
      ++reflected;
    }
    shifts.push_back(-lambda);
    const double nb = pr.b.col(i).norm(), nc = pr.c.col(i).norm();
    b.col(k) = nb > 0.0 ? ComplexVector(pr.b.col(i) / nb) : ComplexVector(pr.b.col(i));
    c.col(k) = nc > 0.0 ? ComplexVector(pr.c.col(i) / nc) : ComplexVector(pr.c.col(i));
    ++k;
  }
  // An odd r with no real pole left among the dominant ones (second order): the best pair not
  // chosen gives a real shift |lambda| with the real parts of its directions.
  if (static_cast<Index>(shifts.size()) == r - 1) {
    Index extra = -1;
    double heaviest = -1.0;
    for (Index i = 0; i < n; ++i) {
      if (std::find(chosen.begin(), chosen.end(), i) != chosen.end()) continue;
      const double w = h2_weight(pr, i);
      if (pr.poles(i).imag() > 0.0 && w > heaviest) {
        heaviest = w;
        extra = i;
      }
    }
    if (extra >= 0) {
      shifts.emplace_back(std::abs(pr.poles(extra)), 0.0);
      b.col(k) = pr.b.col(extra).real().normalized().cast<Complex>();
      c.col(k) = pr.c.col(extra).real().normalized().cast<Complex>();
    }
  }
  if (static_cast<Index>(shifts.size()) < r) {
    throw NumericalError(
        fmt::format("only {} of the {} next shifts could be chosen from {} reduced poles",
                    shifts.size(), r, n));
  }
  return canonical(shifts, b, c);
}

double h2_weight(const PoleResidues& pr, Index i) {
  return pr.b.col(i).squaredNorm() * pr.c.col(i).squaredNorm() /
         std::max(std::abs(pr.poles(i).real()), std::numeric_limits<double>::min());
}

std::vector<Index> dominant(const PoleResidues& pr, Index r) {
  struct Item {
    std::vector<Index> members;
    double weight;
  };
  std::vector<Item> items;
  const Index n = pr.poles.size();
  for (Index i = 0; i < n; ++i) {
    const Complex p = pr.poles(i);
    if (p.imag() < 0.0) continue;
    const double w = h2_weight(pr, i);
    Item item{{i}, p.imag() > 0.0 ? 2.0 * w : w};
    if (p.imag() > 0.0) {
      // Its conjugate partner: the nearest pole to conj(p) with Im < 0.
      Index partner = -1;
      double best = std::numeric_limits<double>::infinity();
      for (Index j = 0; j < n; ++j) {
        if (pr.poles(j).imag() >= 0.0) continue;
        const double d = std::abs(pr.poles(j) - std::conj(p));
        if (d < best) {
          best = d;
          partner = j;
        }
      }
      if (partner < 0) continue;
      item.members.push_back(partner);
    }
    items.push_back(std::move(item));
  }
  std::stable_sort(items.begin(), items.end(),
                   [](const Item& a, const Item& b) { return a.weight > b.weight; });
  std::vector<Index> chosen;
  for (const Item& item : items) {
    const Index left = r - static_cast<Index>(chosen.size());
    if (left == 0) break;
    if (static_cast<Index>(item.members.size()) <= left) {
      chosen.insert(chosen.end(), item.members.begin(), item.members.end());
    }
  }
  return chosen;
}

}  // namespace ecmor::irka
