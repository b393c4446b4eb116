#pragma once
/// \file fe_geometry.hpp
/// The finite-element geometry a model directory may carry next to its matrices:
///
///   nodes.csv   header `node,x,y,z`:        one line per node (id > 0, finite coordinates)
///   dofs.csv    header `row,node,direction`: one line per row of M (1-based), the node it belongs
///               to and the direction: 1..3 translations x, y, z; 4..6 rotations about x, y, z
///
/// Both files or neither: a model without them is a plain matrix model. load_model() does not read
/// them (it looks at .mtx files only); tools that need node positions (importers, plots of mode
/// shapes) call read_fe_geometry(). Written by `ecmor import calculix` (calculix.hpp).

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/interop/export.hpp"

namespace ecmor {

/// A node of the mesh: its id (the label in the input deck) and position.
struct FeNode {
  long long id = 0;
  double x = 0.0, y = 0.0, z = 0.0;
};

/// What one row (and column) of M, D, K, the rows of B and the columns of C stand for.
struct FeDof {
  Index row = 0;       ///< 1-based row of M
  long long node = 0;  ///< FeNode::id
  int direction = 0;   ///< 1..3 translation x, y, z; 4..6 rotation about x, y, z
};

struct FeGeometry {
  std::vector<FeNode> nodes;  ///< in file order
  std::vector<FeDof> dofs;    ///< sorted by row: dofs[r - 1].row == r
};

/// The rules read_fe_geometry() applies, for geometry built in memory: N >= 1; node ids in 1..2^60
/// and unique; coordinates finite; exactly N dofs with rows 1..N each once (in any order:
/// `geometry` is taken as is and not sorted); directions 1..6; every dof's node among the nodes;
/// each (node, direction) pair at most once. `origin` prefixes the messages. \throws InputError
/// naming the row or node and the rule broken.
ECMOR_INTEROP_API void validate(const FeGeometry& geometry, Index model_size,
                                const std::string& origin);

/// Reads DIR/nodes.csv and DIR/dofs.csv and validates them against a model of size N =
/// `model_size` (the rules of validate()). Returns nothing when neither file is there.
/// \throws InputError "DIR/dofs.csv: line 7: row 3 given twice (first at line 5)", a malformed
///         line (wrong header, field count, a number that does not parse), one file without the
///         other, a rule of validate() broken (with the line of the offending entry).
ECMOR_INTEROP_API std::optional<FeGeometry> read_fe_geometry(const std::filesystem::path& dir,
                                                             Index model_size);

/// Writes DIR/nodes.csv and DIR/dofs.csv (atomically; coordinates in the shortest form that reads
/// back bitwise). Validates first: nothing is written for invalid geometry.
/// \throws InputError (validate()), IoError naming a file that cannot be written.
ECMOR_INTEROP_API void write_fe_geometry(const std::filesystem::path& dir,
                                         const FeGeometry& geometry);

}  // namespace ecmor
