// lattice.cpp: the 3-D lattice model of lattice.hpp (moved from bench_models.cpp unchanged).
#include "lattice.hpp"

#include <fmt/format.h>

#include <vector>

#include "ecmor/base/error.hpp"

namespace ecmor::bench {

SecondOrderModel lattice(Index nx, Index ny, Index nz) {
  if (nx < 1 || ny < 1 || nz < 1)
    throw ConfigError(fmt::format("grid: {} x {} x {}: every size must be >= 1", nx, ny, nz));
  const double total = static_cast<double>(nx) * static_cast<double>(ny) * static_cast<double>(nz);
  if (total > 2e8) throw ConfigError(fmt::format("grid: N = {:g} is too large", total));
  const Index n = nx * ny * nz;
  auto id = [&](Index i, Index j, Index k) { return i + nx * (j + ny * k); };
  const double k_spring = 1e4, alpha = 0.01, beta = 1e-5;
  std::vector<Eigen::Triplet<double>> kt, mt;
  kt.reserve(static_cast<std::size_t>(7 * n));
  mt.reserve(static_cast<std::size_t>(n));
  std::vector<double> diag(static_cast<std::size_t>(n), 0.0);
  auto spring = [&](Index a, Index b) {
    diag[static_cast<std::size_t>(a)] += k_spring;
    diag[static_cast<std::size_t>(b)] += k_spring;
    kt.emplace_back(a, b, -k_spring);
    kt.emplace_back(b, a, -k_spring);
  };
  for (Index k = 0; k < nz; ++k)
    for (Index j = 0; j < ny; ++j)
      for (Index i = 0; i < nx; ++i) {
        const Index a = id(i, j, k);
        if (i + 1 < nx) spring(a, id(i + 1, j, k));
        if (j + 1 < ny) spring(a, id(i, j + 1, k));
        if (k + 1 < nz) spring(a, id(i, j, k + 1));
        if (i == 0) diag[static_cast<std::size_t>(a)] += k_spring;  // clamped face
        mt.emplace_back(a, a, 1.0);
      }
  for (Index a = 0; a < n; ++a) kt.emplace_back(a, a, diag[static_cast<std::size_t>(a)]);
  SecondOrderModel m;
  m.M.resize(n, n);
  m.M.setFromTriplets(mt.begin(), mt.end());
  m.K.resize(n, n);
  m.K.setFromTriplets(kt.begin(), kt.end());
  m.D = alpha * m.M + beta * m.K;
  m.M.makeCompressed();
  m.K.makeCompressed();
  m.D.makeCompressed();
  const Index corner = id(nx - 1, ny - 1, nz - 1), centre = id(nx - 1, ny / 2, nz / 2);
  m.B = Matrix::Zero(n, 1);
  m.B(corner, 0) = 1.0;
  m.C = Matrix::Zero(2, n);
  m.C(0, corner) = 1.0;
  m.C(1, centre) = 1.0;
  return m;
}

}  // namespace ecmor::bench
