#pragma once
/// \file calculix.hpp
/// Import of finite-element models from CalculiX (ccx 2.20, `apt-get install calculix-ccx`):
/// stiffness K and mass M as ccx assembles them, inputs and outputs on node sets of the deck, and
/// Rayleigh damping, written as an ecmor model directory (docs/import-calculix.md).
///
/// What ccx writes for `*FREQUENCY, SOLVER=MATRIXSTORAGE` (checked with ccx 2.20 and its source,
/// src/matrixstorage.c), and what the reader relies on:
///   jobname.sti, jobname.mas  one entry a line, `row column value` (1-based, value %20.13e, i.e.
///                             14 significant digits); the upper triangle only (row <= column) of
///                             the symmetric matrix, column by column, rows ascending within a
///                             column; explicit zeros occur (M's couplings between directions).
///   jobname.dof               one line per row, `node.direction` (direction 1..3 translations,
///                             4..6 rotations; 0 would be a thermal degree of freedom).
/// Degrees of freedom fixed by *BOUNDARY (and dependent ones of *EQUATION/MPCs) are not among the
/// rows: the matrices are those of the constrained structure. ccx stops after writing them.

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/interop/export.hpp"
#include "ecmor/interop/fe_geometry.hpp"

namespace ecmor {

/// What read_calculix_deck() takes from a CalculiX/Abaqus input deck.
struct CalculixDeck {
  std::filesystem::path path;
  std::vector<FeNode> nodes;  ///< *NODE, in deck order
  /// *NSET (also GENERATE, and *NODE, NSET=): upper-case name -> node ids in the order given,
  /// each once. Names are case-insensitive in CalculiX, as in Abaqus.
  std::map<std::string, std::vector<long long>> nsets;
  /// One per *STEP: its analysis keyword ("*FREQUENCY", "*STATIC", ...; "" if none) and where it
  /// is.
  struct Step {
    std::string procedure;
    bool matrix_storage = false;  ///< *FREQUENCY, SOLVER=MATRIXSTORAGE
    std::string location;         ///< "deck.inp: line 40"
  };
  std::vector<Step> steps;
  /// The deck's lines with every *INCLUDE replaced by the included file's lines (what ccx reads).
  std::vector<std::string> flattened;
};

/// Reads the deck at `path`: *NODE (id, x[, y[, z]], missing coordinates 0; parameter NSET; no
/// SYSTEM), *NSET (NSET=name; data lines of node ids or names of earlier sets; GENERATE: `first,
/// last[, increment]`), *INCLUDE (INPUT=file, relative to the including file; nested up to 16
/// deep), *STEP / *END STEP (the analysis keyword of each step). Every other keyword and its data
/// lines are kept for ccx without being interpreted. Lines starting with ** are comments; blank
/// lines are skipped.
/// \throws InputError "beam.inp: line 12: *NSET: node id 'x' is not an integer", and: data before
///         the first keyword, a node given twice, a set naming a node no *NODE defines (with the
///         line of the set), a set name never defined, GENERATE with an increment <= 0 or
///         first > last, *NODE, SYSTEM=..., *NSET without NSET=, *INCLUDE without INPUT= or of a
///         missing file, an *INCLUDE cycle, a *STEP without *END STEP, INPUT= on any other card
///         (ccx runs the deck elsewhere), a line longer than ccx's 132 columns.
ECMOR_INTEROP_API CalculixDeck read_calculix_deck(const std::filesystem::path& path);

/// K and M as ccx stored them, expanded to full symmetric matrices (exact zeros dropped), and the
/// meaning of each row.
struct CalculixMatrices {
  SparseMatrix K;
  SparseMatrix M;
  std::vector<FeDof> dofs;  ///< dofs[r].row == r + 1
};

/// Reads jobname.sti, jobname.mas and jobname.dof (formats above). N is the number of lines of
/// the .dof file.
/// \throws InputError naming file and line: a line that is not `row column value` (or
///         `node.direction`), an index outside 1..N, an entry below the diagonal (row > column)
///         or out of ccx's column-by-column order (also a repeated entry), a non-finite value, a
///         thermal degree of freedom (direction 0) or a direction > 6, an empty .dof file.
ECMOR_INTEROP_API CalculixMatrices read_calculix_matrices(const std::filesystem::path& sti,
                                                          const std::filesystem::path& mas,
                                                          const std::filesystem::path& dof);

/// One group of inputs or outputs: a node set and the directions (one column of B, or one row of
/// C, per direction).
struct CalculixPort {
  std::string nset;             ///< node set name of the deck (case-insensitive)
  std::vector<int> directions;  ///< 1..6, each once
  std::string location;         ///< where it is configured ("import.yaml:7"), for messages
};

/// The import configuration (YAML, see load_calculix_import_config()).
struct CalculixImportConfig {
  std::filesystem::path source;  ///< the YAML file ("" when built in code)
  std::filesystem::path deck;    ///< calculix.deck
  /// calculix.run: true (default) runs ccx on the deck in OUTPUT/calculix/; false reads the
  /// DECKDIR/DECKSTEM.sti, .mas and .dof that ccx already wrote next to the deck.
  bool run = true;
  std::string executable = "ccx";  ///< calculix.executable: a path, or a name searched on PATH
  /// inputs: column k of B is a force of total magnitude 1 in direction d, distributed equally
  /// over the n nodes of the set (1/n at each), one column per (set, direction) in order.
  std::vector<CalculixPort> inputs;
  /// outputs: row k of C is the mean displacement of the set's nodes in direction d (1/n each).
  std::vector<CalculixPort> outputs;
  double alpha = 0.0;                ///< damping.alpha [1/s]: D = alpha M + beta K; >= 0
  double beta = 0.0;                 ///< damping.beta [s]; >= 0
  std::filesystem::path output_dir;  ///< output.dir: the model directory written
};

/// Parses and validates an import configuration:
///
///   calculix: {deck: model.inp, run: true, executable: ccx}   # run, executable optional
///   inputs:   [{nset: TIP, directions: [2, 3]}]                # or direction: 3
///   outputs:  [{nset: TIP, directions: [2, 3]}]
///   damping:  {alpha: 0.0, beta: 1.0e-5}                       # Rayleigh, both required
///   output:   {dir: out/beam_model}
///
/// Relative paths are resolved against the current working directory (as in config.hpp).
/// \throws ConfigError naming file, line and key: unknown keys (with a suggestion), missing
///         required keys, an empty inputs/outputs list, a direction outside 1..6 or given twice,
///         a negative or non-finite alpha or beta.
ECMOR_INTEROP_API CalculixImportConfig parse_calculix_import_config(const std::string& yaml,
                                                                    const std::string& name);
ECMOR_INTEROP_API CalculixImportConfig
load_calculix_import_config(const std::filesystem::path& path);

/// What import_calculix() did.
struct CalculixImportSummary {
  Index size = 0;                      ///< N, the free degrees of freedom
  Index inputs = 0, outputs = 0;       ///< columns of B, rows of C
  std::size_t nodes = 0;               ///< nodes in nodes.csv
  double ccx_seconds = 0.0;            ///< wall time of the ccx run (0 with run: false)
  std::filesystem::path calculix_dir;  ///< OUTPUT/calculix (the deck ccx ran and its log)
  std::vector<std::string> input_labels, output_labels;  ///< "TIP direction 3 (13 nodes)"
};

/// Runs the import: reads the deck; runs ccx (config.run) on the deck with, when the deck has no
/// step, a `*FREQUENCY, SOLVER=MATRIXSTORAGE` step appended (a deck whose only step is that
/// step runs as it is; any other step is an error: it would be computed for nothing, or preload
/// the structure); reads K, M and the row map; builds B, C and D = alpha M + beta K; writes
/// M.mtx, D.mtx, K.mtx, B.mtx, C.mtx, nodes.csv and dofs.csv into config.output_dir.
/// \throws InputError (the deck, the matrices; a set unknown to the deck; a node of an input or
///         output set without a row for that direction: fixed by *BOUNDARY or not in any
///         element), IoError (ccx cannot be started, fails, or leaves no matrices: its *ERROR
///         lines and the path of its log are in the message; outputs that cannot be written).
ECMOR_INTEROP_API CalculixImportSummary import_calculix(const CalculixImportConfig& config);

}  // namespace ecmor
