// calculix_deck.cpp: the strict reader of CalculiX input decks (what the importer needs: nodes,
// node sets, steps, *INCLUDE) and of the matrices ccx stores with SOLVER=MATRIXSTORAGE. Strict,
// because a deck read differently from the way ccx reads it gives a model whose inputs act on the
// wrong nodes without any sign of it.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <unordered_map>
#include <unordered_set>

#include "ecmor/base/error.hpp"
#include "ecmor/interop/calculix.hpp"
#include "text_fields.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;
using detail::at_line;

// ccx reads records of at most 132 columns (manual, section "Simple example problem"); a longer
// line would be cut without a word, so it is an error here.
constexpr std::size_t kMaxColumns = 132;
constexpr int kMaxIncludeDepth = 16;

std::string upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

/// A keyword line: `*NAME, KEY=VALUE, FLAG`. Names and keys upper-case (CalculiX is
/// case-insensitive), values as written (file names are case-sensitive).
struct Keyword {
  std::string name;
  std::vector<std::pair<std::string, std::string>> params;

  const std::string* param(const std::string& key) const {
    for (const auto& [k, v] : params)
      if (k == key) return &v;
    return nullptr;
  }
};

Keyword parse_keyword(std::string_view line) {
  const auto fields = detail::split(line, ',');
  Keyword kw;
  // "*SOLID  SECTION" and "*solid section" are the same keyword.
  for (char c : fields[0]) {
    if (c == ' ' || c == '\t') {
      if (!kw.name.empty() && kw.name.back() != ' ') kw.name += ' ';
    } else {
      kw.name += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    }
  }
  for (std::size_t i = 1; i < fields.size(); ++i) {
    if (fields[i].empty()) continue;
    const auto eq = fields[i].find('=');
    if (eq == std::string_view::npos) {
      kw.params.emplace_back(upper(fields[i]), "");
    } else {
      kw.params.emplace_back(upper(detail::trim(fields[i].substr(0, eq))),
                             std::string(detail::trim(fields[i].substr(eq + 1))));
    }
  }
  return kw;
}

// The analysis keywords of CalculiX that define what a step computes.
const std::vector<std::string> kProcedures = {"*STATIC",
                                              "*FREQUENCY",
                                              "*BUCKLE",
                                              "*DYNAMIC",
                                              "*MODAL DYNAMIC",
                                              "*STEADY STATE DYNAMICS",
                                              "*HEAT TRANSFER",
                                              "*COUPLED TEMPERATURE-DISPLACEMENT",
                                              "*UNCOUPLED TEMPERATURE-DISPLACEMENT",
                                              "*VISCO",
                                              "*GREEN",
                                              "*SENSITIVITY",
                                              "*COMPLEX FREQUENCY",
                                              "*ELECTROMAGNETICS",
                                              "*CFD",
                                              "*SUBSTRUCTURE GENERATE",
                                              "*CRACK PROPAGATION",
                                              "*FEASIBLE DIRECTION",
                                              "*ROBUSTDESIGN"};

struct SetEntry {
  long long node;
  std::string location;
};

class DeckReader {
 public:
  CalculixDeck read(const fs::path& path) {
    m_deck.path = path;
    read_file(path, 0);
    if (m_in_step) throw InputError(m_step_start + ": *STEP without *END STEP");
    check_set_members();
    for (auto& [name, entries] : m_sets) {
      std::vector<long long>& ids = m_deck.nsets[name];
      for (const SetEntry& e : entries) ids.push_back(e.node);
    }
    return std::move(m_deck);
  }

 private:
  enum class Block { None, Node, Nset, NsetGenerate, Other };

  void read_file(const fs::path& path, int depth) {
    const std::vector<std::string> lines = detail::read_lines(path, "CalculiX deck");
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const std::string& raw = lines[i];
      m_location = path.string() + ": line " + std::to_string(i + 1);
      const std::string where = m_location + ": ";
      if (raw.size() > kMaxColumns)
        throw InputError(where + fmt::format("{} columns: ccx reads at most {} per line and would "
                                             "cut the rest",
                                             raw.size(), kMaxColumns));
      const std::string_view line = detail::trim(raw);
      if (line.empty() || line.rfind("**", 0) == 0) {
        m_deck.flattened.push_back(raw);
        continue;
      }
      if (line[0] == '*') {
        const Keyword kw = parse_keyword(line);
        if (kw.name == "*INCLUDE") {
          include(kw, path, where, depth);
          continue;
        }
        m_deck.flattened.push_back(raw);
        start_block(kw, where);
        continue;
      }
      m_deck.flattened.push_back(raw);
      data_line(line, where);
    }
  }

  void include(const Keyword& kw, const fs::path& from, const std::string& where, int depth) {
    const std::string* input = kw.param("INPUT");
    if (input == nullptr || input->empty()) throw InputError(where + "*INCLUDE without INPUT=file");
    if (depth + 1 > kMaxIncludeDepth)
      throw InputError(
          where + fmt::format("*INCLUDE nested more than {} deep (a cycle?)", kMaxIncludeDepth));
    fs::path file = *input;
    if (file.is_relative()) file = from.parent_path() / file;
    std::error_code ec;
    if (!fs::is_regular_file(file, ec))
      throw InputError(where + "*INCLUDE, INPUT=" + *input + ": no such file (" + file.string() +
                       "; relative names are taken from the including file's directory)");
    m_block = Block::None;
    m_deck.flattened.push_back("** ecmor: begin of " + file.filename().string());
    read_file(file, depth + 1);
    m_deck.flattened.push_back("** ecmor: end of " + file.filename().string());
    m_block = Block::None;  // a data line after *INCLUDE belongs to no keyword of this file
  }

  static void allow_only(const Keyword& kw, const std::string& where,
                         const std::vector<std::string>& allowed) {
    for (const auto& [key, value] : kw.params)
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end())
        throw InputError(where + fmt::format("{}: parameter {} is not supported by ecmor's deck "
                                             "reader (supported: {})",
                                             kw.name, key, fmt::join(allowed, ", ")));
  }

  void start_block(const Keyword& kw, const std::string& where) {
    m_block = Block::Other;
    m_set.clear();
    // ccx runs the deck in another directory (OUTPUT/calculix), where a relative INPUT= of a
    // card would name another file, and ecmor would not read what the card brings in.
    if (const std::string* input = kw.param("INPUT"))
      throw InputError(where + fmt::format("{}, INPUT={}: data from other files only through "
                                           "*INCLUDE",
                                           kw.name, *input));
    if (kw.name == "*NODE") {
      allow_only(kw, where, {"NSET"});
      m_block = Block::Node;
      if (const std::string* set = kw.param("NSET")) m_set = set_name(*set, kw, where);
    } else if (kw.name == "*NSET") {
      // INTERNAL and UNSORTED (Abaqus) do not change which nodes are in the set.
      allow_only(kw, where, {"NSET", "GENERATE", "INTERNAL", "UNSORTED"});
      const std::string* set = kw.param("NSET");
      if (set == nullptr) throw InputError(where + "*NSET without NSET=name");
      m_set = set_name(*set, kw, where);
      m_sets[m_set];  // an *NSET with no data lines still defines the (empty) set
      m_block = kw.param("GENERATE") != nullptr ? Block::NsetGenerate : Block::Nset;
    } else if (kw.name == "*STEP") {
      if (m_in_step)
        throw InputError(where + "*STEP inside the step that starts at " + m_step_start);
      m_in_step = true;
      m_step_start = m_location;
      m_deck.steps.push_back({"", false, m_step_start});
    } else if (kw.name == "*END STEP") {
      if (!m_in_step) throw InputError(where + "*END STEP without *STEP");
      m_in_step = false;
    } else if (m_in_step &&
               std::find(kProcedures.begin(), kProcedures.end(), kw.name) != kProcedures.end()) {
      CalculixDeck::Step& step = m_deck.steps.back();
      if (step.procedure.empty()) step.procedure = kw.name;
      const std::string* solver = kw.param("SOLVER");
      if (kw.name == "*FREQUENCY" && solver != nullptr && upper(*solver) == "MATRIXSTORAGE")
        step.matrix_storage = true;
    }
  }

  static std::string set_name(const std::string& raw, const Keyword& kw, const std::string& where) {
    if (raw.empty()) throw InputError(where + kw.name + ": empty set name");
    return upper(raw);
  }

  void data_line(std::string_view line, const std::string& where) {
    auto fields = detail::split(line, ',');
    while (!fields.empty() && fields.back().empty()) fields.pop_back();  // "1, 2, " (gmsh)
    switch (m_block) {
      case Block::None:
        throw InputError(where + "data line outside any keyword block");
      case Block::Node:
        node_line(fields, where);
        return;
      case Block::Nset:
        nset_line(fields, where);
        return;
      case Block::NsetGenerate:
        generate_line(fields, where);
        return;
      case Block::Other:
        return;
    }
  }

  long long node_id(std::string_view text, const std::string& where, const char* keyword) const {
    const auto id = detail::parse_integer(text);
    if (!id)
      throw InputError(where + fmt::format("{}: node id '{}' is not an integer", keyword, text));
    if (*id <= 0)
      throw InputError(where + fmt::format("{}: node id {}: must be > 0", keyword, *id));
    return *id;
  }

  void node_line(const std::vector<std::string_view>& f, const std::string& where) {
    if (f.empty() || f.size() > 4)
      throw InputError(where + fmt::format("*NODE: {} fields: expected id, x[, y[, z]]", f.size()));
    FeNode p;
    p.id = node_id(f[0], where, "*NODE");
    double* coordinate[3] = {&p.x, &p.y, &p.z};
    for (std::size_t k = 1; k < f.size(); ++k) {
      if (f[k].empty()) continue;  // an omitted coordinate is 0, as in ccx
      const auto v = detail::parse_real(f[k]);
      if (!v)
        throw InputError(
            where + fmt::format("*NODE {}: coordinate '{}' is not a finite number", p.id, f[k]));
      *coordinate[k - 1] = *v;
    }
    const std::string location = m_location;
    if (auto [it, inserted] = m_node_line.emplace(p.id, location); !inserted)
      throw InputError(where +
                       fmt::format("node {} defined twice (first at {})", p.id, it->second));
    m_deck.nodes.push_back(p);
    if (!m_set.empty()) add_to_set(p.id, location);
  }

  void nset_line(const std::vector<std::string_view>& f, const std::string& where) {
    const std::string location = m_location;
    for (std::string_view field : f) {
      if (field.empty()) continue;
      if (std::isdigit(static_cast<unsigned char>(field[0])) || field[0] == '-' ||
          field[0] == '+') {
        add_to_set(node_id(field, where, "*NSET"), location);
        continue;
      }
      // A set name: the nodes of a set defined earlier.
      const std::string name = upper(field);
      const auto it = m_sets.find(name);
      if (it == m_sets.end())
        throw InputError(where + fmt::format("*NSET {}: '{}' is neither a node id nor a node set "
                                             "defined above",
                                             m_set, field));
      const std::vector<SetEntry> members = it->second;  // a copy: the set may be m_set itself
      for (const SetEntry& e : members) add_to_set(e.node, e.location);
    }
  }

  void generate_line(const std::vector<std::string_view>& f, const std::string& where) {
    if (f.size() < 2 || f.size() > 3)
      throw InputError(where + fmt::format("*NSET, GENERATE: {} fields: expected first, last[, "
                                           "increment]",
                                           f.size()));
    const long long first = node_id(f[0], where, "*NSET, GENERATE");
    const long long last = node_id(f[1], where, "*NSET, GENERATE");
    long long step = 1;
    if (f.size() == 3) {
      const auto inc = detail::parse_integer(f[2]);
      if (!inc || *inc <= 0)
        throw InputError(where + fmt::format("*NSET, GENERATE: increment '{}': must be an integer "
                                             "> 0",
                                             f[2]));
      step = *inc;
    }
    if (first > last)
      throw InputError(where + fmt::format("*NSET, GENERATE: first {} > last {}", first, last));
    const std::string location = m_location;
    for (long long id = first; id <= last; id += step) add_to_set(id, location);
  }

  void add_to_set(long long node, const std::string& location) {
    auto& members = m_set_members[m_set];
    if (members.insert(node).second) m_sets[m_set].push_back({node, location});
  }

  void check_set_members() const {
    for (const auto& [name, entries] : m_sets)
      for (const SetEntry& e : entries)
        if (m_node_line.count(e.node) == 0)
          throw InputError(fmt::format("{}: *NSET {}: node {} is not defined by any *NODE",
                                       e.location, name, e.node));
  }

  CalculixDeck m_deck;
  Block m_block = Block::None;
  std::string m_set;  // upper-case name of the set the current block adds to ("" none)
  std::map<std::string, std::vector<SetEntry>> m_sets;
  std::unordered_map<std::string, std::unordered_set<long long>> m_set_members;
  std::unordered_map<long long, std::string> m_node_line;
  bool m_in_step = false;
  std::string m_step_start;
  std::string m_location;  // "deck.inp: line 12", the line being read
};

void read_triangle(const fs::path& path, Index n, std::vector<Eigen::Triplet<double, int>>& out) {
  Index prev_row = 0, prev_col = 0;
  std::size_t blank_line = 0;  // a blank line is only allowed as the last one
  detail::for_each_line(path, "CalculiX matrix file", [&](const std::string& text, std::size_t i) {
    if (blank_line != 0) throw InputError(at_line(path, blank_line) + "blank line");
    std::vector<std::string_view> f;
    for (std::string_view t : detail::split(detail::trim(text), ' '))
      if (!t.empty()) f.push_back(t);
    if (f.empty()) {
      blank_line = i;
      return;
    }
    const std::string where = at_line(path, i);
    const auto r = f.size() == 3 ? detail::parse_integer(f[0]) : std::nullopt;
    const auto c = f.size() == 3 ? detail::parse_integer(f[1]) : std::nullopt;
    const auto v = f.size() == 3 ? detail::parse_real(f[2]) : std::nullopt;
    if (!r || !c || !v)
      throw InputError(where + "expected 'row column value' (two integers and a finite number)");
    if (*r < 1 || *r > n || *c < 1 || *c > n)
      throw InputError(where + fmt::format("entry ({}, {}) outside 1..N = {} (N from the .dof "
                                           "file)",
                                           *r, *c, n));
    if (*r > *c)
      throw InputError(where + fmt::format("entry ({}, {}) below the diagonal: ccx stores the "
                                           "upper triangle (row <= column)",
                                           *r, *c));
    if (*c < prev_col || (*c == prev_col && *r <= prev_row))
      throw InputError(where + fmt::format("entry ({}, {}) after ({}, {}): ccx writes column by "
                                           "column, rows ascending, each entry once",
                                           *r, *c, prev_row, prev_col));
    prev_row = *r;
    prev_col = *c;
    if (*v == 0.0) return;  // ccx lists some structural zeros; they carry nothing
    out.emplace_back(static_cast<int>(*r - 1), static_cast<int>(*c - 1), *v);
    if (*r != *c) out.emplace_back(static_cast<int>(*c - 1), static_cast<int>(*r - 1), *v);
  });
}

SparseMatrix read_symmetric(const fs::path& path, Index n) {
  std::vector<Eigen::Triplet<double, int>> t;
  read_triangle(path, n, t);
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

std::vector<FeDof> read_dofs(const fs::path& path) {
  const std::vector<std::string> lines = detail::read_lines(path, "CalculiX dof file");
  std::vector<FeDof> dofs;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string_view t = detail::trim(lines[i]);
    if (t.empty() && i + 1 == lines.size()) break;
    const std::string where = at_line(path, i + 1);
    const auto dot = t.find('.');
    const auto node =
        dot == std::string_view::npos ? std::nullopt : detail::parse_integer(t.substr(0, dot));
    const auto dir =
        dot == std::string_view::npos ? std::nullopt : detail::parse_integer(t.substr(dot + 1));
    if (!node || !dir || *node <= 0)
      throw InputError(where + fmt::format("'{}': expected node.direction (node > 0)", t));
    if (*dir == 0)
      throw InputError(where + fmt::format("'{}': a thermal degree of freedom (direction 0): only "
                                           "mechanical models are imported",
                                           t));
    if (*dir < 1 || *dir > 6)
      throw InputError(where + fmt::format("'{}': direction {}: must be 1..6", t, *dir));
    dofs.push_back({static_cast<Index>(dofs.size() + 1), *node, static_cast<int>(*dir)});
  }
  if (dofs.empty())
    throw InputError(path.string() + ": no degrees of freedom (is everything constrained?)");
  return dofs;
}

}  // namespace

CalculixDeck read_calculix_deck(const fs::path& path) { return DeckReader().read(path); }

CalculixMatrices read_calculix_matrices(const fs::path& sti, const fs::path& mas,
                                        const fs::path& dof) {
  CalculixMatrices m;
  m.dofs = read_dofs(dof);
  const Index n = static_cast<Index>(m.dofs.size());
  m.K = read_symmetric(sti, n);
  m.M = read_symmetric(mas, n);
  return m;
}

}  // namespace ecmor
