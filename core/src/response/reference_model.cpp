// reference_model.cpp: the error estimator's reference model, grown by full-model solves.
#include "ecmor/response/reference_model.hpp"

#include <cstdint>
#include <string>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/model/projection.hpp"

namespace ecmor {

namespace {

// Appends the blocks of Q' T Q for the new columns Q_new = Q(:, first..): the top-right block
// Q_old' T Q_new, the bottom-left block Q_new' T Q_old = (T' Q_new)' Q_old and the corner.
void extend_projection(Matrix& Tr, const SparseMatrix& T, const Matrix& Q, Index first) {
  const Index r = Q.cols(), k = r - first;
  const Matrix Qn = Q.rightCols(k);
  const Matrix TQn = T * Qn;
  const Matrix TtQn = T.transpose() * Qn;
  Matrix out(r, r);
  out.topLeftCorner(first, first) = Tr;
  out.topRightCorner(first, k) = Q.leftCols(first).transpose() * TQn;
  out.bottomLeftCorner(k, first) = TtQn.transpose() * Q.leftCols(first);
  out.bottomRightCorner(k, k) = Qn.transpose() * TQn;
  Tr = std::move(out);
}

void extend_rows(Matrix& Br, const Matrix& B, const Matrix& Q, Index first) {
  const Index k = Q.cols() - first;
  Matrix out(Q.cols(), B.cols());
  out.topRows(first) = Br;
  out.bottomRows(k) = Q.rightCols(k).transpose() * B;
  Br = std::move(out);
}

void extend_cols(Matrix& Cr, const Matrix& C, const Matrix& Q, Index first) {
  if (C.size() == 0) return;  // no velocity output
  const Index k = Q.cols() - first;
  Matrix out(C.rows(), Q.cols());
  out.leftCols(first) = Cr;
  out.rightCols(k) = C * Q.rightCols(k);
  Cr = std::move(out);
}

// FNV-1a over the bytes of column j: equal columns, bit for bit, hash equal. A collision (about
// 2^-64 per pair) would only leave a direction out of the reference, which the full solves of the
// re-check still see.
std::uint64_t column_hash(const Matrix& X, Index j) {
  std::uint64_t h = 1469598103934665603ull;
  const auto* bytes = reinterpret_cast<const unsigned char*>(X.col(j).data());
  const std::size_t size = static_cast<std::size_t>(X.rows()) * sizeof(double);
  for (std::size_t i = 0; i < size; ++i) {
    h ^= bytes[i];
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace

ReferenceModel::ReferenceModel(const Model& model, double deflation_tol)
    : m_model(model), m_deflation_tol(deflation_tol) {
  if (!(deflation_tol > 0.0 && deflation_tol < 1.0))
    throw ConfigError("ReferenceModel: deflation_tol = " + std::to_string(deflation_tol) +
                      ": must be in (0, 1)");
  const Index n = size_of(model), m = inputs_of(model), p = outputs_of(model);
  m_Q.resize(n, 0);
  if (const auto* so = std::get_if<SecondOrderModel>(&model)) {
    ReducedSecondOrderModel r;
    r.M.resize(0, 0);
    r.D.resize(0, 0);
    r.K.resize(0, 0);
    r.B.resize(0, m);
    r.C.resize(p, 0);
    if (so->has_velocity_output()) r.Cv.resize(p, 0);
    m_reduced = std::move(r);
  } else {
    ReducedDescriptorModel r;
    r.E.resize(0, 0);
    r.A.resize(0, 0);
    r.B.resize(0, m);
    r.C.resize(p, 0);
    m_reduced = std::move(r);
  }
}

Index ReferenceModel::add(const ComplexMatrix& Z) {
  Matrix X(Z.rows(), 2 * Z.cols());
  X << Z.real(), Z.imag();
  return add(X);
}

Index ReferenceModel::add(const Matrix& X) {
  if (X.rows() != m_Q.rows())
    throw InputError("reference model: a basis with " + std::to_string(X.rows()) +
                     " rows was offered; the full model has N = " + std::to_string(m_Q.rows()));
  if (X.cols() == 0) return 0;
  // A column offered before, bit for bit, is in span(Q) already (appended then, or deflated
  // against a smaller Q): orthogonalising it again would only deflate it. Strategies offer each
  // candidate's whole basis, and successive candidates share most of it (a Krylov basis grown by
  // a point keeps its first blocks); measured on triplechain_mess_n1501_greedy, orthogonalising
  // those again was a fifth of the reference model's time.
  // The hashes are kept only once the columns were taken: a basis refused (a NaN in it) leaves
  // its other columns to be offered again.
  std::vector<Index> fresh;
  std::vector<std::uint64_t> hashes;
  for (Index j = 0; j < X.cols(); ++j) {
    const std::uint64_t h = column_hash(X, j);
    if (m_offered.count(h) != 0) continue;
    fresh.push_back(j);
    hashes.push_back(h);
  }
  if (fresh.empty()) return 0;
  const Index first = m_Q.cols();
  const Index added = static_cast<Index>(fresh.size()) == X.cols()
                          ? orthonormalize_append(m_Q, X, InnerProduct{}, m_deflation_tol)
                          : orthonormalize_append(m_Q, Matrix(X(Eigen::all, fresh)), InnerProduct{},
                                                  m_deflation_tol);
  m_offered.insert(hashes.begin(), hashes.end());
  if (added > 0) extend(first);
  return added;
}

Index ReferenceModel::add(const std::vector<FullSolution>& solutions) {
  Index added = 0;
  for (const FullSolution& s : solutions) added += add(s.Z);
  return added;
}

void ReferenceModel::extend(Index first) {
  if (auto* r = std::get_if<ReducedSecondOrderModel>(&m_reduced)) {
    const auto& so = std::get<SecondOrderModel>(m_model);
    extend_projection(r->M, so.M, m_Q, first);
    extend_projection(r->D, so.D, m_Q, first);
    extend_projection(r->K, so.K, m_Q, first);
    extend_rows(r->B, so.B, m_Q, first);
    extend_cols(r->C, so.C, m_Q, first);
    extend_cols(r->Cv, so.Cv, m_Q, first);
  } else {
    auto& d = std::get<ReducedDescriptorModel>(m_reduced);
    const auto& ds = std::get<DescriptorModel>(m_model);
    extend_projection(d.E, ds.E, m_Q, first);
    extend_projection(d.A, ds.A, m_Q, first);
    extend_rows(d.B, ds.B, m_Q, first);
    extend_cols(d.C, ds.C, m_Q, first);
  }
  ++m_version;
}

}  // namespace ecmor
