// ecmor_bench_models: writes large second-order models as Matrix Market directories, for the
// cluster scaling benchmark (bench/cluster_scaling.sh, docs/cluster.md) and anyone who wants a
// model of a given size:
//
//   ecmor_bench_models triplechain N DIR        the triple chain of triple_chain.hpp, N = 3 n1 + 1
//   ecmor_bench_models grid NX NY NZ DIR        a 3-D grid (FE-like sparsity), N = NX NY NZ
//
// The grid model: one displacement per node of an NX x NY x NZ lattice of spacing h = 1, the
// 7-point stiffness of a scalar elastic continuum (k = 1e4 between neighbours), lumped masses
// (m = 1), the face x = 0 held by springs of k to the ground, Rayleigh damping D = 0.01 M + 1e-5 K,
// a force at the far corner (NX-1, NY-1, NZ-1) and two outputs: the displacements at that corner
// and at the centre of the far face. The matrix graph is that of a hexahedral FE mesh with one
// degree of freedom per node; the factors' fill grows like a 3-D mesh's (nested dissection:
// O(N^(4/3)) for a cube, less for a thin plate NZ << NX, NY).
#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "ecmor/matrix_market.hpp"
#include "triple_chain.hpp"

namespace {

using ecmor::Index;

Index parse_size(const std::string& text, const char* what) {
  double v = 0.0;
  try {
    std::size_t used = 0;
    v = std::stod(text, &used);
    if (used != text.size()) throw std::invalid_argument(text);
  } catch (const std::exception&) {
    throw std::runtime_error(fmt::format("{} = '{}': not a number", what, text));
  }
  if (!(v >= 1.0) || v > 2e9 || v != static_cast<double>(static_cast<Index>(v)))
    throw std::runtime_error(fmt::format("{} = '{}': must be a positive integer", what, text));
  return static_cast<Index>(v);
}

void write_model(const std::filesystem::path& dir, const ecmor::SecondOrderModel& m) {
  std::filesystem::create_directories(dir);
  const std::string comment = "written by ecmor_bench_models";
  ecmor::write_matrix_market(dir / "M.mtx", m.M, comment);
  ecmor::write_matrix_market(dir / "D.mtx", m.D, comment);
  ecmor::write_matrix_market(dir / "K.mtx", m.K, comment);
  ecmor::write_matrix_market(dir / "B.mtx", ecmor::Matrix(m.B), comment);
  ecmor::write_matrix_market(dir / "C.mtx", ecmor::Matrix(m.C), comment);
}

ecmor::SecondOrderModel grid(Index nx, Index ny, Index nz) {
  const double total = static_cast<double>(nx) * static_cast<double>(ny) * static_cast<double>(nz);
  if (total > 2e8) throw std::runtime_error(fmt::format("grid: N = {:g} is too large", total));
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
  ecmor::SecondOrderModel m;
  m.M.resize(n, n);
  m.M.setFromTriplets(mt.begin(), mt.end());
  m.K.resize(n, n);
  m.K.setFromTriplets(kt.begin(), kt.end());
  m.D = alpha * m.M + beta * m.K;
  m.M.makeCompressed();
  m.K.makeCompressed();
  m.D.makeCompressed();
  const Index corner = id(nx - 1, ny - 1, nz - 1), centre = id(nx - 1, ny / 2, nz / 2);
  m.B = ecmor::Matrix::Zero(n, 1);
  m.B(corner, 0) = 1.0;
  m.C = ecmor::Matrix::Zero(2, n);
  m.C(0, corner) = 1.0;
  m.C(1, centre) = 1.0;
  return m;
}

int usage(const char* argv0) {
  fmt::print(stderr,
             "usage: {0} triplechain N DIR      (N = 3 n1 + 1 is rounded up to that form)\n"
             "       {0} grid NX NY NZ DIR\n",
             argv0);
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc < 2) return usage(argv[0]);
    const std::string kind = argv[1];
    if (kind == "triplechain" && argc == 4) {
      const Index n = parse_size(argv[2], "N");
      const Index n1 = std::max<Index>(1, (n - 1 + 2) / 3);
      // alpha = beta = 0.002, v = 5: the triplechain_mess_n1501 instance scaled up.
      const ecmor::SecondOrderModel m = ecmor::bench::triple_chain(n1, 0.002, 0.002, 5.0);
      write_model(argv[3], m);
      fmt::print("triple chain: N = {}, nnz(K) = {} -> {}\n", m.K.rows(), m.K.nonZeros(), argv[3]);
      return 0;
    }
    if (kind == "grid" && argc == 6) {
      const ecmor::SecondOrderModel m = grid(parse_size(argv[2], "NX"), parse_size(argv[3], "NY"),
                                             parse_size(argv[4], "NZ"));
      write_model(argv[5], m);
      fmt::print("grid: N = {}, nnz(K) = {} -> {}\n", m.K.rows(), m.K.nonZeros(), argv[5]);
      return 0;
    }
    return usage(argv[0]);
  } catch (const std::exception& e) {
    fmt::print(stderr, "ecmor_bench_models: {}\n", e.what());
    return 1;
  }
}
