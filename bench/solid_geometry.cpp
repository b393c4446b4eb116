// solid_geometry.cpp: the solid's mesh as nodes.csv/dofs.csv data (see solid_geometry.hpp).
#include "solid_geometry.hpp"

#include <algorithm>

namespace ecmor::bench {

FeGeometry solid_geometry(const SolidOptions& o) {
  o.validate();
  FeGeometry g;
  const Index i0 = o.clamped ? 1 : 0;
  for (Index k = 0; k <= o.nz; ++k)
    for (Index j = 0; j <= o.ny; ++j)
      for (Index i = 0; i <= o.nx; ++i) {
        const long long id = 1 + i + (o.nx + 1) * (j + (o.ny + 1) * k);
        g.nodes.push_back({id, o.lx * static_cast<double>(i) / static_cast<double>(o.nx),
                           o.ly * static_cast<double>(j) / static_cast<double>(o.ny),
                           o.lz * static_cast<double>(k) / static_cast<double>(o.nz)});
        if (i < i0) continue;
        const Index n = (i - i0) + (o.nx + 1 - i0) * (j + (o.ny + 1) * k);
        for (int c = 0; c < 3; ++c) g.dofs.push_back({3 * n + c + 1, id, c + 1});
      }
  std::sort(g.dofs.begin(), g.dofs.end(),
            [](const FeDof& a, const FeDof& b) { return a.row < b.row; });
  return g;
}

}  // namespace ecmor::bench
