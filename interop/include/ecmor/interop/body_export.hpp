#pragma once
/// \file body_export.hpp
/// A reduction's result as a reduced elastic body for multibody simulation: the whole path from
/// the full second-order model, its FE geometry and a run's bases to the SID file, its JSON and
/// .mat companions (docs/multibody.md). What `ecmor export-body RUN_DIR` and the Python module's
/// ecmor.export_body do; they only differ in where the inputs come from.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "ecmor/interop/export.hpp"
#include "ecmor/interop/flexible_body.hpp"
#include "ecmor/interop/sid.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

struct BodyExportInput {
  SecondOrderModel model;  ///< the full model the run reduced
  FeGeometry geometry;     ///< its nodes and DOF map
  Matrix V, W;             ///< the run's bases, N x n
  /// The run's reduced matrices: W' M V, W' D V, W' K V are checked against them (they must agree
  /// to 1e-10 relative, else the model or the bases are not those of the run).
  ReducedSecondOrderModel reduced;
  std::optional<MassModel>
      mass_model;               ///< the mesh without boundary conditions (flexible_body.hpp)
  bool all_nodes = false;       ///< frame: every node (default: the nodes where B or C act)
  std::string name = "ecmor";   ///< `new modal = name` in the SID file
  std::string header_comment;   ///< its first line's comment
  std::string origin = "body";  ///< prefixes messages (a run directory, "ecmor.export_body")
};

struct BodyExport {
  BodyInvariants invariants;
  SidBody sid;
  ElasticBases elastic;  ///< the body's coordinates against the run's
  Index run_order = 0;   ///< n of the run's bases
  /// max |W' A V - Ar| / max |Ar| for A = M, D, K against the run's reduced matrices.
  double check_M = 0.0, check_D = 0.0, check_K = 0.0;
  /// Things the user must know (a mass model lacking DOFs, W != V couplings), one line each.
  std::vector<std::string> warnings;
};

/// Builds the body: checks the bases against the run's reduced matrices, decides the rigid-body
/// modes of K (a free-floating body's frame carries them: elastic_bases()), computes the mass
/// invariants of seed Eq. 5 and arranges them as a SID body.
/// \throws InputError naming `origin` and the rule broken: bases of another size than the model,
///         W' A V not the run's reduced matrices, no rigid-body analysis of K, and the cases of
///         compute_body_invariants(), elastic_bases() and to_sid().
ECMOR_INTEROP_API BodyExport export_body(const BodyExportInput& input);

/// The files of an export: the SID file at `sid_path` and the JSON and .mat files beside it (same
/// stem, extensions .json and .mat).
struct BodyFiles {
  std::filesystem::path sid, json, mat;
};
/// Writes them, each atomically. \throws IoError.
ECMOR_INTEROP_API BodyFiles write_body_files(const std::filesystem::path& sid_path,
                                             const BodyExport& body);

}  // namespace ecmor
