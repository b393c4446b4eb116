#pragma once
/// \file solid.hpp
/// Generator of a 3-D linear-elastic solid: a box [0, lx] x [0, ly] x [0, lz] meshed with
/// nx x ny x nz equal 8-node tri-linear hexahedra (issue 26 item 5). Unlike the scalar lattice of
/// `ecmor_bench_models grid`, this is a finite-element model of a continuum: 3 displacement
/// degrees of freedom per node, bending, torsion and axial modes, a 3x3 block coupling between
/// all 27 neighbours of a node (the fill and the spectrum of a real structural model).
///
/// Element matrices (computed once: every element of a regular box mesh is the same), with the
/// shape functions N_l, l = 0..7, of the reference cube [-1, 1]^3 and 2x2x2 Gauss integration:
///   K_e[3l+c][3m+d] = int_e  lambda dN_l/dx_c dN_m/dx_d + mu dN_l/dx_d dN_m/dx_c
///                            + mu delta_cd grad N_l . grad N_m  dV        (isotropic elasticity)
///   M_e[3l+c][3m+d] = delta_cd int_e rho N_l N_m dV                        (consistent mass)
/// lambda = E nu / ((1 + nu)(1 - 2 nu)), mu = E / (2 (1 + nu)). Both integrands are polynomials of
/// degree <= 2 in each coordinate, so 2-point Gauss integration is exact (full integration; the
/// bending modes of coarse meshes are too stiff, shear locking, as with any fully integrated H8).
///   D = alpha M + beta K (Rayleigh).
///
/// Numbering. Node (i, j, k) sits at (i lx/nx, j ly/ny, k lz/nz), 0 <= i <= nx, 0 <= j <= ny,
/// 0 <= k <= nz. With i0 = 1 if clamped (the nodes of the face x = 0 are fixed and their degrees
/// of freedom eliminated) and i0 = 0 otherwise, the free nodes i >= i0 are numbered
///   n(i, j, k) = (i - i0) + (nx + 1 - i0) (j + (ny + 1) k)
/// and the displacement component c (0: x, 1: y, 2: z) of node n is degree of freedom 3 n + c
/// (0-based). N = 3 (nx + 1 - i0)(ny + 1)(nz + 1).
///
/// Inputs and outputs (1 N forces, displacements in m; nodes by their indices (i, j, k), so
/// (nx, ny, nz) is the corner (lx, ly, lz)). With the far-face centre node
/// Fc = (nx, ny/2, nz/2) and the mid-span centre node Mc = ((nx+1)/2, ny/2, nz/2) (integer
/// division; Mc is never on the clamped face, and is Fc when nx = 1), input q is a unit force,
/// column q of B, and output r is a displacement, row r of C, taken in this order:
///
///   | #  | input (force)                          | output (displacement)             |
///   |----|----------------------------------------|-----------------------------------|
///   | 0  | Fc, x (axial)                          | Fc, x                             |
///   | 1  | Fc, y (bending in the x-y plane)       | Fc, y                             |
///   | 2  | Fc, z (bending in the x-z plane)       | Fc, z                             |
///   | 3  | (nx, ny, nz), y (x-y bending, torsion) | (nx, ny, nz), y (sees torsion)    |
///   | 4  | (nx, ny, 0), z (x-z bending, torsion)  | Mc, y                             |
///   | 5  | (nx, 0, nz), x (eccentric axial)       | Mc, z                             |
///   | 6  | (nx, ny, nz), z                        | (nx, ny, nz), z                   |
///   | 7  | (nx, ny, nz), x                        | Mc, x                             |
///
/// All input (node, direction) pairs are distinct for every mesh (Fc is never one of the three
/// corners used). The default 4 inputs excite the axial, both bending and the torsion modes; the
/// default 6 outputs observe them. Cv is empty.

#include "ecmor/base/types.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::bench {

/// Rayleigh coefficients giving the modal damping ratio zeta at the two frequencies f_a and f_b
/// [Hz]: a mode of frequency f has zeta(f) = alpha / (4 pi f) + beta pi f, so
///   alpha = 4 pi zeta f_a f_b / (f_a + f_b) [1/s],   beta = zeta / (pi (f_a + f_b)) [s].
/// Between f_a and f_b the ratio dips to 2 zeta sqrt(f_a f_b) / (f_a + f_b) at sqrt(f_a f_b).
constexpr double rayleigh_alpha(double zeta, double f_a_hz, double f_b_hz) {
  return 4.0 * kPi * zeta * f_a_hz * f_b_hz / (f_a_hz + f_b_hz);
}
constexpr double rayleigh_beta(double zeta, double f_a_hz, double f_b_hz) {
  return zeta / (kPi * (f_a_hz + f_b_hz));
}

/// Largest number of inputs and of outputs (the rows of the table in the file comment).
constexpr Index kSolidMaxInputs = 8;
constexpr Index kSolidMaxOutputs = 8;
/// Largest number of mesh nodes (nx + 1)(ny + 1)(nz + 1): a degree of freedom couples to at most
/// 27 nodes x 3 components = 81, so nnz(K) <= 243 per node must fit 32-bit sparse indices.
constexpr double kSolidMaxNodes = 8837381.0;  // floor((2^31 - 1) / 243)

/// Options of solid(). Every field: meaning, unit, default, valid range (checked by validate()).
struct SolidOptions {
  /// Elements along x, y, z; each >= 1 and (nx + 1)(ny + 1)(nz + 1) <= kSolidMaxNodes.
  /// Default 20 x 2 x 1: cubic elements of 5 cm on the default box (N = 360 clamped).
  Index nx = 20;
  Index ny = 2;
  Index nz = 1;
  /// Box lengths [m], finite and > 0. Default: a steel bar 1.0 x 0.1 x 0.05. The section is not
  /// square on purpose: a square one gives equal bending frequencies in y and z (double
  /// eigenvalues), which would put pairs astride the edge of any band.
  double lx = 1.0;
  double ly = 0.1;
  double lz = 0.05;
  /// Young's modulus [Pa], finite and > 0. Default 2.1e11 (steel).
  double E = 2.1e11;
  /// Poisson ratio [-], 0 <= nu < 0.5. Default 0.3 (steel).
  double nu = 0.3;
  /// Density [kg/m^3], finite and > 0. Default 7850 (steel).
  double rho = 7850.0;
  /// Rayleigh damping D = alpha M + beta K: alpha [1/s] and beta [s], finite and >= 0.
  /// Default: zeta = 1 % at 40 Hz and 2000 Hz (rayleigh_alpha/beta: alpha = 4.93 1/s,
  /// beta = 1.56e-6 s). The default bar clamped at x = 0, meshed 140 x 14 x 7, has its first
  /// eigenfrequency at 42 Hz and its 10th and 11th at 1.81 and 2.21 kHz: the two points bracket
  /// the first ten modes, which get 0.95 % (42 Hz) ... 0.28 % (minimum, at 283 Hz) ... 0.91 %
  /// (1.81 kHz); above 2 kHz zeta grows like beta pi f.
  double alpha = rayleigh_alpha(0.01, 40.0, 2000.0);
  double beta = rayleigh_beta(0.01, 40.0, 2000.0);
  /// true (default): the face x = 0 is clamped, its nodes' degrees of freedom eliminated (K is
  /// positive definite). false: a free-floating body, K is singular with the 6 rigid-body modes
  /// (3 translations, 3 rotations) as its null space.
  bool clamped = true;
  /// Number of inputs, in [1, kSolidMaxInputs]; the first `inputs` rows of the table. Default 4.
  Index inputs = 4;
  /// Number of outputs, in [1, kSolidMaxOutputs]; the first `outputs` rows. Default 6.
  Index outputs = 6;

  /// \throws ConfigError naming field, value and rule ("SolidOptions::nu = 0.5: must be in
  ///         [0, 0.5)").
  void validate() const;
};

/// The solid model of the file comment: M, K symmetric (bit for bit) positive definite (K only
/// when clamped; M always), D = alpha M + beta K on the pattern of K (no stored entries when
/// alpha = beta = 0), B (N x inputs), C (outputs x N), Cv empty. The matrices are written column
/// by column straight into compressed storage, without triplets: memory O(nnz) = O(N), time a few
/// seconds for N = 1e6. M stores only the diagonal of its 3x3 node blocks (m_pq I).
/// \throws ConfigError from options.validate().
SecondOrderModel solid(const SolidOptions& options);

}  // namespace ecmor::bench
