#pragma once
/// \file model.hpp
/// Linear time-invariant models: second order (seed Eq. 3)
///     M q'' + D q' + K q = B u,   y = C q + Cv q'
/// and first-order descriptor (seed Eq. 1)
///     E x' = A x + B u,           y = C x.
/// Full models hold sparse N x N matrices; reduced models (seed Eqs. 2 and 4) hold dense n x n
/// ones. B (N x m) and C, Cv (p x N) are dense in both: m and p are small.

#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"

namespace ecmor {

/// Second-order system with matrix type Mat (SparseMatrix for full, Matrix for reduced models).
template <class Mat>
struct SecondOrderSystem {
  Mat M;      ///< mass, N x N
  Mat D;      ///< damping, N x N
  Mat K;      ///< stiffness, N x N
  Matrix B;   ///< input, N x m
  Matrix C;   ///< position output, p x N
  Matrix Cv;  ///< velocity output, p x N; empty (0 x 0) when the model has none

  Index size() const { return K.rows(); }
  Index inputs() const { return B.cols(); }
  Index outputs() const { return C.rows(); }
  bool has_velocity_output() const { return Cv.size() > 0; }
};

/// First-order descriptor system with matrix type Mat.
template <class Mat>
struct DescriptorSystem {
  Mat E;     ///< descriptor matrix, N x N (may be singular: DAE)
  Mat A;     ///< system matrix, N x N
  Matrix B;  ///< input, N x m
  Matrix C;  ///< output, p x N

  Index size() const { return A.rows(); }
  Index inputs() const { return B.cols(); }
  Index outputs() const { return C.rows(); }
};

using SecondOrderModel = SecondOrderSystem<SparseMatrix>;
using DescriptorModel = DescriptorSystem<SparseMatrix>;
using ReducedSecondOrderModel = SecondOrderSystem<Matrix>;
using ReducedDescriptorModel = DescriptorSystem<Matrix>;

/// A full (sparse) model of either kind.
using Model = std::variant<SecondOrderModel, DescriptorModel>;
/// A reduced (dense) model of either kind. A reducer may return a first-order reduced model of a
/// second-order full model (e.g. IRKA through the first-order realisation).
using ReducedModel = std::variant<ReducedSecondOrderModel, ReducedDescriptorModel>;

enum class ModelKind { SecondOrder, Descriptor };
ECMOR_API std::string to_string(ModelKind kind);

ECMOR_API ModelKind kind_of(const Model& model);
ECMOR_API ModelKind kind_of(const ReducedModel& model);
ECMOR_API Index size_of(const Model& model);
ECMOR_API Index size_of(const ReducedModel& model);
ECMOR_API Index inputs_of(const Model& model);
ECMOR_API Index outputs_of(const Model& model);
ECMOR_API Index inputs_of(const ReducedModel& model);
ECMOR_API Index outputs_of(const ReducedModel& model);

/// Structural checks every model must pass: all coefficient matrices square and of one size N,
/// B with N rows, C (and Cv) with N columns and equal row counts, every stored value finite.
/// \param origin prefix for messages (e.g. the model directory).
/// \throws InputError naming the matrix and the rule broken, e.g.
///         "model dir: D is 450 x 451: must be square",
///         "model dir: B has 300 rows: must equal N = 301 (the size of K)",
///         "model dir: K has a non-finite value (NaN) at (3, 4)" (1-based indices).
///         N is the size of K (second order) or A (descriptor); N, m and p must be >= 1.
ECMOR_API void validate(const Model& model, std::string_view origin = "model");
ECMOR_API void validate(const ReducedModel& model, std::string_view origin = "reduced model");

/// Relative asymmetry ||A - A'||_F / ||A||_F (0 for an all-zero matrix, +inf if not square).
ECMOR_API double relative_asymmetry(const SparseMatrix& A);
ECMOR_API double relative_asymmetry(const Matrix& A);

/// True if the symmetric matrix A admits a Cholesky factorisation (CHOLMOD). A is checked for
/// symmetry first (relative asymmetry <= symmetry_tol), else false. The symmetric part is
/// factorised after symmetric diagonal (Jacobi) scaling, so bad scaling alone does not matter;
/// indefinite and singular matrices give false, including numerically singular ones whose scaled
/// pivots span a ratio below N * eps (CHOLMOD's rcond estimate).
ECMOR_API bool is_positive_definite(const SparseMatrix& A, double symmetry_tol = 1e-10);

/// Require M (second-order) or E (descriptor) symmetric positive definite.
/// \throws InputError "<origin>: M is not positive definite (Cholesky failed at column 17)"
///         (1-based column), "<origin>: M is not symmetric (relative asymmetry 0.003 > 1e-10)" or
///         "<origin>: E is numerically singular (...)".
ECMOR_API void require_spd_mass(const Model& model, std::string_view origin = "model",
                                double symmetry_tol = 1e-10);

/// Recognises a first-order model that is a second-order model written in the state x = [q; q']
/// and returns that second-order model, or std::nullopt (never throws). With N even, n = N / 2
/// and n x n blocks  E = [E11 E12; E21 E22],  A = [A11 A12; A21 A22],  B = [B1; B2],
/// C = [C1 C2], the pattern recognised is exactly:
///   * E12 and E21 hold no stored nonzero value, A11 holds no stored nonzero value;
///   * A12 == E11 entrywise (bit for bit, e.g. both I), and E11 is symmetric positive definite
///     (is_positive_definite with its default tolerance);
///   * B1 is zero.
/// Then E11 q' = E11 v gives q' = v, and the second block row reads E22 v' = A21 q + A22 v + B2 u,
/// so the model is  M q'' + D q' + K q = B u,  y = C q + Cv q'  with
///   M = E22,  K = -A21,  D = -A22,  B = B2,  C = C1 (p x n, zero if all zero),
///   Cv = C2 (left empty, 0 x 0, when C2 is all zero).
/// Both models have the same transfer matrix. Nothing is required of M, D, K (symmetry,
/// definiteness): callers check what their method needs. A model whose blocks do not have these
/// sizes (inconsistent dimensions, N odd or 0) is not recognised.
ECMOR_API std::optional<SecondOrderModel> second_order_form(const DescriptorModel& model);

}  // namespace ecmor
