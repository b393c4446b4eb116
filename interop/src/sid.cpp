// sid.cpp: SID files (sid.hpp): the writer and a strict reader of the same layout. The reader
// checks every rule where it meets the line, so that a message points at the offending line.
#include "ecmor/interop/sid.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <optional>
#include <sstream>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "text_fields.hpp"

namespace ecmor {
namespace {

/// A block's name and its size for nq elastic coordinates; the order of the body-level blocks is
/// the order in the file.
struct BlockSpec {
  const char* name;
  Index rows_fixed, rows_per_q;  // nrow = rows_fixed + rows_per_q * nq
  Index cols_fixed, cols_per_q;
  Index rows(Index nq) const { return rows_fixed + rows_per_q * nq; }
  Index cols(Index nq) const { return cols_fixed + cols_per_q * nq; }
};

constexpr BlockSpec kOrigin{"origin", 3, 0, 1, 0};
constexpr BlockSpec kPhi{"phi", 3, 0, 0, 1};
constexpr BlockSpec kPsi{"psi", 3, 0, 0, 1};
constexpr BlockSpec kAP{"AP", 3, 0, 3, 0};
constexpr BlockSpec kBodyBlocks[] = {
    {"mdCM", 3, 0, 1, 0},   {"J", 6, 0, 1, 0},  {"Ct", 0, 1, 3, 0}, {"Cr", 0, 1, 3, 0},
    {"Me", 0, 1, 0, 1},     {"Gr", 3, 0, 0, 3}, {"Ge", 0, 1, 0, 3}, {"Oe", 0, 1, 6, 0},
    {"ksigma", 0, 1, 1, 0}, {"Ke", 0, 1, 0, 1}, {"De", 0, 1, 0, 1}};

SidMatrix SidBody::*const kBodyMembers[] = {
    &SidBody::mdCM, &SidBody::J,  &SidBody::Ct,     &SidBody::Cr, &SidBody::Me, &SidBody::Gr,
    &SidBody::Ge,   &SidBody::Oe, &SidBody::ksigma, &SidBody::Ke, &SidBody::De};

// ---------------------------------------------------------------------------------------------
// Writing

std::string number(double v) {
  std::string s = fmt::format("{:.16E}", v);
  std::replace(s.begin(), s.end(), 'E', 'D');
  return v < 0.0 ? s : " " + s;
}

void check_block(const SidMatrix& m, const BlockSpec& spec, Index nq, const std::string& where) {
  const std::string what = where + spec.name;
  if (m.m0.rows() != spec.rows(nq) || m.m0.cols() != spec.cols(nq))
    throw InputError(fmt::format("SID {}: m0 is {} x {}: must be {} x {} for nq = {}", what,
                                 m.m0.rows(), m.m0.cols(), spec.rows(nq), spec.cols(nq), nq));
  if (m.order != 0 && m.order != 1)
    throw InputError(fmt::format("SID {}: order = {}: must be 0 or 1", what, m.order));
  if (m.order == 0 ? !m.m1.empty() : static_cast<Index>(m.m1.size()) != nq)
    throw InputError(fmt::format("SID {}: order {} with {} m1 matrices: must be {}", what, m.order,
                                 m.m1.size(), m.order == 0 ? Index{0} : nq));
  for (const Matrix& a : m.m1)
    if (a.rows() != m.m0.rows() || a.cols() != m.m0.cols())
      throw InputError(fmt::format("SID {}: an m1 matrix is {} x {}: must be m0's size", what,
                                   a.rows(), a.cols()));
  auto finite = [](const Matrix& a) { return a.allFinite(); };
  if (!finite(m.m0) || !std::all_of(m.m1.begin(), m.m1.end(), finite))
    throw InputError(fmt::format("SID {}: an entry is not finite", what));
}

void format_block(std::ostream& os, const char* name, const SidMatrix& m, Index nq,
                  const std::string& indent) {
  const std::string in = indent + "     ";
  os << indent << name << '\n';
  os << fmt::format("{}order     = {}\n{}nrow      = {}\n{}ncol      = {}\n", in, m.order, in,
                    m.m0.rows(), in, m.m0.cols());
  os << fmt::format("{}nq        = {}\n{}nqn       = 0\n{}structure = {}\n", in, nq, in, in,
                    sid_structure(m));
  for (Index i = 0; i < m.m0.rows(); ++i)
    for (Index j = 0; j < m.m0.cols(); ++j)
      if (m.m0(i, j) != 0.0)
        os << fmt::format("{}m0( {}, {}) ={}\n", in, i + 1, j + 1, number(m.m0(i, j)));
  for (Index j = 0; j < m.m0.cols(); ++j)
    for (Index i = 0; i < m.m0.rows(); ++i)
      for (std::size_t k = 0; k < m.m1.size(); ++k)
        if (m.m1[k](i, j) != 0.0)
          os << fmt::format("{}m1( {}, {}, {}) ={}\n", in, i + 1, k + 1, j + 1,
                            number(m.m1[k](i, j)));
  os << indent << "end " << name << '\n';
}

// ---------------------------------------------------------------------------------------------
// Reading

struct Line {
  std::string text;  // trimmed, runs of blanks collapsed to one space
  std::size_t number;
};

class Cursor {
 public:
  Cursor(const std::string& text, std::string origin) : m_origin(std::move(origin)) {
    std::istringstream in(text);
    std::size_t number = 0;
    for (std::string raw; std::getline(in, raw);) {
      ++number;
      std::string s;
      for (char c : raw) {
        const bool blank = c == ' ' || c == '\t' || c == '\r';
        if (blank) {
          if (!s.empty() && s.back() != ' ') s += ' ';
        } else {
          s += c;
        }
      }
      if (!s.empty() && s.back() == ' ') s.pop_back();
      if (!s.empty()) m_lines.push_back({s, number});
    }
  }
  bool done() const { return m_pos >= m_lines.size(); }
  const Line& peek(const std::string& expected) const {
    if (done())
      throw InputError(fmt::format("{}: line {}: file ends where '{}' is expected", m_origin,
                                   m_lines.empty() ? 1 : m_lines.back().number + 1, expected));
    return m_lines[m_pos];
  }
  const Line& next(const std::string& expected) {
    const Line& l = peek(expected);
    ++m_pos;
    return l;
  }
  [[noreturn]] void fail(const Line& l, const std::string& rule) const {
    throw InputError(fmt::format("{}: line {}: {}", m_origin, l.number, rule));
  }
  void expect(const std::string& word) {
    const Line& l = next(word);
    if (l.text != word) fail(l, fmt::format("expected '{}', found '{}'", word, l.text));
  }
  /// "KEY = VALUE" with KEY exactly `key` (blanks around '=' optional); returns VALUE.
  std::string value(const std::string& key) {
    const Line& l = next(key + " = ...");
    const auto eq = l.text.find('=');
    if (eq == std::string::npos || detail::trim(std::string_view(l.text).substr(0, eq)) != key)
      fail(l, fmt::format("expected '{} = ...', found '{}'", key, l.text));
    m_last = &l;
    return std::string(detail::trim(std::string_view(l.text).substr(eq + 1)));
  }
  long long integer(const std::string& key) {
    const std::string v = value(key);
    const auto i = detail::parse_integer(v);
    if (!i) fail(*m_last, fmt::format("{} = '{}': not an integer", key, v));
    return *i;
  }
  double real_value(const std::string& key) { return real(value(key), key); }
  double real(std::string v, const std::string& what) const {
    v = std::string(detail::trim(v));
    std::replace(v.begin(), v.end(), 'D', 'E');
    std::replace(v.begin(), v.end(), 'd', 'e');
    const auto x = detail::parse_real(v);
    if (!x) fail(*m_last, fmt::format("{} = '{}': not a finite number", what, v));
    return *x;
  }
  const Line& last() const { return *m_last; }
  void set_last(const Line& l) { m_last = &l; }
  const std::string& origin() const { return m_origin; }

 private:
  std::string m_origin;
  std::vector<Line> m_lines;
  std::size_t m_pos = 0;
  const Line* m_last = nullptr;
};

/// "name( a, b[, c])" -> the integers; nothing when the text has another form.
std::optional<std::vector<long long>> indices(std::string_view s, std::string_view name) {
  if (s.substr(0, name.size()) != name) return std::nullopt;
  s = detail::trim(s.substr(name.size()));
  if (s.size() < 2 || s.front() != '(' || s.back() != ')') return std::nullopt;
  std::vector<long long> out;
  for (std::string_view field : detail::split(s.substr(1, s.size() - 2), ',')) {
    const auto v = detail::parse_integer(field);
    if (!v) return std::nullopt;
    out.push_back(*v);
  }
  return out;
}

SidMatrix read_block(Cursor& c, const BlockSpec& spec, Index nq) {
  const std::string name = spec.name;
  c.expect(name);
  SidMatrix m;
  const long long order = c.integer("order");
  if (order != 0 && order != 1)
    c.fail(c.last(), fmt::format("{}: order = {}: only orders 0 and 1 are supported", name, order));
  m.order = static_cast<int>(order);
  const long long nrow = c.integer("nrow");
  if (nrow != spec.rows(nq))
    c.fail(c.last(), fmt::format("{}: nrow = {}: must be {} for nelastq = {}", name, nrow,
                                 spec.rows(nq), nq));
  const long long ncol = c.integer("ncol");
  if (ncol != spec.cols(nq))
    c.fail(c.last(), fmt::format("{}: ncol = {}: must be {} for nelastq = {}", name, ncol,
                                 spec.cols(nq), nq));
  const long long nq_block = c.integer("nq");
  if (nq_block != nq)
    c.fail(c.last(), fmt::format("{}: nq = {}: must equal nelastq = {}", name, nq_block, nq));
  const long long nqn = c.integer("nqn");
  if (nqn != 0)
    c.fail(c.last(), fmt::format("{}: nqn = {}: terms of higher order (nqn > 0) are not "
                                 "supported",
                                 name, nqn));
  const long long structure = c.integer("structure");
  if (structure < 0 || structure > 3)
    c.fail(c.last(), fmt::format("{}: structure = {}: must be 0 (zero), 1 (diagonal), 2 "
                                 "(symmetric) or 3 (full)",
                                 name, structure));
  m.structure = static_cast<int>(structure);
  if (structure != 0 && structure != 3 && nrow != ncol)
    c.fail(c.last(), fmt::format("{}: structure = {} needs a square block, not {} x {}", name,
                                 structure, nrow, ncol));
  m.m0 = Matrix::Zero(nrow, ncol);
  if (order == 1) m.m1.assign(static_cast<std::size_t>(nq), Matrix::Zero(nrow, ncol));

  // key (k, i, j), k = 0 for m0 and 1 + k for m1 -> line given
  std::map<std::array<long long, 3>, std::size_t> seen;
  const std::string end = "end " + name;
  while (true) {
    const Line& l = c.next(end);
    c.set_last(l);
    if (l.text == end) break;
    const auto eq = l.text.find('=');
    const std::string_view lhs = detail::trim(
        std::string_view(l.text).substr(0, eq == std::string::npos ? l.text.size() : eq));
    std::optional<std::vector<long long>> idx;
    long long k = 0;
    if (auto i0 = indices(lhs, "m0"); i0 && i0->size() == 2) {
      idx = i0;
    } else if (auto i1 = indices(lhs, "m1"); i1 && i1->size() == 3) {
      if (order == 0) c.fail(l, fmt::format("{}: m1 entry in a block of order 0", name));
      k = (*i1)[1];
      if (k < 1 || k > nq)
        c.fail(l, fmt::format("{}: m1 coordinate index {}: must be in 1..nq = {}", name, k, nq));
      idx = std::vector<long long>{(*i1)[0], (*i1)[2]};
    }
    if (!idx || eq == std::string::npos)
      c.fail(l, fmt::format("expected 'm0( i, j) = value', 'm1( i, k, j) = value' or '{}', "
                            "found '{}'",
                            end, l.text));
    const long long i = (*idx)[0], j = (*idx)[1];
    if (i < 1 || i > nrow || j < 1 || j > ncol)
      c.fail(l,
             fmt::format("{}: entry ({}, {}) outside the {} x {} block", name, i, j, nrow, ncol));
    if (structure == 0) c.fail(l, fmt::format("{}: entry in a block of structure 0 (zero)", name));
    if (structure == 1 && i != j)
      c.fail(l, fmt::format("{}: off-diagonal entry ({}, {}) in a block of structure 1 "
                            "(diagonal)",
                            name, i, j));
    const double v = c.real(std::string(std::string_view(l.text).substr(eq + 1)), std::string(lhs));
    if (auto [it, inserted] = seen.emplace(std::array<long long, 3>{k, i, j}, l.number); !inserted)
      c.fail(l, fmt::format("{}: {} given twice (first at line {})", name, lhs, it->second));
    Matrix& target = k == 0 ? m.m0 : m.m1[static_cast<std::size_t>(k - 1)];
    if (structure == 2 && i != j) {
      if (auto mirror = seen.find({k, j, i}); mirror != seen.end() && target(j - 1, i - 1) != v)
        c.fail(l, fmt::format("{}: structure 2 (symmetric), but {} differs from entry ({}, {}) "
                              "at line {}",
                              name, lhs, j, i, mirror->second));
      target(j - 1, i - 1) = v;
    }
    target(i - 1, j - 1) = v;
  }
  return m;
}

}  // namespace

int sid_structure(const SidMatrix& m) {
  auto all = [&](auto&& pred) {
    if (!pred(m.m0)) return false;
    return std::all_of(m.m1.begin(), m.m1.end(), pred);
  };
  if (all([](const Matrix& a) { return a.size() == 0 || a.cwiseAbs().maxCoeff() == 0.0; }))
    return 0;
  if (m.m0.rows() != m.m0.cols()) return 3;
  if (all([](const Matrix& a) { return Matrix(a.diagonal().asDiagonal()) == a; })) return 1;
  if (all([](const Matrix& a) { return Matrix(a.transpose()) == a; })) return 2;
  return 3;
}

std::string format_sid(const SidBody& body) {
  const Index nq = body.nq();
  if (nq < 1) throw InputError("SID: nelastq = 0: a flexible body needs elastic coordinates");
  for (const SidNode& n : body.frame) {
    const std::string where = fmt::format("node {} ", n.id);
    check_block(n.origin, kOrigin, nq, where);
    check_block(n.phi, kPhi, nq, where);
    check_block(n.psi, kPsi, nq, where);
    check_block(n.AP, kAP, nq, where);
  }
  for (std::size_t b = 0; b < std::size(kBodyBlocks); ++b)
    check_block(body.*kBodyMembers[b], kBodyBlocks[b], nq, "");
  if (!std::isfinite(body.mass)) throw InputError("SID: mass is not finite");

  std::ostringstream os;
  os << fmt::format("{:5} {:3}    :No. nodes, No. modes:{}\n", body.frame.size(), nq,
                    body.header_comment);
  os << "part\n";
  os << "     new modal = " << body.name << '\n';
  const std::string i1 = "          ", i2 = i1 + "     ", i3 = i2 + "     ";
  os << i1 << "refmod\n";
  os << i2 << "mass    =" << number(body.mass) << '\n';
  os << i2 << "nelastq = " << nq << '\n';
  for (Index k = 0; k < nq; ++k)
    os << fmt::format("{}ielastq( {}) = {}\n", i2, k + 1,
                      body.ielastq[static_cast<std::size_t>(k)]);
  os << i1 << "end refmod\n";
  os << i1 << "frame\n";
  for (const SidNode& n : body.frame) {
    os << i2 << "new node = " << n.id << '\n';
    os << i3 << "rframe = " << n.rframe << '\n';
    format_block(os, kOrigin.name, n.origin, nq, i3);
    format_block(os, kPhi.name, n.phi, nq, i3);
    format_block(os, kPsi.name, n.psi, nq, i3);
    format_block(os, kAP.name, n.AP, nq, i3);
    os << i2 << "end node\n";
  }
  os << i1 << "end frame\n";
  for (std::size_t b = 0; b < std::size(kBodyBlocks); ++b)
    format_block(os, kBodyBlocks[b].name, body.*kBodyMembers[b], nq, i1);
  os << "     end modal\n";
  os << "end part\n";
  return os.str();
}

void write_sid(const std::filesystem::path& path, const SidBody& body) {
  write_text_atomically(path, format_sid(body));
}

SidBody parse_sid(const std::string& text, const std::string& origin) {
  Cursor c(text, origin);
  SidBody body;
  std::optional<long long> header_nodes, header_nq;
  std::size_t header_line = 0;
  const Line& first = c.peek("part");
  if (std::isdigit(static_cast<unsigned char>(first.text[0]))) {
    c.next("part");
    const auto colon = first.text.find(':');
    const auto counts =
        detail::split(detail::trim(std::string_view(first.text).substr(0, colon)), ' ');
    if (counts.size() != 2 || !detail::parse_integer(counts[0]) ||
        !detail::parse_integer(counts[1]))
      c.fail(first, fmt::format("first line '{}': must start with two integers, the numbers of "
                                "nodes and of modes",
                                first.text));
    header_nodes = detail::parse_integer(counts[0]);
    header_nq = detail::parse_integer(counts[1]);
    header_line = first.number;
    if (colon != std::string::npos) {
      const std::string rest = first.text.substr(colon + 1);
      const std::string label = "No. nodes, No. modes:";
      body.header_comment = rest.rfind(label, 0) == 0 ? rest.substr(label.size()) : rest;
    }
  }
  c.expect("part");
  {
    const Line& l = c.next("new modal");
    if (l.text != "new modal" && l.text.rfind("new modal =", 0) != 0 &&
        l.text.rfind("new modal=", 0) != 0)
      c.fail(l, fmt::format("expected 'new modal = NAME', found '{}'", l.text));
    const auto eq = l.text.find('=');
    if (eq != std::string::npos)
      body.name = std::string(detail::trim(std::string_view(l.text).substr(eq + 1)));
  }
  c.expect("refmod");
  body.mass = c.real_value("mass");
  const long long nq = c.integer("nelastq");
  if (nq < 1 || nq > 100000)
    c.fail(c.last(), fmt::format("nelastq = {}: must be in 1..100000", nq));
  for (long long k = 1; k <= nq; ++k) {
    const Line& l = c.next("ielastq");
    c.set_last(l);
    const auto eq = l.text.find('=');
    const auto idx = indices(detail::trim(std::string_view(l.text).substr(0, eq)), "ielastq");
    if (eq == std::string::npos || !idx || idx->size() != 1)
      c.fail(l, fmt::format("expected 'ielastq( {}) = TEXT', found '{}'", k, l.text));
    if ((*idx)[0] != k)
      c.fail(l, fmt::format("ielastq( {}): expected ielastq( {}) (numbered 1..nelastq in order)",
                            (*idx)[0], k));
    body.ielastq.emplace_back(detail::trim(std::string_view(l.text).substr(eq + 1)));
  }
  c.expect("end refmod");
  c.expect("frame");
  while (c.peek("end frame").text != "end frame") {
    SidNode n;
    const Line& l = c.next("new node");
    c.set_last(l);
    const auto eq = l.text.find('=');
    const auto id =
        eq == std::string::npos
            ? std::nullopt
            : detail::parse_integer(detail::trim(std::string_view(l.text).substr(eq + 1)));
    if (detail::trim(std::string_view(l.text).substr(0, eq)) != "new node" || !id)
      c.fail(l, fmt::format("expected 'new node = ID' or 'end frame', found '{}'", l.text));
    n.id = *id;
    n.rframe = c.value("rframe");
    n.origin = read_block(c, kOrigin, nq);
    n.phi = read_block(c, kPhi, nq);
    n.psi = read_block(c, kPsi, nq);
    n.AP = read_block(c, kAP, nq);
    c.expect("end node");
    body.frame.push_back(std::move(n));
  }
  c.expect("end frame");
  for (std::size_t b = 0; b < std::size(kBodyBlocks); ++b)
    body.*kBodyMembers[b] = read_block(c, kBodyBlocks[b], nq);
  c.expect("end modal");
  c.expect("end part");
  if (!c.done()) {
    const Line& l = c.next("");
    c.fail(l, fmt::format("text after 'end part': '{}'", l.text));
  }
  if (header_nodes &&
      (*header_nodes != static_cast<long long>(body.frame.size()) || *header_nq != nq))
    throw InputError(fmt::format(
        "{}: line {}: first line gives {} nodes and {} modes, but the file has {} nodes and "
        "nelastq = {}",
        origin, header_line, *header_nodes, *header_nq, body.frame.size(), nq));
  return body;
}

SidBody read_sid(const std::filesystem::path& path) {
  std::string text;
  detail::for_each_line(path, "SID file", [&](const std::string& line, std::size_t) {
    text += line;
    text += '\n';
  });
  return parse_sid(text, path.string());
}

}  // namespace ecmor
