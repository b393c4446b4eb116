#pragma once
/// \file flexible_body.hpp
/// The reduced elastic body of the seed's Eq. 5: the mass invariants of the floating frame of
/// reference formulation (Wallrapp 1994; Schwertassek & Wallrapp 1999, ch. 6; Shabana 2005, ch. 5)
/// computed from a finite-element model (nodes, DOF map, M, D, K) and the projection bases V, W
/// of a reduction. docs/multibody.md derives every formula; the notation here follows it.
///
/// Position of a material point in the body frame: r = R + u, R its undeformed position, u the
/// elastic displacement. Displacements are interpolated by the finite element shape functions, so
/// every integral below is one of the form  int u . v dm = u' M v  for two fields u, v of the FE
/// space (the consistent mass matrix is the Gram matrix of the shape functions under the mass
/// measure): the rigid motions (translations e_a, rotations e_a x R, exactly in the space of
/// isoparametric elements) and cross products of FE fields with constant vectors are such fields.
/// Elastic shapes are the columns phi_k of S_el = T_BC V (displacement ansatz u = S_el q) and the
/// test functions psi_k the columns of S_rl = T_BC W (the elastic equations are projected on W).
/// T_BC puts each row of the model into the row of the same (node, direction) of the mass model;
/// rows the model lacks (constrained by boundary conditions) stay zero.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/interop/export.hpp"
#include "ecmor/interop/fe_geometry.hpp"
#include "ecmor/interop/sid.hpp"

namespace ecmor {

/// A matrix with its term linear in the elastic coordinates: A(q) = a0 + sum_k a1[k] q_k.
/// a1 is empty for a constant matrix, else it has one matrix of a0's size per coordinate.
struct TaylorMatrix {
  Matrix a0;
  std::vector<Matrix> a1;
};

/// The mass model the rigid-body invariants (m, c, J and the rigid rows of C_t, C_r) are taken
/// from. The model's own M lacks the mass of degrees of freedom fixed by boundary conditions
/// (CalculiX drops their rows); the same mesh imported without the boundary conditions supplies
/// it. Its geometry must contain every (node, direction) of the model.
struct MassModel {
  FeGeometry geometry;
  SparseMatrix M;
};

/// Inputs of compute_body_invariants().
struct BodyModel {
  FeGeometry geometry;   ///< nodes and DOF map of the model (validated against M's size)
  SparseMatrix M, D, K;  ///< the full model's matrices (D may be empty: D = 0)
  Matrix V, W;           ///< projection bases, N x n each (W = V for a Galerkin projection)
  /// Unset: the model's M is the mass model (right for a model without boundary conditions).
  std::optional<MassModel> mass_model;
};

/// The mass invariants of seed Eq. 5 (units: those of the model; mass [kg] when M is in kg).
/// Directions a, b = x, y, z are indices 0, 1, 2. The six-component symmetric layout
/// (xx, yy, zz, xy, xz, yz) of J and the (xx, yy, zz, xy, yz, xz) layout of the centrifugal
/// matrix are those of FEMBS's SID files (docs/multibody.md, "SID layout").
struct BodyInvariants {
  double mass = 0.0;                          ///< m = int dm
  std::array<double, 3> mass_by_direction{};  ///< e_a' M e_a: equal to m for a complete mass model
  /// m c(q) = int r dm: mc.a0 (3 x 1) = int R dm, mc.a1[k] (3 x 1) = int phi_k dm.
  TaylorMatrix mc;
  /// J(q) = int r~' r~ dm (about the body frame's origin, tensor entries, J_xy = -int x y dm):
  /// J.a0 (3 x 3), J.a1[k] (3 x 3) = int (u_k~' R~ + R~' u_k~) dm with u_k = phi_k.
  TaylorMatrix J;
  /// C_t = int S' dm (n x 3): row k, column a = int s_k . e_a dm; "v" with s = phi (rigid-body
  /// rows of Eq. 5, ^vC_t' V), "w" with s = psi (elastic rows, W' ^wC_t). Constant in q.
  Matrix Ct_v, Ct_w;
  /// C_r(q) = int S' r~' dm (n x 3): row i, column a = int s_i . (e_a x r) dm; the linear term
  /// a1[k] row i, column a = int s_i . (e_a x phi_k) dm.
  TaylorMatrix Cr_v, Cr_w;
  /// Gyroscopic matrices of the rotational equations, one 3 x 3 per elastic coordinate (order
  /// 0): Gr[k] = -2 C4_k with C4_k = int R~ phi_k~ dm; the rotational equations hold
  /// sum_k Gr[k] omega q'_k. Note J.a1[k] = (Gr[k] + Gr[k]') / 2.
  std::vector<Eigen::Matrix3d> Gr;
  /// Gyroscopic matrices of the elastic equations, one n x 3 per elastic coordinate:
  /// Ge[k] = 2 Cr_w.a1[k]; the elastic equations hold sum_k Ge[k] omega q'_k (from int psi .
  /// 2 omega x u' dm).
  std::vector<Matrix> Ge;
  /// Centrifugal matrix of the elastic equations (n x 6, columns xx, yy, zz, xy, yz, xz):
  /// row i = int psi_i . omega~ omega~ r dm as coefficients of (wx^2, wy^2, wz^2, wx wy, wy wz,
  /// wx wz); a0 with r = R, a1[k] with r = phi_k.
  TaylorMatrix Oe;
  Matrix Me, De, Ke;  ///< W' M V, W' D V, W' K V (model's matrices; n x n)
  /// Degrees of freedom of the mass model that the model lacks (constrained; zero in S_el).
  Index constrained_dofs = 0;
  /// Translational DOFs of the model's nodes that neither the model nor the mass model holds:
  /// nonzero means m, c, J miss the mass of those DOFs (no mass model was given for a model with
  /// boundary conditions). Counted over (node, direction) pairs of nodes that appear in dofs.csv.
  Index missing_translations = 0;
  /// max over the entries of |^vC - ^wC| / max(|^vC|, |^wC|) (0 for W = V): how far the rigid
  /// and the elastic rows of Eq. 5 differ; the SID file can hold one of them only.
  double vw_coupling_difference = 0.0;
};

/// Computes the invariants (see the file comment and docs/multibody.md).
/// \throws InputError when the geometry does not fit M (validate()), V or W do not have N rows or
///         differ in width, D or K are not N x N, the mass model's geometry lacks a (node,
///         direction) of the model, or a mass model's node has other coordinates than the model's.
ECMOR_INTEROP_API BodyInvariants compute_body_invariants(const BodyModel& body);

/// The bases of a body whose elastic coordinates exclude the rigid-body motion (elastic_bases()).
struct ElasticBases {
  Matrix V, W;  ///< N x n_el: the bases with the free rigid-body motions removed
  /// n x n_el: V = P V_run T, W = P W_run T, where P x = x - R R' M x removes the M-orthogonal
  /// component in the free rigid-body motions R (M-orthonormal, N x free_motions).
  Matrix T;
  /// Rigid-body motions moved to the body frame: the rigid_modes of elastic_bases() (6 for a
  /// free-floating solid, 0 for a clamped one).
  Index free_motions = 0;
  /// Run coordinates dropped because span V contained a rigid-body motion (to 1e-6 of its
  /// M-norm): n_el = n - removed.
  Index removed = 0;
};

/// The elastic coordinates of a free-floating body. In the floating frame of reference the body
/// frame carries the rigid-body motion, so the displacement ansatz S_el must not: a rigid motion
/// in both would make the multibody equations singular. `rigid_modes` is the dimension of the
/// null space of K, decided by rigid_body_modes(const Model&) (rigid_body.hpp): its Cholesky and
/// gap tests, not a threshold here, tell a free body from a clamped one whose restricted rigid
/// motions are merely soft. The free rigid-body motions R are the `rigid_modes` combinations of
/// the six rigid motions of `body.geometry` (restricted to the model's rows, M-orthonormal) of
/// least strain energy. Their M-orthogonal component is removed from V and W (the Tisserand /
/// Buckens mean-axis condition: the elastic coordinates then have ᵛC_t = 0 and ᵛC_r(0) = 0), and
/// the directions of span V that were rigid motions are dropped. For a Galerkin basis (W == V)
/// the coordinates are then rotated to the eigenvectors of the reduced elastic pencil (Me = I, Ke
/// diagonal): a modal run keeps its elastic modes. rigid_modes = 0 returns V, W unchanged and
/// T = I.
/// \throws InputError for the cases of compute_body_invariants(); for a V that is rank deficient
///         in the mass inner product; when K's null space is not made of rigid motions of the
///         geometry (a mechanism, or more zero-energy modes than the geometry's rigid motions).
ECMOR_INTEROP_API ElasticBases elastic_bases(const BodyModel& body, Index rigid_modes);

/// The six rigid-body motions of a geometry as columns (N x 6): translations along x, y, z
/// (1 at the rows of that direction), then rotations about x, y, z (e_a x X at translational rows,
/// 1 at the rotational rows about a). Rows are those of `geometry.dofs` (1-based row r -> r - 1).
ECMOR_INTEROP_API Matrix rigid_body_modes(const FeGeometry& geometry);

/// What to_sid() puts into the file besides the invariants.
struct SidExportOptions {
  std::string name = "ecmor";          ///< `new modal = name`
  std::string header_comment;          ///< the first line's comment
  std::vector<std::string> ielastq;    ///< one text per elastic coordinate (empty: generated)
  std::vector<long long> frame_nodes;  ///< node ids written to the frame, in this order
};

/// Arranges the invariants as a SID body (docs/multibody.md, "What the SID file holds"): the
/// rigid-body rows' terms from the displacement basis V (mdCM, J, Gr), the elastic rows' terms
/// from the test basis W (Ct, Cr, Ge, Oe; Me, Ke, De = W' M V, W' K V, W' D V), ksigma zero (no
/// reference stresses), and per frame node its position, the translations (phi) and rotations
/// (psi, zero for nodes without rotational degrees of freedom) of the columns of V, AP = I +
/// sum_k psi_k~ q_k. \throws InputError for a frame node the geometry does not have, or
/// `ielastq` of the wrong length.
ECMOR_INTEROP_API SidBody to_sid(const BodyInvariants& invariants, const FeGeometry& geometry,
                                 const Matrix& V, const SidExportOptions& options);

/// Writes the invariants (both the V and the W variants of C_t and C_r), the frame nodes of
/// `sid`, the reduced matrices and how the body's coordinates relate to the run's (`coordinates`:
/// free_motions, removed, T) as JSON (docs/multibody.md, "The JSON file"), atomically.
/// \throws IoError.
ECMOR_INTEROP_API void write_body_json(const std::filesystem::path& path,
                                       const BodyInvariants& invariants, const SidBody& sid,
                                       const ElasticBases& coordinates);

/// The same data as write_body_json() as a MAT v5 file of dense double variables, atomically
/// (docs/multibody.md, "The .mat file"). A term linear in the n coordinates is one variable whose
/// blocks for q_1 .. q_n stand side by side: J1 is 3 x 3n, and reshape(J1, 3, 3, n) gives
/// J1(:, :, k) in MATLAB. \throws IoError; NumericalError for a non-finite entry.
ECMOR_INTEROP_API void write_body_mat(const std::filesystem::path& path,
                                      const BodyInvariants& invariants, const SidBody& sid,
                                      const ElasticBases& coordinates);

/// The 6-component symmetric layout index pairs of J (xx, yy, zz, xy, xz, yz) and of Oe's columns
/// (xx, yy, zz, xy, yz, xz), FEMBS's orders (docs/multibody.md).
inline constexpr std::array<std::array<int, 2>, 6> kJPairs{
    {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}}};
inline constexpr std::array<std::array<int, 2>, 6> kOmegaPairs{
    {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {1, 2}, {0, 2}}};

}  // namespace ecmor
