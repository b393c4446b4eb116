// calculix_import.cpp: `ecmor import calculix`: the YAML of an import, the ccx run and the
// assembly of the model directory. The deck is read by calculix_deck.cpp; this file decides
// policy (which steps a deck may have, what B and C mean) and runs ccx.
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <fstream>
#include <set>
#include <unordered_map>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/parameters.hpp"
#include "ecmor/interop/calculix.hpp"
#include "ecmor/interop/subprocess.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model.hpp"
#include "text_fields.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;

// ---- the YAML of an import ------------------------------------------------------------------

class ImportParser {
 public:
  explicit ImportParser(std::string name) : m_name(std::move(name)) {}

  CalculixImportConfig parse(const std::string& yaml) {
    YAML::Node root;
    try {
      root = YAML::Load(yaml);
    } catch (const YAML::Exception& e) {
      fail(at(e.mark), "YAML syntax error: " + e.msg);
    }
    if (!root.IsMap()) fail(m_name, "an import configuration must be a mapping of sections");
    check_keys(root, "the import configuration",
               {"calculix", "inputs", "outputs", "damping", "output"});
    CalculixImportConfig c;
    const YAML::Node calculix = section(root, "calculix", {"deck", "run", "executable"});
    c.deck = fs::absolute(text(calculix, "calculix.deck", true)).lexically_normal();
    if (const YAML::Node run = calculix["run"]; run.IsDefined())
      c.run = boolean(run, "calculix.run");
    if (calculix["executable"].IsDefined())
      c.executable = text(calculix, "calculix.executable", true);
    c.inputs = ports(root, "inputs");
    c.outputs = ports(root, "outputs");
    const YAML::Node damping = section(root, "damping", {"alpha", "beta"});
    c.alpha = non_negative(damping, "damping", "alpha");
    c.beta = non_negative(damping, "damping", "beta");
    if (root["output"].IsDefined()) {
      const YAML::Node output = section(root, "output", {"dir"});
      c.output_dir = fs::absolute(text(output, "output.dir", true)).lexically_normal();
    }
    return c;
  }

 private:
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw ConfigError(where + ": " + what);
  }
  std::string at(const YAML::Mark& mark) const {
    return mark.is_null() ? m_name : fmt::format("{}:{}", m_name, mark.line + 1);
  }
  std::string at(const YAML::Node& node) const { return at(node.Mark()); }

  void check_keys(const YAML::Node& map, const std::string& where_name,
                  const std::vector<std::string>& known) const {
    std::set<std::string> seen;
    for (auto it = map.begin(); it != map.end(); ++it) {
      if (!it->first.IsScalar()) fail(at(it->first), "keys in " + where_name + " must be names");
      const std::string& k = it->first.Scalar();
      if (!seen.insert(k).second)
        fail(at(it->first), fmt::format("duplicate key '{}' in {}", k, where_name));
      if (std::find(known.begin(), known.end(), k) == known.end())
        fail(at(it->first),
             fmt::format("unknown key '{}' in {}{}", k, where_name, suggestion(k, known)));
    }
  }

  /// A required mapping `name` of the root (or of a list item), keys checked.
  YAML::Node section(const YAML::Node& parent, const std::string& name,
                     const std::vector<std::string>& known) const {
    const YAML::Node node = parent[name];
    if (!node.IsDefined()) fail(at(parent), "missing required section '" + name + "'");
    if (!node.IsMap())
      fail(at(node),
           fmt::format("'{}' must be a mapping of keys ({})", name, fmt::join(known, ", ")));
    check_keys(node, "'" + name + "'", known);
    return node;
  }

  const YAML::Node& scalar(const YAML::Node& node, const std::string& key) const {
    if (node.IsNull()) fail(at(node), key + " has no value");
    if (!node.IsScalar()) fail(at(node), key + " must be a single value");
    return node;
  }

  std::string text(const YAML::Node& map, const std::string& key, bool required) const {
    const YAML::Node node = map[key.substr(key.rfind('.') + 1)];
    if (!node.IsDefined()) {
      if (required) fail(at(map), "missing required key '" + key + "'");
      return {};
    }
    const std::string& s = scalar(node, key).Scalar();
    if (s.empty()) fail(at(node), key + " must not be empty");
    return s;
  }

  bool boolean(const YAML::Node& node, const std::string& key) const {
    const std::string& s = scalar(node, key).Scalar();
    if (s == "true" || s == "True" || s == "yes") return true;
    if (s == "false" || s == "False" || s == "no") return false;
    fail(at(node), fmt::format("{} = {}: must be true or false", key, s));
  }

  double non_negative(const YAML::Node& map, const std::string& sec, const std::string& key) const {
    const std::string full = sec + "." + key;
    const YAML::Node node = map[key];
    if (!node.IsDefined()) fail(at(map), "missing required key '" + full + "'");
    const std::string& s = scalar(node, full).Scalar();
    const auto v = detail::parse_real(s);
    if (!v) fail(at(node), fmt::format("{} = '{}': must be a finite number", full, s));
    if (*v < 0.0) fail(at(node), fmt::format("{} = {}: must be >= 0", full, s));
    return *v;
  }

  int direction(const YAML::Node& node, const std::string& key) const {
    const std::string& s = scalar(node, key).Scalar();
    const auto v = detail::parse_integer(s);
    if (!v || *v < 1 || *v > 6)
      fail(at(node), fmt::format("{} = {}: must be an integer 1..6 (1..3 translations x, y, z; "
                                 "4..6 rotations)",
                                 key, s));
    return static_cast<int>(*v);
  }

  std::vector<CalculixPort> ports(const YAML::Node& root, const std::string& name) const {
    const YAML::Node list = root[name];
    if (!list.IsDefined()) fail(at(root), "missing required section '" + name + "'");
    if (!list.IsSequence() || list.size() == 0)
      fail(at(list), fmt::format("'{}' must be a non-empty list of {{nset: NAME, directions: "
                                 "[...]}}",
                                 name));
    std::vector<CalculixPort> out;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const YAML::Node item = list[i];
      const std::string item_name = fmt::format("{}[{}]", name, i);
      if (!item.IsMap())
        fail(at(item), item_name + " must be a mapping {nset: NAME, directions: [...]}");
      check_keys(item, item_name, {"nset", "direction", "directions"});
      CalculixPort p;
      p.location = at(item);
      p.nset = text(item, item_name + ".nset", true);
      const YAML::Node one = item["direction"];
      const YAML::Node many = item["directions"];
      if (one.IsDefined() == many.IsDefined())
        fail(at(item), item_name + ": give either 'direction' or 'directions'");
      if (one.IsDefined()) {
        p.directions.push_back(direction(one, item_name + ".direction"));
      } else {
        if (!many.IsSequence() || many.size() == 0)
          fail(at(many), item_name + ".directions must be a non-empty list of 1..6");
        for (std::size_t k = 0; k < many.size(); ++k) {
          const int d = direction(many[k], fmt::format("{}.directions[{}]", item_name, k));
          if (std::find(p.directions.begin(), p.directions.end(), d) != p.directions.end())
            fail(at(many[k]), fmt::format("{}.directions: {} given twice", item_name, d));
          p.directions.push_back(d);
        }
      }
      out.push_back(std::move(p));
    }
    return out;
  }

  std::string m_name;
};

// ---- running ccx ----------------------------------------------------------------------------

/// The *ERROR messages of a ccx log (each with the lines that continue it), for error messages.
std::string ccx_errors(const fs::path& log) {
  std::ifstream in(log);
  std::vector<std::string> out;
  int continuation = 0;
  for (std::string line; std::getline(in, line) && out.size() < 8;) {
    const std::string_view t = detail::trim(line);
    if (t.find("*ERROR") != std::string_view::npos) {
      out.emplace_back(t);
      continuation = 3;
    } else if (continuation > 0 && !t.empty()) {
      out.emplace_back(t);
      --continuation;
    } else {
      continuation = 0;
    }
  }
  return out.empty() ? "no *ERROR line in its log" : fmt::format("{}", fmt::join(out, " "));
}

/// Runs `exe -i job` in `dir`, stdout and stderr into `log`; returns the wall time in seconds.
double run_ccx(const std::string& exe, const fs::path& dir, const std::string& job,
               const fs::path& log) {
  ProgramExit finished;
  try {
    finished = run_program(exe, {"-i", job}, dir, log, /*stdout_to_log=*/true);
  } catch (const IoError& e) {
    throw IoError(std::string(e.what()) +
                  " (install calculix-ccx: bash scripts/setup.sh fe; or set calculix.executable)");
  }
  if (!finished.ok())
    throw IoError(fmt::format("{} failed ({}) on {}: {}; its log is {}", exe, finished.describe(),
                              (dir / (job + ".inp")).string(), ccx_errors(log), log.string()));
  return finished.seconds;
}

/// The step ecmor appends to a deck without steps: ccx assembles K and M of the constrained
/// structure, writes them and stops. The data line (number of eigenvalues) is required by the
/// card but unused.
const char* const kMatrixStorageStep =
    "** ecmor: the matrix-storage step\n"
    "*STEP\n"
    "*FREQUENCY, SOLVER=MATRIXSTORAGE\n"
    "1\n"
    "*END STEP\n";

/// Whether the deck brings its own matrix-storage step (then it is run as it is); throws naming
/// the step when the deck has any other step.
bool deck_has_storage_step(const CalculixDeck& deck) {
  for (std::size_t i = 0; i < deck.steps.size(); ++i) {
    const CalculixDeck::Step& s = deck.steps[i];
    if (!s.matrix_storage)
      throw InputError(fmt::format(
          "{}: a *STEP with {}: ecmor appends its own *FREQUENCY, SOLVER=MATRIXSTORAGE step; give "
          "the model without steps, or with that step as its only step",
          s.location, s.procedure.empty() ? "no analysis keyword" : s.procedure));
    if (i > 0)
      throw InputError(
          fmt::format("{}: a second *STEP: ccx stops after the first "
                      "*FREQUENCY, SOLVER=MATRIXSTORAGE step; give only one",
                      s.location));
  }
  return !deck.steps.empty();
}

struct MatrixFiles {
  fs::path sti, mas, dof;
};
MatrixFiles matrix_files(const fs::path& dir, const std::string& job) {
  return {dir / (job + ".sti"), dir / (job + ".mas"), dir / (job + ".dof")};
}

/// calculix.run: false: the files ccx wrote next to the deck, which must be newer than the deck.
MatrixFiles existing_matrices(const CalculixImportConfig& c) {
  const MatrixFiles f = matrix_files(c.deck.parent_path(), c.deck.stem().string());
  std::error_code ec;
  const auto deck_time = fs::last_write_time(c.deck, ec);
  for (const fs::path& p : {f.sti, f.mas, f.dof}) {
    if (!fs::is_regular_file(p, ec))
      throw InputError(
          fmt::format("{}: not found (calculix.run: false reads the matrices ccx "
                      "wrote for {}; run `ccx -i {}` next to it, or set run: true)",
                      p.string(), c.deck.string(), c.deck.stem().string()));
    if (fs::last_write_time(p, ec) < deck_time)
      throw InputError(
          fmt::format("{}: older than the deck {}: the matrices may not be those of "
                      "the deck as it is; run ccx again, or set run: true",
                      p.string(), c.deck.string()));
  }
  return f;
}

// ---- B and C ----------------------------------------------------------------------------------

struct Port {
  std::string label;
  std::vector<Index> rows;  // 0-based rows of M, one per node of the set
};

/// One Port per (set, direction); every node of the set must have a row in that direction.
std::vector<Port> resolve(const std::vector<CalculixPort>& ports, const std::string& kind,
                          const CalculixDeck& deck, const std::vector<FeDof>* dofs) {
  std::unordered_map<long long, Index> row_of;  // node * 8 + direction -> 0-based row
  if (dofs != nullptr)
    for (const FeDof& d : *dofs) row_of.emplace(d.node * 8 + d.direction, d.row - 1);
  std::vector<std::string> names;
  for (const auto& [name, ids] : deck.nsets) names.push_back(name);
  std::vector<Port> out;
  for (std::size_t i = 0; i < ports.size(); ++i) {
    const CalculixPort& p = ports[i];
    const std::string what = fmt::format("{}: {}[{}]", p.location, kind, i);
    std::string key = p.nset;
    std::transform(key.begin(), key.end(), key.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::toupper(ch)); });
    const auto set = deck.nsets.find(key);
    if (set == deck.nsets.end())
      throw ConfigError(fmt::format("{}: nset '{}' is not a node set of {}{}", what, p.nset,
                                    deck.path.string(), suggestion(key, names)));
    if (set->second.empty())
      throw ConfigError(
          fmt::format("{}: node set '{}' of {} is empty", what, p.nset, deck.path.string()));
    for (int d : p.directions) {
      Port port;
      port.label = fmt::format("{} direction {} ({} nodes)", key, d, set->second.size());
      std::vector<long long> missing;
      for (long long node : set->second) {
        const auto it = row_of.find(node * 8 + d);
        if (it == row_of.end()) {
          missing.push_back(node);
        } else {
          port.rows.push_back(it->second);
        }
      }
      if (dofs != nullptr && !missing.empty()) {
        missing.resize(std::min<std::size_t>(missing.size(), 5));
        throw InputError(fmt::format(
            "{}: node set {} direction {}: {} of {} nodes have no degree of freedom {} in the "
            "matrices (first: {}): fixed by *BOUNDARY, in no element, or a direction the "
            "elements do not have",
            what, key, d, set->second.size() - port.rows.size(), set->second.size(), d,
            fmt::join(missing, ", ")));
      }
      out.push_back(std::move(port));
    }
  }
  return out;
}

/// Column k of the result is 1/n at the n rows of port k (B: a unit total force spread equally;
/// C, transposed: the mean displacement).
Matrix spread(const std::vector<Port>& ports, Index n) {
  Matrix X = Matrix::Zero(n, static_cast<Index>(ports.size()));
  for (std::size_t k = 0; k < ports.size(); ++k)
    for (Index r : ports[k].rows)
      X(r, static_cast<Index>(k)) = 1.0 / static_cast<double>(ports[k].rows.size());
  return X;
}

std::string numbered(const std::string& what, const std::vector<Port>& ports) {
  std::string s;
  for (std::size_t k = 0; k < ports.size(); ++k)
    s += fmt::format("\n{} {}: {}", what, k + 1, ports[k].label);
  return s;
}

/// nodes.csv holds every node of the deck; each row's node must be one of them (ccx adds nodes of
/// its own when it expands beam and shell elements).
FeGeometry geometry_of(const CalculixDeck& deck, const std::vector<FeDof>& dofs,
                       const fs::path& dof_file) {
  std::unordered_map<long long, bool> known;
  for (const FeNode& p : deck.nodes) known.emplace(p.id, true);
  for (const FeDof& d : dofs)
    if (known.count(d.node) == 0)
      throw InputError(fmt::format(
          "{}: row {} belongs to node {}, which {} does not define: ccx adds such nodes when it "
          "expands beam and shell elements; only decks of solid elements are supported",
          dof_file.string(), d.row, d.node, deck.path.string()));
  return FeGeometry{deck.nodes, dofs};
}

void write_model(const fs::path& dir, const SecondOrderModel& m, const std::vector<Port>& in,
                 const std::vector<Port>& out, const CalculixImportConfig& c,
                 const FeGeometry& geometry) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError("cannot create directory " + dir.string() + ": " + ec.message());
  // Files of another model left in the directory would make it inconsistent or ambiguous.
  for (const char* stale : {"Cv.mtx", "E.mtx", "A.mtx"}) {
    fs::remove(dir / stale, ec);
    if (ec)
      throw IoError("cannot remove stale file " + (dir / stale).string() + ": " + ec.message());
  }
  const std::string from = "imported from CalculiX deck " + c.deck.string();
  write_matrix_market(dir / "M.mtx", m.M, "M: mass, " + from);
  write_matrix_market(dir / "K.mtx", m.K, "K: stiffness, " + from);
  write_matrix_market(
      dir / "D.mtx", m.D,
      fmt::format("D = alpha M + beta K, alpha = {:.17g} 1/s, beta = {:.17g} s", c.alpha, c.beta));
  write_matrix_market(
      dir / "B.mtx", m.B,
      "B: each column a unit total force spread equally over a node set" + numbered("column", in));
  write_matrix_market(dir / "C.mtx", m.C,
                      "C: each row the mean displacement of a node set" + numbered("row", out));
  write_fe_geometry(dir, geometry);
}

}  // namespace

CalculixImportConfig parse_calculix_import_config(const std::string& yaml,
                                                  const std::string& name) {
  CalculixImportConfig c = ImportParser(name).parse(yaml);
  c.source = name;
  return c;
}

CalculixImportConfig load_calculix_import_config(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path.string() + ": cannot open the import configuration");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse_calculix_import_config(text, path.string());
}

CalculixImportSummary import_calculix(const CalculixImportConfig& c) {
  if (c.output_dir.empty())
    throw ConfigError((c.source.empty() ? std::string("import") : c.source.string()) +
                      ": no output directory: set output.dir, or give -o DIR");
  const CalculixDeck deck = read_calculix_deck(c.deck);
  // The sets are checked before ccx runs: a misspelt set name should not cost a ccx run.
  resolve(c.inputs, "inputs", deck, nullptr);
  resolve(c.outputs, "outputs", deck, nullptr);
  const bool has_step = deck_has_storage_step(deck);

  CalculixImportSummary summary;
  summary.calculix_dir = c.output_dir / "calculix";
  MatrixFiles files;
  if (c.run) {
    std::error_code ec;
    fs::create_directories(summary.calculix_dir, ec);
    if (ec) throw IoError("cannot create " + summary.calculix_dir.string() + ": " + ec.message());
    const std::string job = "model";
    files = matrix_files(summary.calculix_dir, job);
    for (const fs::path& p : {files.sti, files.mas, files.dof}) fs::remove(p, ec);
    write_file_atomically(summary.calculix_dir / (job + ".inp"), [&](std::ostream& os) {
      // File names only in these comments: ccx reads at most 132 columns a line.
      os << "** ecmor import calculix: " << c.deck.filename().string() << ", *INCLUDEs expanded\n";
      for (const std::string& line : deck.flattened) os << line << '\n';
      if (!has_step) os << kMatrixStorageStep;
    });
    const fs::path log = summary.calculix_dir / "ccx.log";
    summary.ccx_seconds = run_ccx(c.executable, summary.calculix_dir, job, log);
    for (const fs::path& p : {files.sti, files.mas, files.dof})
      if (!fs::is_regular_file(p, ec))
        throw IoError(fmt::format("ccx wrote no {} for {}: {}; its log is {}",
                                  p.filename().string(), c.deck.string(), ccx_errors(log),
                                  log.string()));
  } else {
    files = existing_matrices(c);
  }
  CalculixMatrices mats = read_calculix_matrices(files.sti, files.mas, files.dof);
  const FeGeometry geometry = geometry_of(deck, mats.dofs, files.dof);
  const std::vector<Port> in = resolve(c.inputs, "inputs", deck, &mats.dofs);
  const std::vector<Port> out = resolve(c.outputs, "outputs", deck, &mats.dofs);

  const Index n = mats.K.rows();
  SecondOrderModel so;
  so.D = c.alpha * mats.M + c.beta * mats.K;
  so.D.prune(0.0);  // drops exact zeros only (alpha or beta 0)
  so.D.makeCompressed();
  so.M = std::move(mats.M);
  so.K = std::move(mats.K);
  so.B = spread(in, n);
  so.C = spread(out, n).transpose();
  const Model model(std::move(so));
  validate(model, "imported model " + c.output_dir.string());
  const SecondOrderModel& m = std::get<SecondOrderModel>(model);
  write_model(c.output_dir, m, in, out, c, geometry);
  if (c.run) {
    // The matrices are in the model now; the text copies are large and no longer needed.
    std::error_code ec;
    for (const fs::path& p : {files.sti, files.mas, files.dof}) fs::remove(p, ec);
  }
  summary.size = n;
  summary.inputs = m.B.cols();
  summary.outputs = m.C.rows();
  summary.nodes = geometry.nodes.size();
  for (const Port& p : in) summary.input_labels.push_back(p.label);
  for (const Port& p : out) summary.output_labels.push_back(p.label);
  return summary;
}

}  // namespace ecmor
