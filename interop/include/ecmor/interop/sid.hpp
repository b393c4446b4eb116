#pragma once
/// \file sid.hpp
/// Standard Input Data (SID) of a flexible body (Wallrapp 1994) in the ASCII layout of FEMBS's
/// `.SID_FEM` files, which Simpack reads; docs/multibody.md lists the blocks, the subset ecmor
/// writes and the public sources of the layout. A file:
///
///   <nodes> <nq> :No. nodes, No. modes: <comment>          (first line)
///   part
///     new modal = <name>
///       refmod  mass = ..  nelastq = nq  ielastq( k) = <text> ...  end refmod
///       frame   new node = <id>  rframe = body ref  origin .. phi .. psi .. AP ..  end node ...
///               end frame
///       mdCM  J  Ct  Cr  Me  Gr  Ge  Oe  ksigma  Ke  De      (each: NAME ... end NAME)
///     end modal
///   end part
///
/// Each matrix block: `order = 0|1`, `nrow`, `ncol`, `nq`, `nqn = 0`, `structure = 0..3`
/// (0 zero, 1 diagonal, 2 symmetric, 3 full), then its nonzero entries `m0( i, j) = v` and
/// `m1( i, k, j) = v` (row i, elastic coordinate k, column j: the index order of FEMBS), values in
/// Fortran `D` notation. The matrix is M(q) = m0 + sum_k m1(:, k, :) q_k.

#include <filesystem>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/interop/export.hpp"

namespace ecmor {

/// One matrix block of a SID file. m1 is empty for order 0, else it has nq matrices of m0's size.
struct SidMatrix {
  int order = 0;      ///< 0 or 1
  int structure = 3;  ///< 0 zero, 1 diagonal, 2 symmetric, 3 full (the writer derives it)
  Matrix m0;
  std::vector<Matrix> m1;
};

/// A node of the body's frame: position and mode shapes at the node (FEMBS's `new node`).
struct SidNode {
  long long id = 0;
  std::string rframe = "body ref";
  SidMatrix origin;  ///< 3 x 1, order 1: position, m1(:, k) = translation of mode k
  SidMatrix phi;     ///< 3 x nq: translations of the modes at the node
  SidMatrix psi;     ///< 3 x nq: rotations of the modes at the node
  SidMatrix AP;      ///< 3 x 3, order 1: orientation, m0 = I, m1(:, k, :) = psi_k~
};

/// The body: what `ecmor export-body` writes and read_sid() returns.
struct SidBody {
  std::string header_comment;  ///< text after "No. nodes, No. modes:" on the first line
  std::string name;            ///< `new modal = name`
  double mass = 0.0;
  std::vector<std::string> ielastq;  ///< one description per elastic coordinate (nelastq of them)
  std::vector<SidNode> frame;
  SidMatrix mdCM;    ///< 3 x 1: m c(q)
  SidMatrix J;       ///< 6 x 1: J(q) as (xx, yy, zz, xy, xz, yz)
  SidMatrix Ct;      ///< nq x 3
  SidMatrix Cr;      ///< nq x 3
  SidMatrix Me;      ///< nq x nq
  SidMatrix Gr;      ///< 3 x 3nq: column (a - 1) nq + k holds Gr_k(:, a)
  SidMatrix Ge;      ///< nq x 3nq: column (a - 1) nq + k holds Ge_k(:, a)
  SidMatrix Oe;      ///< nq x 6 (xx, yy, zz, xy, yz, xz)
  SidMatrix ksigma;  ///< nq x 1
  SidMatrix Ke;      ///< nq x nq
  SidMatrix De;      ///< nq x nq
  Index nq() const { return static_cast<Index>(ielastq.size()); }
};

/// The structure code of a block's content: 0 all zero, 1 diagonal, 2 symmetric (square), 3 full.
ECMOR_INTEROP_API int sid_structure(const SidMatrix& m);

/// The SID text of `body` (structures derived from the content; zero entries omitted; 17
/// significant digits, so that read_sid() gives the same numbers back bit for bit).
/// \throws InputError when a block's size does not fit nq (the sizes in the SidBody comments) or
///         an entry is not finite.
ECMOR_INTEROP_API std::string format_sid(const SidBody& body);

/// Writes format_sid(body) to `path` atomically. \throws InputError (format_sid), IoError.
ECMOR_INTEROP_API void write_sid(const std::filesystem::path& path, const SidBody& body);

/// Reads a SID file in the layout above (the first line optional; lines may be indented; tabs
/// count as blanks). \throws InputError "FILE: line L: RULE" for: a keyword other than the one
/// the layout expects, a missing `end`, a value that is not a number or not finite, an index
/// outside the block, an entry given twice, order other than 0 or 1, nqn != 0, structure outside
/// 0..3 or broken by an entry (off-diagonal in a diagonal block, any entry in a zero block,
/// different values at (i, j) and (j, i) of a symmetric block), m1 entries in an order-0 block,
/// nq or a block's size not fitting nelastq, ielastq numbered out of order, the first line's
/// counts not matching the file, text after `end part`, and an early end of file.
ECMOR_INTEROP_API SidBody read_sid(const std::filesystem::path& path);

/// The same parser on text in memory; `origin` names it in messages.
ECMOR_INTEROP_API SidBody parse_sid(const std::string& text, const std::string& origin);

}  // namespace ecmor
