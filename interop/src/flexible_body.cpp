// flexible_body.cpp: the mass invariants of seed Eq. 5 (flexible_body.hpp, docs/multibody.md).
// Every invariant is a mass-weighted inner product f' M g of two fields of the finite-element
// space. Nothing N x N is formed: the work is 3n + 6n + 9 sparse products with M for n elastic
// coordinates, and dense products of N x n blocks.
#include "ecmor/interop/flexible_body.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <unordered_map>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/model/model_io.hpp"

namespace ecmor {
namespace {

/// The translational rows of each node (0-based rows of the mass model, -1 where absent) and
/// its position.
struct NodeRows {
  std::array<Index, 3> rows{-1, -1, -1};
  Eigen::Vector3d X = Eigen::Vector3d::Zero();
};

std::unordered_map<long long, std::size_t> node_positions(const FeGeometry& g) {
  std::unordered_map<long long, std::size_t> at;
  for (std::size_t k = 0; k < g.nodes.size(); ++k) at.emplace(g.nodes[k].id, k);
  return at;
}

/// (node, direction) packed into one key; validate() bounds ids by 2^60, directions by 6.
long long dof_key(long long node, int direction) { return node * 8 + direction; }

std::vector<NodeRows> translational_rows(const FeGeometry& g) {
  const auto at = node_positions(g);
  std::vector<NodeRows> nodes(g.nodes.size());
  for (std::size_t k = 0; k < g.nodes.size(); ++k)
    nodes[k].X = Eigen::Vector3d(g.nodes[k].x, g.nodes[k].y, g.nodes[k].z);
  for (const FeDof& d : g.dofs)
    if (d.direction <= 3)
      nodes[at.at(d.node)].rows[static_cast<std::size_t>(d.direction - 1)] = d.row - 1;
  return nodes;
}

/// e_a x f node by node, f a field of the mass model's rows (its translational part; absent rows
/// read as zero); the result is zero at rotational rows.
Vector cross(int a, const Vector& f, const std::vector<NodeRows>& nodes) {
  Vector out = Vector::Zero(f.size());
  const Eigen::Vector3d e = Eigen::Vector3d::Unit(a);
  for (const NodeRows& p : nodes) {
    Eigen::Vector3d v;
    for (std::size_t d = 0; d < 3; ++d)
      v(static_cast<Index>(d)) = p.rows[d] >= 0 ? f(p.rows[d]) : 0.0;
    const Eigen::Vector3d w = e.cross(v);
    for (std::size_t d = 0; d < 3; ++d)
      if (p.rows[d] >= 0) out(p.rows[d]) = w(static_cast<Index>(d));
  }
  return out;
}

/// The undeformed position field R (X at translational rows, 0 at rotational rows).
Vector position_field(const std::vector<NodeRows>& nodes, Index size) {
  Vector R = Vector::Zero(size);
  for (const NodeRows& p : nodes)
    for (std::size_t d = 0; d < 3; ++d)
      if (p.rows[d] >= 0) R(p.rows[d]) = p.X(static_cast<Index>(d));
  return R;
}

/// The centrifugal field of pair c = (a, b) of kOmegaPairs: e_a x (e_a x f) for a == b, else
/// e_a x (e_b x f) + e_b x (e_a x f): the coefficient of w_a w_b in omega x (omega x f).
Vector centrifugal_field(std::size_t c, const Vector& f, const std::vector<NodeRows>& nodes) {
  const int a = kOmegaPairs[c][0], b = kOmegaPairs[c][1];
  if (a == b) return cross(a, cross(a, f, nodes), nodes);
  return cross(a, cross(b, f, nodes), nodes) + cross(b, cross(a, f, nodes), nodes);
}

void check_square(const SparseMatrix& A, const char* name, Index n) {
  if (A.rows() != n || A.cols() != n)
    throw InputError(fmt::format("flexible body: {} is {} x {}: must be N x N = {} x {}", name,
                                 A.rows(), A.cols(), n, n));
}

double max_abs(const Matrix& A) { return A.size() == 0 ? 0.0 : A.cwiseAbs().maxCoeff(); }

}  // namespace

Matrix rigid_body_modes(const FeGeometry& g) {
  const auto at = node_positions(g);
  Matrix G = Matrix::Zero(static_cast<Index>(g.dofs.size()), 6);
  for (const FeDof& d : g.dofs) {
    const Index r = d.row - 1;
    if (d.direction <= 3) {
      const FeNode& p = g.nodes[at.at(d.node)];
      const Eigen::Vector3d X(p.x, p.y, p.z);
      const int c = d.direction - 1;
      G(r, c) = 1.0;
      for (int a = 0; a < 3; ++a) G(r, 3 + a) = Eigen::Vector3d::Unit(a).cross(X)(c);
    } else {
      G(r, 3 + d.direction - 4) = 1.0;
    }
  }
  return G;
}

namespace {

/// The shapes both compute_body_invariants() and elastic_bases() rely on.
void check_body(const BodyModel& body) {
  const Index N = body.M.rows();
  validate(body.geometry, N, "flexible body: model geometry");
  check_square(body.M, "M", N);
  check_square(body.K, "K", N);
  if (body.D.size() != 0) check_square(body.D, "D", N);
  const Index n = body.V.cols();
  if (body.V.rows() != N || body.W.rows() != N || body.W.cols() != n)
    throw InputError(
        fmt::format("flexible body: V is {} x {}, W is {} x {}: both must be N x n with N = {}",
                    body.V.rows(), body.V.cols(), body.W.rows(), body.W.cols(), N));
}

/// An orthonormal eigenbasis of the symmetric positive semidefinite G scaled by the inverse
/// square roots of the eigenvalues above `floor` times the largest: X' G X = I on the range of G.
Matrix inverse_root_basis(const Matrix& G, double floor) {
  const Eigen::SelfAdjointEigenSolver<Matrix> eig(0.5 * (G + G.transpose()));
  const Vector& lambda = eig.eigenvalues();
  const double top = lambda.size() > 0 ? lambda.maxCoeff() : 0.0;
  std::vector<Index> kept;
  for (Index i = 0; i < lambda.size(); ++i)
    if (top > 0.0 && lambda(i) > floor * top) kept.push_back(i);
  Matrix X(G.rows(), static_cast<Index>(kept.size()));
  for (std::size_t j = 0; j < kept.size(); ++j)
    X.col(static_cast<Index>(j)) = eig.eigenvectors().col(kept[j]) / std::sqrt(lambda(kept[j]));
  return X;
}

}  // namespace

ElasticBases elastic_bases(const BodyModel& body, Index rigid_modes) {
  check_body(body);
  const Index n = body.V.cols();
  ElasticBases out{body.V, body.W, Matrix::Identity(n, n), 0, 0};
  if (rigid_modes <= 0) return out;

  // The rigid motions the model's rows can represent, M-orthonormal (a planar model has fewer
  // than six), and among their combinations the rigid_modes of least strain energy. For a free
  // body those are annihilated by K up to rounding; a larger Rayleigh quotient (above
  // kRigidCeiling of the spectrum scale, the bound of rigid_body_modes) means K's null space is
  // not made of rigid motions.
  const Matrix Gamma = rigid_body_modes(body.geometry);
  const Matrix G1 = Gamma * inverse_root_basis(Gamma.transpose() * (body.M * Gamma), 1e-12);
  const Matrix KG = G1.transpose() * (body.K * G1);
  const Eigen::SelfAdjointEigenSolver<Matrix> stiffness(0.5 * (KG + KG.transpose()));
  double scale = 0.0;
  for (Index i = 0; i < body.M.rows(); ++i)
    if (body.M.coeff(i, i) > 0.0) scale = std::max(scale, body.K.coeff(i, i) / body.M.coeff(i, i));
  const Vector& energy = stiffness.eigenvalues();  // ascending
  if (rigid_modes > G1.cols() || !(std::abs(energy(rigid_modes - 1)) <= kRigidCeiling * scale))
    throw InputError(fmt::format(
        "flexible body: K has {} rigid-body modes, but only {} of the {} rigid motions of the "
        "geometry are free (Rayleigh quotients {:.3g} relative to max K_ii / M_ii, at most {:g} "
        "for a free motion): a mechanism or a model whose nodes.csv does not fit K",
        rigid_modes, (energy.array().abs() <= kRigidCeiling * scale).count(), G1.cols(),
        rigid_modes <= G1.cols() ? std::abs(energy(rigid_modes - 1)) / scale : 0.0, kRigidCeiling));
  out.free_motions = rigid_modes;
  const Matrix R = G1 * stiffness.eigenvectors().leftCols(rigid_modes);
  const Matrix MR = body.M * R;

  // V M-orthonormal (V Z), then its rigid content R' M V Z = U S Y': a singular value of 1 is a
  // rigid motion inside span V. Dropping those directions (columns of Y) and removing the rigid
  // component of the rest leaves n - removed independent elastic directions: a kept direction
  // has at least kContained of its M-norm outside the rigid motions.
  constexpr double kContained = 1e-6;
  const Matrix Z = inverse_root_basis(body.V.transpose() * (body.M * body.V), 1e-14);
  if (Z.cols() < n)
    throw InputError(fmt::format(
        "flexible body: V has rank {} of {} columns in the mass inner product (V' M V is "
        "singular): its columns must be independent displacement shapes",
        Z.cols(), n));
  const Matrix rigid_content = MR.transpose() * (body.V * Z);
  const Eigen::JacobiSVD<Matrix> svd(rigid_content, Eigen::ComputeFullV);
  std::vector<Index> kept;
  for (Index j = 0; j < n; ++j) {
    const double s = j < svd.singularValues().size() ? svd.singularValues()(j) : 0.0;
    if (std::sqrt(std::max(0.0, 1.0 - s * s)) >= kContained) kept.push_back(j);
  }
  out.removed = n - static_cast<Index>(kept.size());
  out.T.resize(n, static_cast<Index>(kept.size()));
  for (std::size_t j = 0; j < kept.size(); ++j)
    out.T.col(static_cast<Index>(j)) = Z * svd.matrixV().col(kept[j]);
  const auto without_rigid = [&](const Matrix& X) -> Matrix {
    return X - R * (MR.transpose() * X);
  };
  out.V = without_rigid(body.V * out.T);
  const bool galerkin = body.W.rows() == body.V.rows() && body.W == body.V;
  if (!galerkin) {
    out.W = without_rigid(body.W * out.T);
    return out;
  }
  // Galerkin: the eigenvectors of the elastic pencil, so that a modal run keeps its modes (mass
  // normalised, ascending frequency) and a Krylov run gets Ritz modes.
  const Matrix Me = out.V.transpose() * (body.M * out.V);
  const Matrix Ke = out.V.transpose() * (body.K * out.V);
  const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> modes(0.5 * (Ke + Ke.transpose()),
                                                               0.5 * (Me + Me.transpose()));
  if (modes.info() != Eigen::Success)
    throw NumericalError("flexible body: the elastic pencil (W' K V, W' M V) has no eigenbasis");
  out.T = out.T * modes.eigenvectors();
  out.V = out.V * modes.eigenvectors();
  out.W = out.V;
  return out;
}

BodyInvariants compute_body_invariants(const BodyModel& body) {
  check_body(body);
  const Index N = body.M.rows();
  const Index n = body.V.cols();

  const FeGeometry& mg = body.mass_model ? body.mass_model->geometry : body.geometry;
  const SparseMatrix& Mm = body.mass_model ? body.mass_model->M : body.M;
  const Index Nm = Mm.rows();
  if (body.mass_model) {
    check_square(Mm, "the mass model's M", Nm);
    validate(mg, Nm, "flexible body: mass model geometry");
  }

  // T_BC: model row -> mass model row of the same (node, direction).
  std::unordered_map<long long, Index> mass_row;
  for (const FeDof& d : mg.dofs) mass_row.emplace(dof_key(d.node, d.direction), d.row - 1);
  std::vector<Index> to_mass(static_cast<std::size_t>(N));
  for (const FeDof& d : body.geometry.dofs) {
    const auto it = mass_row.find(dof_key(d.node, d.direction));
    if (it == mass_row.end())
      throw InputError(fmt::format(
          "flexible body: the mass model has no row for node {}, direction {} (model row {}): "
          "it must hold every degree of freedom of the model",
          d.node, d.direction, d.row));
    to_mass[static_cast<std::size_t>(d.row - 1)] = it->second;
  }
  if (body.mass_model) {
    const auto at = node_positions(mg);
    for (const FeNode& p : body.geometry.nodes) {
      const auto it = at.find(p.id);
      if (it == at.end()) continue;
      const FeNode& q = mg.nodes[it->second];
      if (p.x != q.x || p.y != q.y || p.z != q.z)
        throw InputError(fmt::format(
            "flexible body: node {} is at ({:g}, {:g}, {:g}) in the model but at ({:g}, {:g}, "
            "{:g}) in the mass model: both must come from the same mesh",
            p.id, p.x, p.y, p.z, q.x, q.y, q.z));
    }
  }
  Matrix S_el = Matrix::Zero(Nm, n), S_rl = Matrix::Zero(Nm, n);
  for (Index r = 0; r < N; ++r) {
    S_el.row(to_mass[static_cast<std::size_t>(r)]) = body.V.row(r);
    S_rl.row(to_mass[static_cast<std::size_t>(r)]) = body.W.row(r);
  }

  BodyInvariants inv;
  inv.constrained_dofs = Nm - N;
  const std::vector<NodeRows> nodes = translational_rows(mg);
  for (const NodeRows& p : nodes)
    for (Index r : p.rows) inv.missing_translations += r < 0 ? 1 : 0;

  // Rigid-body mass matrix Gamma' M Gamma = [m I, m c~'; m c~, J] (docs/multibody.md).
  const Matrix Gamma = rigid_body_modes(mg);
  const Matrix MGamma = Mm * Gamma;
  const Matrix G = Gamma.transpose() * MGamma;
  for (int a = 0; a < 3; ++a) inv.mass_by_direction[static_cast<std::size_t>(a)] = G(a, a);
  inv.mass = (G(0, 0) + G(1, 1) + G(2, 2)) / 3.0;
  const Matrix Gtr = G.block(0, 3, 3, 3);  // m c~'
  inv.mc.a0 = Matrix(3, 1);
  inv.mc.a0 << 0.5 * (Gtr(1, 2) - Gtr(2, 1)), 0.5 * (Gtr(2, 0) - Gtr(0, 2)),
      0.5 * (Gtr(0, 1) - Gtr(1, 0));
  inv.J.a0 = G.block(3, 3, 3, 3);

  inv.Ct_v = S_el.transpose() * MGamma.leftCols(3);
  inv.Ct_w = S_rl.transpose() * MGamma.leftCols(3);
  inv.Cr_v.a0 = S_el.transpose() * MGamma.rightCols(3);
  inv.Cr_w.a0 = S_rl.transpose() * MGamma.rightCols(3);
  for (Index k = 0; k < n; ++k) inv.mc.a1.push_back(inv.Ct_v.row(k).transpose());

  // The terms linear in q: the fields e_a x phi_k (column 3k + a) and the rotations e_b x R.
  const Vector R = position_field(nodes, Nm);
  Matrix Rt(Nm, 3);
  for (int b = 0; b < 3; ++b) Rt.col(b) = cross(b, R, nodes);
  const Matrix MRt = Mm * Rt;
  Matrix rot_phi(Nm, 3 * n);
  for (Index k = 0; k < n; ++k)
    for (int a = 0; a < 3; ++a) rot_phi.col(3 * k + a) = cross(a, S_el.col(k), nodes);
  const Matrix M_rot_phi = Mm * rot_phi;
  const Matrix Cr1_v = S_el.transpose() * M_rot_phi;  // n x 3n
  const Matrix Cr1_w = S_rl.transpose() * M_rot_phi;
  const Matrix RtM_rot = MRt.transpose() * rot_phi;  // (b, 3k + a) = (e_b x R)' M (e_a x phi_k)
  for (Index k = 0; k < n; ++k) {
    inv.Cr_v.a1.push_back(Cr1_v.middleCols(3 * k, 3));
    inv.Cr_w.a1.push_back(Cr1_w.middleCols(3 * k, 3));
    inv.Ge.push_back(2.0 * inv.Cr_w.a1.back());
    // C4_k(b, a) = -(e_a x phi_k)' M (e_b x R); Gr_k = -2 C4_k; J1_k = -C4_k - C4_k'.
    const Eigen::Matrix3d minus_C4 = RtM_rot.middleCols(3 * k, 3);
    inv.Gr.push_back(2.0 * minus_C4);
    inv.J.a1.push_back(minus_C4 + minus_C4.transpose());
  }

  // Centrifugal terms: psi_i' M (omega x (omega x r)) by the pairs of kOmegaPairs.
  Matrix cR(Nm, 6);
  for (std::size_t c = 0; c < 6; ++c)
    cR.col(static_cast<Index>(c)) = centrifugal_field(c, R, nodes);
  inv.Oe.a0 = S_rl.transpose() * (Mm * cR);
  Matrix cPhi(Nm, 6 * n);
  for (Index k = 0; k < n; ++k)
    for (std::size_t c = 0; c < 6; ++c)
      cPhi.col(6 * k + static_cast<Index>(c)) = centrifugal_field(c, S_el.col(k), nodes);
  const Matrix Oe1 = S_rl.transpose() * (Mm * cPhi);
  for (Index k = 0; k < n; ++k) inv.Oe.a1.push_back(Oe1.middleCols(6 * k, 6));

  // The reduced matrices, from the model's own (constrained) matrices: = Mr, Dr, Kr of the ROM.
  inv.Me = body.W.transpose() * (body.M * body.V);
  inv.Ke = body.W.transpose() * (body.K * body.V);
  inv.De = body.D.size() != 0 ? Matrix(body.W.transpose() * (body.D * body.V)) : Matrix::Zero(n, n);

  const double scale = std::max(
      {max_abs(inv.Ct_v), max_abs(inv.Ct_w), max_abs(inv.Cr_v.a0), max_abs(inv.Cr_w.a0), 1e-300});
  inv.vw_coupling_difference =
      std::max(max_abs(inv.Ct_v - inv.Ct_w), max_abs(inv.Cr_v.a0 - inv.Cr_w.a0)) / scale;
  return inv;
}

namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0.0, -v(2), v(1), v(2), 0.0, -v(0), -v(1), v(0), 0.0;
  return s;
}

SidMatrix constant(Matrix m0) {
  SidMatrix m;
  m.m0 = std::move(m0);
  return m;
}

SidMatrix linear(Matrix m0, std::vector<Matrix> m1) {
  SidMatrix m;
  m.order = 1;
  m.m0 = std::move(m0);
  m.m1 = std::move(m1);
  return m;
}

/// A 3 x 3 symmetric matrix as the 6 x 1 column (xx, yy, zz, xy, xz, yz) of SID's J.
Matrix six(const Matrix& A) {
  Matrix v(6, 1);
  for (std::size_t c = 0; c < 6; ++c) v(static_cast<Index>(c), 0) = A(kJPairs[c][0], kJPairs[c][1]);
  return v;
}

/// Per-coordinate blocks B_k (r x 3) side by side as SID's r x 3n layout: column a * n + k holds
/// B_k(:, a) (FEMBS's order: the direction outside, the coordinate inside).
template <class Block>
Matrix direction_major(const std::vector<Block>& blocks, Index rows) {
  const Index n = static_cast<Index>(blocks.size());
  Matrix out(rows, 3 * n);
  for (Index k = 0; k < n; ++k)
    for (Index a = 0; a < 3; ++a) out.col(a * n + k) = blocks[static_cast<std::size_t>(k)].col(a);
  return out;
}

nlohmann::json matrix_json(const Matrix& A) {
  nlohmann::json rows = nlohmann::json::array();
  for (Index i = 0; i < A.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (Index j = 0; j < A.cols(); ++j) row.push_back(A(i, j));
    rows.push_back(std::move(row));
  }
  return rows;
}

template <class M>
nlohmann::json list_json(const std::vector<M>& list) {
  nlohmann::json out = nlohmann::json::array();
  for (const M& a : list) out.push_back(matrix_json(a));
  return out;
}

nlohmann::json taylor_json(const TaylorMatrix& t) {
  return {{"a0", matrix_json(t.a0)}, {"a1", list_json(t.a1)}};
}

}  // namespace

SidBody to_sid(const BodyInvariants& inv, const FeGeometry& g, const Matrix& V,
               const SidExportOptions& options) {
  const Index n = inv.Me.rows();
  if (V.cols() != n || V.rows() != static_cast<Index>(g.dofs.size()))
    throw InputError(fmt::format("SID export: V is {} x {}: must be N x n = {} x {}", V.rows(),
                                 V.cols(), g.dofs.size(), n));
  if (!options.ielastq.empty() && static_cast<Index>(options.ielastq.size()) != n)
    throw InputError(fmt::format("SID export: {} ielastq texts for n = {} coordinates",
                                 options.ielastq.size(), n));
  SidBody sid;
  sid.name = options.name;
  sid.header_comment = options.header_comment;
  sid.mass = inv.mass;
  for (Index k = 0; k < n; ++k)
    sid.ielastq.push_back(options.ielastq.empty() ? fmt::format("ecmor coordinate {}", k + 1)
                                                  : options.ielastq[static_cast<std::size_t>(k)]);

  // Rows of each (node, direction) of the model.
  std::unordered_map<long long, Index> row;
  for (const FeDof& d : g.dofs) row.emplace(dof_key(d.node, d.direction), d.row - 1);
  const auto at = node_positions(g);
  for (long long id : options.frame_nodes) {
    const auto it = at.find(id);
    if (it == at.end())
      throw InputError(fmt::format("SID export: frame node {} is not a node of the model", id));
    const FeNode& p = g.nodes[it->second];
    Matrix phi = Matrix::Zero(3, n), psi = Matrix::Zero(3, n);
    for (int d = 0; d < 3; ++d) {
      if (auto r = row.find(dof_key(id, d + 1)); r != row.end()) phi.row(d) = V.row(r->second);
      if (auto r = row.find(dof_key(id, d + 4)); r != row.end()) psi.row(d) = V.row(r->second);
    }
    SidNode node;
    node.id = id;
    Matrix X(3, 1);
    X << p.x, p.y, p.z;
    std::vector<Matrix> origin1, ap1;
    for (Index k = 0; k < n; ++k) {
      origin1.push_back(phi.col(k));
      ap1.push_back(skew(psi.col(k)));
    }
    node.origin = linear(X, std::move(origin1));
    node.phi = constant(phi);
    node.psi = constant(psi);
    node.AP = linear(Matrix::Identity(3, 3), std::move(ap1));
    sid.frame.push_back(std::move(node));
  }

  std::vector<Matrix> J1;
  for (const Matrix& a : inv.J.a1) J1.push_back(six(a));
  std::vector<Matrix> Cr1(static_cast<std::size_t>(n));
  for (Index k = 0; k < n; ++k)
    Cr1[static_cast<std::size_t>(k)] = inv.Cr_w.a1[static_cast<std::size_t>(k)];
  sid.mdCM = linear(inv.mc.a0, inv.mc.a1);
  sid.J = linear(six(inv.J.a0), std::move(J1));
  sid.Ct = constant(inv.Ct_w);
  sid.Cr = linear(inv.Cr_w.a0, std::move(Cr1));
  sid.Me = constant(inv.Me);
  sid.Gr = constant(direction_major(inv.Gr, 3));
  sid.Ge = constant(direction_major(inv.Ge, n));
  sid.Oe = linear(inv.Oe.a0, inv.Oe.a1);
  sid.ksigma = constant(Matrix::Zero(n, 1));
  sid.Ke = constant(inv.Ke);
  sid.De = constant(inv.De);
  return sid;
}

void write_body_json(const std::filesystem::path& path, const BodyInvariants& inv,
                     const SidBody& sid, const ElasticBases& coordinates) {
  nlohmann::json j;
  j["mass"] = inv.mass;
  j["mass_by_direction"] = inv.mass_by_direction;
  j["mc"] = taylor_json(inv.mc);
  j["J"] = taylor_json(inv.J);
  j["Ct_v"] = matrix_json(inv.Ct_v);
  j["Ct_w"] = matrix_json(inv.Ct_w);
  j["Cr_v"] = taylor_json(inv.Cr_v);
  j["Cr_w"] = taylor_json(inv.Cr_w);
  j["Gr"] = list_json(inv.Gr);
  j["Ge"] = list_json(inv.Ge);
  j["Oe"] = taylor_json(inv.Oe);
  j["Me"] = matrix_json(inv.Me);
  j["De"] = matrix_json(inv.De);
  j["Ke"] = matrix_json(inv.Ke);
  j["constrained_dofs"] = inv.constrained_dofs;
  j["missing_translations"] = inv.missing_translations;
  j["vw_coupling_difference"] = inv.vw_coupling_difference;
  j["free_rigid_motions"] = coordinates.free_motions;
  j["removed_coordinates"] = coordinates.removed;
  j["T"] = matrix_json(coordinates.T);
  nlohmann::json nodes = nlohmann::json::array();
  for (const SidNode& p : sid.frame)
    nodes.push_back({{"id", p.id},
                     {"position", matrix_json(p.origin.m0)},
                     {"phi", matrix_json(p.phi.m0)},
                     {"psi", matrix_json(p.psi.m0)}});
  j["frame_nodes"] = std::move(nodes);
  j["ielastq"] = sid.ielastq;
  write_text_atomically(path, j.dump(1) + "\n");
}

namespace {

/// Blocks of equal shape side by side (block k in the k-th group of columns).
template <class Block>
Matrix side_by_side(const std::vector<Block>& blocks, Index rows, Index cols) {
  Matrix out(rows, cols * static_cast<Index>(blocks.size()));
  for (std::size_t k = 0; k < blocks.size(); ++k)
    out.middleCols(static_cast<Index>(k) * cols, cols) = blocks[k];
  return out;
}

Matrix scalar(double v) { return Matrix::Constant(1, 1, v); }

}  // namespace

void write_body_mat(const std::filesystem::path& path, const BodyInvariants& inv,
                    const SidBody& sid, const ElasticBases& coordinates) {
  const Index n = inv.Me.rows(), frames = static_cast<Index>(sid.frame.size());
  Matrix ids(frames, 1), positions(3, frames), phi(3, n * frames), psi(3, n * frames);
  for (Index f = 0; f < frames; ++f) {
    const SidNode& p = sid.frame[static_cast<std::size_t>(f)];
    ids(f, 0) = static_cast<double>(p.id);
    positions.col(f) = p.origin.m0;
    phi.middleCols(f * n, n) = p.phi.m0;
    psi.middleCols(f * n, n) = p.psi.m0;
  }
  write_mat_file(
      path,
      {
          {"mass", scalar(inv.mass)},
          {"mass_by_direction", Eigen::Map<const Matrix>(inv.mass_by_direction.data(), 1, 3)},
          {"mc0", inv.mc.a0},
          {"mc1", side_by_side(inv.mc.a1, 3, 1)},
          {"J0", inv.J.a0},
          {"J1", side_by_side(inv.J.a1, 3, 3)},
          {"Ct_v", inv.Ct_v},
          {"Ct_w", inv.Ct_w},
          {"Cr_v0", inv.Cr_v.a0},
          {"Cr_v1", side_by_side(inv.Cr_v.a1, n, 3)},
          {"Cr_w0", inv.Cr_w.a0},
          {"Cr_w1", side_by_side(inv.Cr_w.a1, n, 3)},
          {"Gr", side_by_side(inv.Gr, 3, 3)},
          {"Ge", side_by_side(inv.Ge, n, 3)},
          {"Oe0", inv.Oe.a0},
          {"Oe1", side_by_side(inv.Oe.a1, n, 6)},
          {"Me", inv.Me},
          {"De", inv.De},
          {"Ke", inv.Ke},
          {"constrained_dofs", scalar(static_cast<double>(inv.constrained_dofs))},
          {"free_rigid_motions", scalar(static_cast<double>(coordinates.free_motions))},
          {"removed_coordinates", scalar(static_cast<double>(coordinates.removed))},
          {"T", coordinates.T},
          {"frame_ids", ids},
          {"frame_positions", positions},
          {"frame_phi", phi},
          {"frame_psi", psi},
      },
      "ecmor reduced elastic body (seed Eq. 5)");
}

}  // namespace ecmor
