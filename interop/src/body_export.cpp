// body_export.cpp: see body_export.hpp. No numerics of its own beyond comparing W' A V with the
// run's reduced matrices; the invariants and the SID layout are flexible_body.cpp's and sid.cpp's.
#include "ecmor/interop/body_export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/rigid_body.hpp"

namespace ecmor {
namespace {

/// Nodes where an input acts or an output is observed (nonzero rows of B, columns of C): the
/// points where joints and force elements attach in the multibody model.
std::vector<long long> interface_nodes(const SecondOrderModel& m, const FeGeometry& g) {
  std::set<long long> seen;
  std::vector<long long> out;
  for (const FeDof& d : g.dofs) {
    const Index r = d.row - 1;
    const bool used = (m.B.row(r).array() != 0.0).any() || (m.C.col(r).array() != 0.0).any();
    if (used && seen.insert(d.node).second) out.push_back(d.node);
  }
  return out;
}

/// "mode k : f Hz" for a coordinate that Me and Ke decouple from all others (an eigenmode: its
/// row and column are zero to 1e-8 of the geometric mean of the diagonals; ARPACK's modes of the
/// calculix-beam example couple at 1.5e-10, a static correction at 3e-3), else "coordinate k"
/// (a Krylov vector, a static correction).
std::vector<std::string> coordinate_names(const BodyInvariants& inv) {
  const Index n = inv.Me.rows();
  auto decoupled = [&](const Matrix& A, Index k) {
    for (Index j = 0; j < n; ++j) {
      const double bound = 1e-8 * std::sqrt(std::abs(A(k, k) * A(j, j)));
      if (j != k && (std::abs(A(k, j)) > bound || std::abs(A(j, k)) > bound)) return false;
    }
    return true;
  };
  std::vector<std::string> names;
  for (Index k = 0; k < n; ++k) {
    const double ratio = inv.Ke(k, k) / inv.Me(k, k);
    const bool mode = decoupled(inv.Me, k) && decoupled(inv.Ke, k) && ratio >= 0.0;
    names.push_back(
        mode ? fmt::format("ecmor mode {} : {:.6g} Hz", k + 1, std::sqrt(ratio) / (2.0 * kPi))
             : fmt::format("ecmor coordinate {}", k + 1));
  }
  return names;
}

double relative_difference(const Matrix& a, const Matrix& b) {
  const double scale = std::max(a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff());
  return scale == 0.0 ? 0.0 : (a - b).cwiseAbs().maxCoeff() / scale;
}

/// max |W' A V - Ar| / max |Ar|, |W' A V| for the run's reduced matrix Ar (an empty Ar is zero).
double reduced_difference(const Matrix& W, const SparseMatrix& A, const Matrix& V,
                          const Matrix& Ar) {
  if (Ar.size() == 0 && A.nonZeros() == 0) return 0.0;
  const Matrix projected = W.transpose() * (A * V);
  return relative_difference(projected, Ar.size() == 0 ? Matrix::Zero(V.cols(), V.cols()) : Ar);
}

}  // namespace

BodyExport export_body(const BodyExportInput& in) {
  const SecondOrderModel& model = in.model;
  if (in.V.rows() != model.size() || in.W.rows() != model.size() || in.V.cols() != in.W.cols())
    throw InputError(
        fmt::format("{}: the bases are {} x {} and {} x {}, but the model has N = {}: the run's "
                    "basis is not one of the second-order model's coordinates",
                    in.origin, in.V.rows(), in.V.cols(), in.W.rows(), in.W.cols(), model.size()));
  BodyExport out;
  out.run_order = in.V.cols();
  // W' M V, W' D V, W' K V must be the run's Mr, Dr, Kr: else the model or the bases changed
  // after the run, and the body would not be the reduced model that was checked.
  out.check_M = reduced_difference(in.W, model.M, in.V, in.reduced.M);
  out.check_D = reduced_difference(in.W, model.D, in.V, in.reduced.D);
  out.check_K = reduced_difference(in.W, model.K, in.V, in.reduced.K);
  constexpr double kAgreement = 1e-10;
  if (!(std::max({out.check_M, out.check_D, out.check_K}) <= kAgreement))
    throw InputError(fmt::format(
        "{}: W' M V, W' D V, W' K V differ from the run's Mr, Dr, Kr by {:.3g}, {:.3g}, {:.3g} "
        "(relative, max entry; must be <= {:g}): the model or the bases changed after the run",
        in.origin, out.check_M, out.check_D, out.check_K, kAgreement));

  // A free-floating body: the frame carries the rigid-body motion, the coordinates the rest.
  const RigidBodyModes rigid = rigid_body_modes(Model(model));
  if (!rigid.decided || rigid.indefinite)
    throw InputError(
        fmt::format("{}: no rigid-body analysis of K ({}): a multibody body needs a symmetric "
                    "positive semidefinite K and a positive definite M",
                    in.origin, rigid.method));
  BodyModel body;
  body.geometry = in.geometry;
  body.M = model.M;
  body.D = model.D;
  body.K = model.K;
  body.V = in.V;
  body.W = in.W;
  body.mass_model = in.mass_model;
  out.elastic = elastic_bases(body, rigid.count);
  body.V = out.elastic.V;
  body.W = out.elastic.W;
  out.invariants = compute_body_invariants(body);

  SidExportOptions so;
  so.name = in.name;
  so.header_comment = in.header_comment;
  so.ielastq = coordinate_names(out.invariants);
  if (in.all_nodes) {
    for (const FeNode& p : body.geometry.nodes) so.frame_nodes.push_back(p.id);
  } else {
    so.frame_nodes = interface_nodes(model, body.geometry);
  }
  out.sid = to_sid(out.invariants, body.geometry, body.V, so);

  const BodyInvariants& inv = out.invariants;
  if (inv.missing_translations > 0)
    out.warnings.push_back(fmt::format(
        "the mass model lacks {} translational DOFs of its nodes (constrained): m, c and J miss "
        "their mass; give a mass model, the same mesh without boundary conditions",
        inv.missing_translations));
  if (inv.vw_coupling_difference > 1e-8)
    out.warnings.push_back(fmt::format(
        "W != V: the couplings ^vC and ^wC differ by {:.3g} (relative); the SID file holds ^wC "
        "(elastic rows), the JSON and .mat both",
        inv.vw_coupling_difference));
  return out;
}

BodyFiles write_body_files(const std::filesystem::path& sid_path, const BodyExport& body) {
  BodyFiles files{sid_path, sid_path, sid_path};
  files.json.replace_extension(".json");
  files.mat.replace_extension(".mat");
  write_sid(files.sid, body.sid);
  write_body_json(files.json, body.invariants, body.sid, body.elastic);
  write_body_mat(files.mat, body.invariants, body.sid, body.elastic);
  return files;
}

}  // namespace ecmor
