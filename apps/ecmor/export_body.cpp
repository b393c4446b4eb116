// `ecmor export-body RUN_DIR`: the reduced elastic body of a finished `ecmor reduce` run as a
// SID file, JSON and .mat (docs/multibody.md). Reads the run and its model directory, calls the
// core (flexible_body.hpp, sid.hpp), prints what was written. No numerics here beyond comparing
// W' M V with the run's Mr.
#include <fmt/core.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "commands.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/body/flexible_body.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model_io.hpp"

namespace ecmor::app {
namespace {

namespace fs = std::filesystem;

/// The model directory recorded in RUN_DIR/summary.json (model.dir).
fs::path run_model_dir(const fs::path& run_dir) {
  const fs::path path = run_dir / "summary.json";
  std::ifstream in(path);
  if (!in)
    throw InputError(
        fmt::format("{}: missing: RUN_DIR must be the output directory of a "
                    "finished `ecmor reduce` run",
                    path.string()));
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: not readable as JSON ({})", path.string(), e.what()));
  }
  // The mass invariants need the node positions and the DOF map, which only a model directory
  // carries (a .mat model file has the matrices alone).
  const std::string need =
      "export-body needs a model directory (M, D, K, B, C .mtx with nodes.csv and dofs.csv: the "
      "node positions and the DOF map of the mass invariants; `ecmor import calculix` writes one, "
      "docs/import-calculix.md)";
  const nlohmann::json* model =
      j.is_object() && j.contains("model") && j.at("model").is_object() ? &j.at("model") : nullptr;
  if (model != nullptr && model->contains("dir") && model->at("dir").is_string()) {
    fs::path dir = model->at("dir").get<std::string>();
    if (dir.is_relative() && !fs::exists(dir)) dir = run_dir / dir;
    return dir;
  }
  if (model != nullptr && model->contains("file") && model->at("file").is_string()) {
    throw InputError(
        fmt::format("run {}: its model was read from the file {}, not from a model "
                    "directory; {}; reduce that model directory instead",
                    run_dir.string(), model->at("file").get<std::string>(), need));
  }
  throw InputError(fmt::format("run {}: {} names no model directory (model.dir); {}",
                               run_dir.string(), path.string(), need));
}

SecondOrderModel second_order(Model model, const fs::path& dir) {
  if (!std::holds_alternative<SecondOrderModel>(model))
    throw InputError(
        fmt::format("{}: a descriptor model: a multibody body needs the "
                    "second-order model M, D, K",
                    dir.string()));
  return std::get<SecondOrderModel>(std::move(model));
}

FeGeometry geometry_of(const fs::path& dir, Index size) {
  auto g = read_fe_geometry(dir, size);
  if (!g)
    throw InputError(
        fmt::format("{}: no nodes.csv and dofs.csv: the mass invariants need the "
                    "node positions and the DOF map (docs/import-calculix.md)",
                    dir.string()));
  return std::move(*g);
}

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

int export_body(const ExportBodyOptions& o, const CommonOptions& common) {
  return guarded([&] {
    const fs::path model_dir = run_model_dir(o.run_dir);
    BodyModel body;
    SecondOrderModel model = second_order(load_model(model_dir), model_dir);
    body.geometry = geometry_of(model_dir, model.size());
    ProjectionBases bases = read_projection_bases(o.run_dir);
    if (bases.V.rows() != model.size() || bases.W.rows() != model.size())
      throw InputError(
          fmt::format("{}: the bases have {} rows, but the model has N = {}: the run's basis is "
                      "not one of the second-order model's coordinates",
                      o.run_dir.string(), bases.V.rows(), model.size()));
    body.V = std::move(bases.V);
    body.W = std::move(bases.W);
    if (!o.mass_model_dir.empty()) {
      SecondOrderModel mm = second_order(load_model(o.mass_model_dir), o.mass_model_dir);
      body.mass_model = MassModel{geometry_of(o.mass_model_dir, mm.size()), std::move(mm.M)};
    }
    body.M = model.M;
    body.D = model.D;
    body.K = model.K;

    // W' M V, W' D V, W' K V must be the run's Mr, Dr, Kr: else the model directory or the
    // bases changed after the run, and the body would not be the reduced model that was checked.
    const ReducedModel rom = read_reduced_model(o.run_dir);
    if (!std::holds_alternative<ReducedSecondOrderModel>(rom))
      throw InputError(
          fmt::format("{}: the reduced model is first order: a multibody body "
                      "needs a second-order reduced model",
                      o.run_dir.string()));
    const auto& r = std::get<ReducedSecondOrderModel>(rom);
    const double dM = reduced_difference(body.W, body.M, body.V, r.M);
    const double dD = reduced_difference(body.W, body.D, body.V, r.D);
    const double dK = reduced_difference(body.W, body.K, body.V, r.K);
    constexpr double kAgreement = 1e-10;
    if (!(std::max({dM, dD, dK}) <= kAgreement))
      throw InputError(fmt::format(
          "{}: W' M V, W' D V, W' K V differ from the run's Mr, Dr, Kr by {:.3g}, {:.3g}, "
          "{:.3g} (relative, max entry; must be <= {:g}): the model directory {} or the bases "
          "changed after the run",
          o.run_dir.string(), dM, dD, dK, kAgreement, model_dir.string()));

    // A free-floating body: the frame carries the rigid-body motion, the coordinates the rest.
    const RigidBodyModes rigid = rigid_body_modes(Model(model));
    if (!rigid.decided || rigid.indefinite)
      throw InputError(
          fmt::format("{}: no rigid-body analysis of K ({}): a multibody body needs a "
                      "symmetric positive semidefinite K and a positive definite M",
                      model_dir.string(), rigid.method));
    const ElasticBases elastic = elastic_bases(body, rigid.count);
    const Index run_order = body.V.cols();
    body.V = elastic.V;
    body.W = elastic.W;
    const BodyInvariants inv = compute_body_invariants(body);

    SidExportOptions so;
    so.name = model_dir.filename().string();
    so.header_comment = fmt::format("SID generated by ecmor from {}", o.run_dir.string());
    so.ielastq = coordinate_names(inv);
    if (o.all_nodes) {
      for (const FeNode& p : body.geometry.nodes) so.frame_nodes.push_back(p.id);
    } else {
      so.frame_nodes = interface_nodes(model, body.geometry);
    }
    const SidBody sid = to_sid(inv, body.geometry, body.V, so);
    const fs::path sid_path = o.output.empty() ? o.run_dir / "body.SID_FEM" : o.output;
    fs::path json_path = sid_path, mat_path = sid_path;
    json_path.replace_extension(".json");
    mat_path.replace_extension(".mat");
    write_sid(sid_path, sid);
    write_body_json(json_path, inv, sid, elastic);
    write_body_mat(mat_path, inv, sid, elastic);

    if (!common.quiet) {
      fmt::print("model    {} (N = {}), {} constrained DOFs in the mass model\n",
                 model_dir.string(), model.size(), inv.constrained_dofs);
      fmt::print("mass     {:.10g}\n", inv.mass);
      fmt::print("c        ({:.6g}, {:.6g}, {:.6g})\n", inv.mc.a0(0) / inv.mass,
                 inv.mc.a0(1) / inv.mass, inv.mc.a0(2) / inv.mass);
      fmt::print("J        xx {:.6g}  yy {:.6g}  zz {:.6g}  xy {:.6g}  xz {:.6g}  yz {:.6g}\n",
                 inv.J.a0(0, 0), inv.J.a0(1, 1), inv.J.a0(2, 2), inv.J.a0(0, 1), inv.J.a0(0, 2),
                 inv.J.a0(1, 2));
      fmt::print("check    W'MV, W'DV, W'KV vs the run's Mr, Dr, Kr: {:.2g}, {:.2g}, {:.2g}\n", dM,
                 dD, dK);
      if (elastic.free_motions > 0)
        fmt::print(
            "free     {} rigid-body motions move the body frame: {} of the run's {} coordinates "
            "were rigid-body motions and are left out; the other {} have their rigid part "
            "removed (mean axes: C_t = 0)\n",
            elastic.free_motions, elastic.removed, run_order, inv.Me.rows());
    }
    if (inv.missing_translations > 0)
      fmt::print(stderr,
                 "ecmor: warning: the mass model lacks {} translational DOFs of its nodes "
                 "(constrained): m, c and J miss their mass; give --mass-model DIR, the same "
                 "mesh without boundary conditions\n",
                 inv.missing_translations);
    if (inv.vw_coupling_difference > 1e-8)
      fmt::print(stderr,
                 "ecmor: warning: W != V: the couplings ^vC and ^wC differ by {:.3g} "
                 "(relative); the SID file holds ^wC (elastic rows), the JSON and .mat both\n",
                 inv.vw_coupling_difference);
    fmt::print("wrote {}, {} and {}: n = {} coordinates, {} frame nodes, m = {:.10g}\n",
               sid_path.string(), json_path.string(), mat_path.string(), inv.Me.rows(),
               sid.frame.size(), inv.mass);
    return 0;
  });
}

}  // namespace ecmor::app
