// fe_geometry.cpp: nodes.csv and dofs.csv of a model directory. The rules are checked once, in
// check(); reading only adds the line of each entry so that a message points into the file.
#include "ecmor/interop/fe_geometry.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <ostream>
#include <unordered_map>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "text_fields.hpp"

namespace ecmor {
namespace {

namespace fs = std::filesystem;

constexpr const char* kNodesHeader = "node,x,y,z";
constexpr const char* kDofsHeader = "row,node,direction";
constexpr long long kMaxNodeId = 1LL << 60;

/// Where entry k of a list came from: line lines[k] of a file, or entry k + 1 of a list in memory.
struct Locator {
  std::string origin;
  std::vector<std::size_t> lines;  // empty: in memory
  std::string brief(std::size_t k) const {
    return lines.empty() ? fmt::format("entry {}", k + 1) : fmt::format("line {}", lines[k]);
  }
  std::string at(std::size_t k) const { return origin + ": " + brief(k) + ": "; }
};

void check(const FeGeometry& g, Index n, const Locator& nodes, const Locator& dofs) {
  if (n < 1) throw InputError(fmt::format("{}: model size N = {}: must be >= 1", dofs.origin, n));
  std::unordered_map<long long, std::size_t> node_index;
  for (std::size_t k = 0; k < g.nodes.size(); ++k) {
    const FeNode& p = g.nodes[k];
    if (p.id <= 0 || p.id > kMaxNodeId)
      throw InputError(nodes.at(k) + fmt::format("node id {}: must be in 1..2^60", p.id));
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw InputError(nodes.at(k) + fmt::format("node {}: coordinates must be finite", p.id));
    if (auto [it, inserted] = node_index.emplace(p.id, k); !inserted)
      throw InputError(nodes.at(k) + fmt::format("node {} given twice (first at {})", p.id,
                                                 nodes.brief(it->second)));
  }
  if (static_cast<Index>(g.dofs.size()) != n)
    throw InputError(
        fmt::format("{}: {} rows, but the model has N = {}: every row 1..N must be "
                    "given exactly once",
                    dofs.origin, g.dofs.size(), n));
  const std::size_t unseen = g.dofs.size();
  std::vector<std::size_t> row_seen(static_cast<std::size_t>(n), unseen);
  // (node, direction) -> entry, packed as node * 8 + direction: no overflow for ids <= 2^60.
  std::unordered_map<long long, std::size_t> pair_seen;
  for (std::size_t k = 0; k < g.dofs.size(); ++k) {
    const FeDof& d = g.dofs[k];
    if (d.row < 1 || d.row > n)
      throw InputError(dofs.at(k) + fmt::format("row {}: must be in 1..N = {}", d.row, n));
    std::size_t& first = row_seen[static_cast<std::size_t>(d.row - 1)];
    if (first != unseen)
      throw InputError(dofs.at(k) +
                       fmt::format("row {} given twice (first at {})", d.row, dofs.brief(first)));
    first = k;
    if (d.direction < 1 || d.direction > 6)
      throw InputError(dofs.at(k) + fmt::format("row {}: direction {}: must be 1..6 (1..3 "
                                                "translations, 4..6 rotations)",
                                                d.row, d.direction));
    if (node_index.count(d.node) == 0)
      throw InputError(dofs.at(k) +
                       fmt::format("row {}: node {} is not in {}", d.row, d.node, nodes.origin));
    if (auto [it, inserted] = pair_seen.emplace(d.node * 8 + d.direction, k); !inserted)
      throw InputError(dofs.at(k) + fmt::format("row {}: node {} direction {} already has row {}",
                                                d.row, d.node, d.direction,
                                                g.dofs[it->second].row));
  }
}

/// The data lines of a CSV file with a fixed header, split into `fields` fields each; `lines`
/// receives their 1-based line numbers. A final empty line (the file's last newline) is allowed,
/// no other blank line.
std::vector<std::vector<std::string_view>> read_csv(const fs::path& path,
                                                    const std::vector<std::string>& text,
                                                    const std::string& header,
                                                    std::vector<std::size_t>& lines) {
  if (text.empty() || detail::trim(text[0]) != header)
    throw InputError(detail::at_line(path, 1) + "the header must be '" + header + "'");
  const std::size_t fields = detail::split(header, ',').size();
  std::vector<std::vector<std::string_view>> rows;
  for (std::size_t i = 1; i < text.size(); ++i) {
    if (detail::trim(text[i]).empty())
      throw InputError(detail::at_line(path, i + 1) + "blank line");
    auto f = detail::split(text[i], ',');
    if (f.size() != fields)
      throw InputError(detail::at_line(path, i + 1) +
                       fmt::format("{} fields, expected {} ({})", f.size(), fields, header));
    rows.push_back(std::move(f));
    lines.push_back(i + 1);
  }
  return rows;
}

template <class T>
T field(std::optional<T> v, const fs::path& path, std::size_t line, std::string_view name,
        std::string_view text, const char* kind) {
  if (!v)
    throw InputError(detail::at_line(path, line) +
                     fmt::format("{} '{}' is not {}", name, text, kind));
  return *v;
}

}  // namespace

void validate(const FeGeometry& geometry, Index model_size, const std::string& origin) {
  check(geometry, model_size, Locator{origin + ": nodes", {}}, Locator{origin + ": dofs", {}});
}

std::optional<FeGeometry> read_fe_geometry(const fs::path& dir, Index model_size) {
  const fs::path nodes_path = dir / "nodes.csv";
  const fs::path dofs_path = dir / "dofs.csv";
  std::error_code ec;
  const bool has_nodes = fs::exists(nodes_path, ec);
  const bool has_dofs = fs::exists(dofs_path, ec);
  if (!has_nodes && !has_dofs) return std::nullopt;
  if (has_nodes != has_dofs)
    throw InputError(fmt::format("{}: {} without {}: give both or neither", dir.string(),
                                 has_nodes ? "nodes.csv" : "dofs.csv",
                                 has_nodes ? "dofs.csv" : "nodes.csv"));
  // The text stays alive while the fields (views into it) are converted.
  const std::vector<std::string> node_text = detail::read_lines(nodes_path, "node file");
  const std::vector<std::string> dof_text = detail::read_lines(dofs_path, "dof file");
  Locator nodes{nodes_path.string(), {}};
  Locator dofs{dofs_path.string(), {}};
  FeGeometry g;
  for (const auto& f : read_csv(nodes_path, node_text, kNodesHeader, nodes.lines)) {
    const std::size_t line = nodes.lines[g.nodes.size()];
    FeNode p;
    p.id = field(detail::parse_integer(f[0]), nodes_path, line, "node", f[0], "an integer");
    p.x = field(detail::parse_real(f[1]), nodes_path, line, "x", f[1], "a finite number");
    p.y = field(detail::parse_real(f[2]), nodes_path, line, "y", f[2], "a finite number");
    p.z = field(detail::parse_real(f[3]), nodes_path, line, "z", f[3], "a finite number");
    g.nodes.push_back(p);
  }
  for (const auto& f : read_csv(dofs_path, dof_text, kDofsHeader, dofs.lines)) {
    const std::size_t line = dofs.lines[g.dofs.size()];
    FeDof d;
    d.row = field(detail::parse_integer(f[0]), dofs_path, line, "row", f[0], "an integer");
    d.node = field(detail::parse_integer(f[1]), dofs_path, line, "node", f[1], "an integer");
    const long long dir_value =
        field(detail::parse_integer(f[2]), dofs_path, line, "direction", f[2], "an integer");
    // check() rejects anything outside 1..6; the clamp only keeps a huge value from overflowing
    // int on its way there.
    d.direction = static_cast<int>(std::clamp(dir_value, -1000LL, 1000LL));
    g.dofs.push_back(d);
  }
  check(g, model_size, nodes, dofs);
  std::vector<FeDof> sorted(g.dofs.size());
  for (const FeDof& d : g.dofs) sorted[static_cast<std::size_t>(d.row - 1)] = d;
  g.dofs = std::move(sorted);
  return g;
}

void write_fe_geometry(const fs::path& dir, const FeGeometry& geometry) {
  validate(geometry, static_cast<Index>(geometry.dofs.size()), dir.string());
  write_file_atomically(dir / "nodes.csv", [&](std::ostream& out) {
    out << kNodesHeader << '\n';
    for (const FeNode& p : geometry.nodes) out << fmt::format("{},{},{},{}\n", p.id, p.x, p.y, p.z);
  });
  write_file_atomically(dir / "dofs.csv", [&](std::ostream& out) {
    out << kDofsHeader << '\n';
    for (const FeDof& d : geometry.dofs)
      out << fmt::format("{},{},{}\n", d.row, d.node, d.direction);
  });
}

}  // namespace ecmor
