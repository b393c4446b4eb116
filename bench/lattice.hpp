#pragma once
/// \file lattice.hpp
/// Generator of the 3-D lattice of `ecmor_bench_models grid NX NY NZ DIR`: a second-order model
/// with the sparsity of a hexahedral FE mesh and one degree of freedom per node.
///
/// One displacement per node of an NX x NY x NZ lattice of spacing h = 1, the 7-point stiffness of
/// a scalar elastic continuum (k = 1e4 between neighbours), lumped masses (m = 1), the face x = 0
/// held by springs of k to the ground, Rayleigh damping D = 0.01 M + 1e-5 K, a force at the far
/// corner (NX-1, NY-1, NZ-1) and two outputs: the displacements at that corner and at the centre
/// of the far face (NX-1, NY/2, NZ/2). Node (i, j, k) is degree of freedom i + NX (j + NY k)
/// (0-based). The factors' fill grows like a 3-D mesh's (nested dissection: O(N^(4/3)) for a
/// cube, less for a thin plate NZ << NX, NY).
///
/// The eigenfrequencies are separable: omega^2 = k (lx + ly + lz) with ly (lz) the eigenvalues of
/// the free-free chain Laplacian of NY (NZ) nodes, 4 sin^2(j pi / (2 NY)), and lx those of the NX
/// chain grounded at its first node. The lowest is about 100 pi / (2 NX + 1) rad/s.

#include "ecmor/base/types.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::bench {

/// The lattice model of the file comment, N = nx ny nz.
/// \throws ConfigError "grid: N = ... is too large" when N > 2e8 (or a size < 1).
SecondOrderModel lattice(Index nx, Index ny, Index nz);

}  // namespace ecmor::bench
