// ecmor_bench_models: writes large second-order models as Matrix Market directories, for the
// cluster scaling benchmark (bench/cluster_scaling.sh, docs/cluster.md) and anyone who wants a
// model of a given size:
//
//   ecmor_bench_models triplechain N DIR        the triple chain of triple_chain.hpp, N = 3 n1 + 1
//   ecmor_bench_models grid NX NY NZ DIR        a 3-D grid (FE-like sparsity), N = NX NY NZ
//   ecmor_bench_models solid NX NY NZ DIR [--free]
//                                               a 3-D elastic solid of NX x NY x NZ hexahedra,
//                                               N = 3 (NX + 1)(NY + 1)(NZ + 1), less the clamped
//                                               face's 3 (NY + 1)(NZ + 1) unless --free
//
// The solid model (solid.hpp): the default steel bar 1.0 x 0.1 x 0.05 m of SolidOptions, 8-node
// tri-linear hexahedra, consistent mass, Rayleigh damping (1 % at 40 Hz and 2 kHz), clamped at
// x = 0 (--free: a free-floating body with 6 rigid-body modes), 4 force inputs on the far face
// and 6 displacement outputs. Cubic elements: NX : NY : NZ = 20 : 2 : 1.
//
// The grid model: the 3-D lattice of lattice.hpp (one degree of freedom per node, the sparsity of
// a hexahedral FE mesh, clamped face, Rayleigh damping, a corner force and two outputs).
#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "ecmor/model/matrix_market.hpp"
#include "lattice.hpp"
#include "solid.hpp"
#include "solid_geometry.hpp"
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

int usage(const char* argv0) {
  fmt::print(stderr,
             "usage: {0} triplechain N DIR      (N = 3 n1 + 1 is rounded up to that form)\n"
             "       {0} grid NX NY NZ DIR\n"
             "       {0} solid NX NY NZ DIR [--free]\n",
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
      const ecmor::SecondOrderModel m = ecmor::bench::lattice(
          parse_size(argv[2], "NX"), parse_size(argv[3], "NY"), parse_size(argv[4], "NZ"));
      write_model(argv[5], m);
      fmt::print("grid: N = {}, nnz(K) = {} -> {}\n", m.K.rows(), m.K.nonZeros(), argv[5]);
      return 0;
    }
    if (kind == "solid" && (argc == 6 || (argc == 7 && std::string(argv[6]) == "--free"))) {
      ecmor::bench::SolidOptions options;
      options.nx = parse_size(argv[2], "NX");
      options.ny = parse_size(argv[3], "NY");
      options.nz = parse_size(argv[4], "NZ");
      options.clamped = argc == 6;
      const ecmor::SecondOrderModel m = ecmor::bench::solid(options);
      write_model(argv[5], m);
      // nodes.csv, dofs.csv: the mesh for `ecmor export-body` (docs/multibody.md).
      ecmor::write_fe_geometry(argv[5], ecmor::bench::solid_geometry(options));
      fmt::print("solid ({}): N = {}, nnz(K) = {}, nnz(M) = {}, {} inputs, {} outputs -> {}\n",
                 options.clamped ? "clamped at x = 0" : "free", m.K.rows(), m.K.nonZeros(),
                 m.M.nonZeros(), m.inputs(), m.outputs(), argv[5]);
      return 0;
    }
    return usage(argv[0]);
  } catch (const std::exception& e) {
    fmt::print(stderr, "ecmor_bench_models: {}\n", e.what());
    return 1;
  }
}
