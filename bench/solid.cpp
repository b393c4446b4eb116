// solid.cpp: the 3-D hexahedral solid generator (see solid.hpp).
#include "solid.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "ecmor/base/error.hpp"

namespace ecmor::bench {

namespace {

constexpr Index kNoLimit = std::numeric_limits<Index>::max();

[[noreturn]] void fail(const char* field, const std::string& value, const std::string& rule) {
  throw ConfigError(fmt::format("SolidOptions::{} = {}: {}", field, value, rule));
}

std::string num(double x) { return fmt::format("{:g}", x); }

void require_positive(const char* field, double value) {
  if (!(std::isfinite(value) && value > 0.0)) fail(field, num(value), "must be finite and > 0");
}

void require_nonnegative(const char* field, double value) {
  if (!(std::isfinite(value) && value >= 0.0)) fail(field, num(value), "must be finite and >= 0");
}

void require_in(const char* field, Index value, Index lo, Index hi, const std::string& rule) {
  if (value < lo || value > hi) fail(field, std::to_string(value), rule);
}

// Element matrices of one hexahedron with edges hx, hy, hz; local node l = a + 2 b + 4 c sits at
// the reference corner ((2a-1), (2b-1), (2c-1)). K is 24 x 24 (row 3 l + component), M is the
// 8 x 8 scalar mass (the 24 x 24 consistent mass is M (x) I3). Only the upper triangles are
// integrated; the lower ones are copies, so both are symmetric bit for bit, and so is every
// global sum of their entries taken in the same element order.
struct ElementMatrices {
  std::array<double, 24 * 24> K{};
  std::array<double, 8 * 8> M{};
};

ElementMatrices element_matrices(const SolidOptions& o) {
  const std::array<double, 3> h = {o.lx / static_cast<double>(o.nx),
                                   o.ly / static_cast<double>(o.ny),
                                   o.lz / static_cast<double>(o.nz)};
  const double lambda = o.E * o.nu / ((1.0 + o.nu) * (1.0 - 2.0 * o.nu));
  const double mu = o.E / (2.0 * (1.0 + o.nu));
  // 2-point Gauss rule per direction: points +-1/sqrt(3), weights 1; dV = det J = hx hy hz / 8.
  const double g = 1.0 / std::sqrt(3.0);
  const double det_j = h[0] * h[1] * h[2] / 8.0;
  ElementMatrices e;
  for (int point = 0; point < 8; ++point) {
    const std::array<double, 3> xi = {(point & 1) ? g : -g, (point & 2) ? g : -g,
                                      (point & 4) ? g : -g};
    std::array<double, 8> n{};
    std::array<std::array<double, 3>, 8> dn{};  // physical derivatives dN_l/dx_c
    for (int l = 0; l < 8; ++l) {
      const std::array<double, 3> s = {(l & 1) ? 1.0 : -1.0, (l & 2) ? 1.0 : -1.0,
                                       (l & 4) ? 1.0 : -1.0};
      const std::array<double, 3> f = {1.0 + s[0] * xi[0], 1.0 + s[1] * xi[1], 1.0 + s[2] * xi[2]};
      n[l] = f[0] * f[1] * f[2] / 8.0;
      // dN/dxi_c = s_c / 8 prod_{d != c} f_d; dxi_c/dx_c = 2 / h_c.
      dn[l][0] = s[0] * f[1] * f[2] / 4.0 / h[0];
      dn[l][1] = s[1] * f[0] * f[2] / 4.0 / h[1];
      dn[l][2] = s[2] * f[0] * f[1] / 4.0 / h[2];
    }
    for (int a = 0; a < 24; ++a) {
      const int l = a / 3, c = a % 3;
      for (int b = a; b < 24; ++b) {
        const int m = b / 3, d = b % 3;
        double v = lambda * dn[l][c] * dn[m][d] + mu * dn[l][d] * dn[m][c];
        if (c == d) {
          v += mu * (dn[l][0] * dn[m][0] + dn[l][1] * dn[m][1] + dn[l][2] * dn[m][2]);
        }
        e.K[a * 24 + b] += v * det_j;
      }
    }
    for (int l = 0; l < 8; ++l)
      for (int m = l; m < 8; ++m) e.M[l * 8 + m] += o.rho * n[l] * n[m] * det_j;
  }
  for (int a = 0; a < 24; ++a)
    for (int b = 0; b < a; ++b) e.K[a * 24 + b] = e.K[b * 24 + a];
  for (int l = 0; l < 8; ++l)
    for (int m = 0; m < l; ++m) e.M[l * 8 + m] = e.M[m * 8 + l];
  return e;
}

// A node and a displacement component: one column of B or one row of C.
struct Probe {
  Index i, j, k;
  int component;
};

}  // namespace

void SolidOptions::validate() const {
  require_in("nx", nx, 1, kNoLimit, "must be >= 1");
  require_in("ny", ny, 1, kNoLimit, "must be >= 1");
  require_in("nz", nz, 1, kNoLimit, "must be >= 1");
  const double nodes = (static_cast<double>(nx) + 1.0) * (static_cast<double>(ny) + 1.0) *
                       (static_cast<double>(nz) + 1.0);
  if (nodes > kSolidMaxNodes) {
    throw ConfigError(fmt::format(
        "SolidOptions::nx, ny, nz = {} x {} x {}: (nx + 1)(ny + 1)(nz + 1) = {:g} nodes: must be "
        "<= {:g} (nnz(K) <= 243 per node must fit 32-bit sparse indices)",
        nx, ny, nz, nodes, kSolidMaxNodes));
  }
  require_positive("lx", lx);
  require_positive("ly", ly);
  require_positive("lz", lz);
  require_positive("E", E);
  if (!(nu >= 0.0 && nu < 0.5)) fail("nu", num(nu), "must be in [0, 0.5)");
  require_positive("rho", rho);
  require_nonnegative("alpha", alpha);
  require_nonnegative("beta", beta);
  require_in("inputs", inputs, 1, kSolidMaxInputs,
             fmt::format("must be in [1, {}]", kSolidMaxInputs));
  require_in("outputs", outputs, 1, kSolidMaxOutputs,
             fmt::format("must be in [1, {}]", kSolidMaxOutputs));
}

SecondOrderModel solid(const SolidOptions& o) {
  o.validate();
  const ElementMatrices e = element_matrices(o);
  const Index nx = o.nx, ny = o.ny, nz = o.nz;
  const Index i0 = o.clamped ? 1 : 0;
  const Index nxf = nx + 1 - i0;  // free nodes along x
  const Index N = 3 * nxf * (ny + 1) * (nz + 1);
  auto node = [&](Index i, Index j, Index k) { return (i - i0) + nxf * (j + (ny + 1) * k); };
  // Neighbours of coordinate a (itself included) within [lo, hi].
  auto span = [](Index a, Index lo, Index hi) {
    return std::min(a + 1, hi) - std::max(a - 1, lo) + 1;
  };

  // First pass: the number of stored entries. A node couples to every node of the elements it
  // belongs to (at most 27), with a full 3x3 block in K and D and the block diagonal in M.
  Index nnz_k = 0;
  for (Index k = 0; k <= nz; ++k)
    for (Index j = 0; j <= ny; ++j)
      for (Index i = i0; i <= nx; ++i)
        nnz_k += 9 * span(i, i0, nx) * span(j, 0, ny) * span(k, 0, nz);
  const Index nnz_m = nnz_k / 3;

  // The matrices are written straight into compressed column storage: no triplet list (which
  // for N = 1e6 would hold 2e8 entries), no sort, no duplicate summation. Peak memory is the
  // three matrices themselves.
  const bool damped = o.alpha != 0.0 || o.beta != 0.0;
  SecondOrderModel model;
  model.K.resize(N, N);
  model.K.resizeNonZeros(nnz_k);
  model.M.resize(N, N);
  model.M.resizeNonZeros(nnz_m);
  model.D.resize(N, N);
  if (damped) model.D.resizeNonZeros(nnz_k);
  int* k_outer = model.K.outerIndexPtr();
  int* k_inner = model.K.innerIndexPtr();
  double* k_value = model.K.valuePtr();
  int* m_outer = model.M.outerIndexPtr();
  int* m_inner = model.M.innerIndexPtr();
  double* m_value = model.M.valuePtr();
  double* d_value = damped ? model.D.valuePtr() : nullptr;

  // Elements (along one axis) holding both coordinate a (of the column node) and b (of the row
  // node): {a - 1, a} within [0, n - 1] when a == b, else the one between them.
  struct Range {
    Index first, last;
  };
  auto shared = [](Index a, Index b, Index n) {
    if (a != b) return Range{std::min(a, b), std::min(a, b)};
    return Range{std::max<Index>(a - 1, 0), std::min(a, n - 1)};
  };

  // Second pass. Column (q, cc), rows (p, cr) for the neighbours p in increasing order (the
  // numbering is lexicographic in (k, j, i), so the loop order dk, dj, di visits p increasingly)
  // and cr = 0, 1, 2: every column is sorted. Entry (p cr, q cc) sums K_e[3 lp + cr][3 lq + cc]
  // over the shared elements in the fixed order (ez, ey, ex); entry (q cc, p cr) sums the
  // transposed element entries (equal bit for bit) over the same elements in the same order, so
  // K, M and D are exactly symmetric.
  Index pk = 0, pm = 0;
  for (Index k = 0; k <= nz; ++k)
    for (Index j = 0; j <= ny; ++j)
      for (Index i = i0; i <= nx; ++i) {
        const Index q = node(i, j, k);
        for (int cc = 0; cc < 3; ++cc) {
          const Index col = 3 * q + cc;
          k_outer[col] = static_cast<int>(pk);
          m_outer[col] = static_cast<int>(pm);
          for (Index kk = std::max<Index>(k - 1, 0); kk <= std::min(k + 1, nz); ++kk)
            for (Index jj = std::max<Index>(j - 1, 0); jj <= std::min(j + 1, ny); ++jj)
              for (Index ii = std::max(i - 1, i0); ii <= std::min(i + 1, nx); ++ii) {
                const Index p = node(ii, jj, kk);
                const Range rz = shared(k, kk, nz), ry = shared(j, jj, ny), rx = shared(i, ii, nx);
                std::array<double, 3> kv = {0.0, 0.0, 0.0};
                double mv = 0.0;
                for (Index ez = rz.first; ez <= rz.last; ++ez)
                  for (Index ey = ry.first; ey <= ry.last; ++ey)
                    for (Index ex = rx.first; ex <= rx.last; ++ex) {
                      const Index lq = (i - ex) + 2 * (j - ey) + 4 * (k - ez);
                      const Index lp = (ii - ex) + 2 * (jj - ey) + 4 * (kk - ez);
                      const double* kcol =
                          &e.K[static_cast<std::size_t>(3 * lp * 24 + 3 * lq + cc)];
                      kv[0] += kcol[0];
                      kv[1] += kcol[24];
                      kv[2] += kcol[48];
                      mv += e.M[static_cast<std::size_t>(lp * 8 + lq)];
                    }
                for (int cr = 0; cr < 3; ++cr) {
                  const int row = static_cast<int>(3 * p + cr);
                  k_inner[pk] = row;
                  k_value[pk] = kv[static_cast<std::size_t>(cr)];
                  if (damped) {
                    d_value[pk] =
                        o.beta * kv[static_cast<std::size_t>(cr)] + (cr == cc ? o.alpha * mv : 0.0);
                  }
                  ++pk;
                  if (cr == cc) {
                    m_inner[pm] = row;
                    m_value[pm] = mv;
                    ++pm;
                  }
                }
              }
        }
      }
  k_outer[N] = static_cast<int>(pk);
  m_outer[N] = static_cast<int>(pm);
  if (damped) {
    std::copy(model.K.outerIndexPtr(), model.K.outerIndexPtr() + N + 1, model.D.outerIndexPtr());
    std::copy(k_inner, k_inner + nnz_k, model.D.innerIndexPtr());
  }

  // Inputs and outputs: the table of solid.hpp.
  const Index jc = ny / 2, kc = nz / 2, im = (nx + 1) / 2;
  const std::array<Probe, kSolidMaxInputs> input_table = {{{nx, jc, kc, 0},
                                                           {nx, jc, kc, 1},
                                                           {nx, jc, kc, 2},
                                                           {nx, ny, nz, 1},
                                                           {nx, ny, 0, 2},
                                                           {nx, 0, nz, 0},
                                                           {nx, ny, nz, 2},
                                                           {nx, ny, nz, 0}}};
  const std::array<Probe, kSolidMaxOutputs> output_table = {{{nx, jc, kc, 0},
                                                             {nx, jc, kc, 1},
                                                             {nx, jc, kc, 2},
                                                             {nx, ny, nz, 1},
                                                             {im, jc, kc, 1},
                                                             {im, jc, kc, 2},
                                                             {nx, ny, nz, 2},
                                                             {im, jc, kc, 0}}};
  auto dof = [&](const Probe& p) { return 3 * node(p.i, p.j, p.k) + p.component; };
  model.B = Matrix::Zero(N, o.inputs);
  for (Index c = 0; c < o.inputs; ++c)
    model.B(dof(input_table[static_cast<std::size_t>(c)]), c) = 1.0;
  model.C = Matrix::Zero(o.outputs, N);
  for (Index r = 0; r < o.outputs; ++r)
    model.C(r, dof(output_table[static_cast<std::size_t>(r)])) = 1.0;
  return model;
}

}  // namespace ecmor::bench
