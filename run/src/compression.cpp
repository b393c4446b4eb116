// compression.cpp: see compression.hpp.
#include "compression.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <memory>
#include <numeric>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/measures/stability.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::run {
namespace {

// Symmetry a Galerkin projection of symmetric matrices keeps up to rounding.
constexpr double kSymmetric = 1e-10;
// Full solves the re-checks of one compression may add (issue 51: at most 5 factorisations):
// BandErrorEstimator::verify_near spends them at the largest departures from the accepted model.
constexpr Index kCheckSolves = 5;

// The accepted model as a symmetric pencil: second order M q'' + D q' + K q = B u, y = C q + Cv q'
// (mass Mr, stiffness Kr), or first order E x' = A x + B u, y = C x read as mass E and stiffness
// -A (a stable symmetric model has -A positive semidefinite), so that one modal path serves both.
struct Pencil {
  bool second_order = true;
  Matrix mass, stiffness, damping;  // damping: second order only
  Matrix B, C, Cv;                  // Cv: second order only (may be empty)
};

Pencil pencil_of(const ReducedModel& model) {
  Pencil p;
  if (const auto* r = std::get_if<ReducedSecondOrderModel>(&model)) {
    p = {true, r->M, r->K, r->D, r->B, r->C, r->Cv};
  } else {
    const auto& d = std::get<ReducedDescriptorModel>(model);
    p = {false, d.E, -d.A, Matrix(), d.B, d.C, Matrix()};
  }
  return p;
}

struct Modes {
  Pencil pencil;
  Matrix phi;  // n x n, mass-orthonormal columns
  std::vector<double>
      lambda;                // ascending: K phi = lambda M phi (first order: -A phi = lambda E phi)
  std::vector<Index> order;  // columns by rank: the rigid ones first, then by band contribution
  Index rigid = 0;           // leading entries of `order` that are always kept
};

// A mode's term of the response at w: c_i(w) b_i' / den_i(w), den = lambda - w^2 + i w d_i (second
// order) or lambda + i w (first order: i w - a_i with a_i = -lambda).
Complex denominator(const Modes& m, Index i, double w, double d) {
  const double l = m.lambda[static_cast<std::size_t>(i)];
  return m.pencil.second_order ? Complex(l - w * w, w * d) : Complex(l, w);
}

// The largest contribution of each mode to the response over the band, relative to the
// response there (the error measure is relative: near an antiresonance a small term matters):
// max over the samples and the modes' own resonances in the band of
// |c_i(w)| |b_i| / |den_i(w)| / ||Hr(w)||_F, Hr the sum of the modal terms.
std::vector<double> band_contributions(const Modes& m, std::vector<double> f_hz) {
  const Pencil& p = m.pencil;
  const Index n = m.phi.cols();
  const double f_lo = f_hz.front(), f_hi = f_hz.back();
  if (p.second_order) {
    for (double l : m.lambda) {
      const double f = l > 0.0 ? std::sqrt(l) / kTwoPi : -1.0;
      if (f >= f_lo && f <= f_hi) f_hz.push_back(f);
    }
  }
  const Matrix b = m.phi.transpose() * p.B;  // row i: b_i
  const Matrix c = p.C * m.phi;              // column i: c_i
  const Matrix cv = p.Cv.size() > 0 ? Matrix(p.Cv * m.phi) : Matrix::Zero(c.rows(), n);
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
  if (p.second_order)
    for (Index i = 0; i < n; ++i) d(i) = m.phi.col(i).dot(p.damping * m.phi.col(i));
  std::vector<double> score(static_cast<std::size_t>(n), 0.0);
  ComplexMatrix H(c.rows(), b.cols());
  std::vector<double> term(static_cast<std::size_t>(n));
  for (double f : f_hz) {
    const double w = kTwoPi * f;
    H.setZero();
    for (Index i = 0; i < n; ++i) {
      const Complex den = denominator(m, i, w, d(i));
      const Eigen::VectorXcd ci = c.col(i).cast<Complex>() + Complex(0.0, w) * cv.col(i);
      H += ci * b.row(i).cast<Complex>() / den;
      term[static_cast<std::size_t>(i)] = ci.norm() * b.row(i).norm() / std::abs(den);
    }
    const double scale = H.norm();
    if (!(scale > 0.0)) continue;
    for (Index i = 0; i < n; ++i) {
      double& s = score[static_cast<std::size_t>(i)];
      s = std::max(s, term[static_cast<std::size_t>(i)] / scale);
    }
  }
  return score;
}

// The accepted model's modes, ranked; std::nullopt with `why` when the model is not of the kind
// this compression keeps the structure of.
std::optional<Modes> ranked_modes(const ReducerResult& accepted, const RigidBodyModes& rigid,
                                  const std::vector<double>& f_hz, std::string& why) {
  if (accepted.W.size() != 0 && accepted.W != accepted.V) {
    why = "a Petrov-Galerkin model, W != V (compressed so far: W = V)";
    return std::nullopt;
  }
  Modes m;
  m.pencil = pencil_of(accepted.model);
  const Pencil& p = m.pencil;
  if (relative_asymmetry(p.mass) > kSymmetric || relative_asymmetry(p.stiffness) > kSymmetric ||
      (p.second_order && relative_asymmetry(p.damping) > kSymmetric)) {
    why = p.second_order
              ? "Mr, Dr or Kr is not symmetric (a reduced modal truncation needs symmetric "
                "matrices)"
              : "Er or Ar is not symmetric (a reduced modal truncation needs symmetric matrices)";
    return std::nullopt;
  }
  const Matrix Ms = 0.5 * (p.mass + p.mass.transpose());
  const Matrix Ks = 0.5 * (p.stiffness + p.stiffness.transpose());
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> eig(Ks, Ms);
  if (eig.info() != Eigen::Success) {
    why = p.second_order ? "Mr is not positive definite" : "Er is not positive definite";
    return std::nullopt;
  }
  m.phi = eig.eigenvectors();
  const Index n = m.phi.cols();
  for (Index i = 0; i < n; ++i) m.lambda.push_back(eig.eigenvalues()(i));
  // A free body's reduced model keeps its rigid-body modes: the lowest rigid.count eigenvalues.
  m.rigid = p.second_order && rigid.count > 0 ? std::min<Index>(rigid.count, n) : 0;
  const std::vector<double> score = band_contributions(m, f_hz);
  std::vector<Index> rest(static_cast<std::size_t>(n - m.rigid));
  std::iota(rest.begin(), rest.end(), m.rigid);
  std::stable_sort(rest.begin(), rest.end(), [&](Index a, Index b) {
    return score[static_cast<std::size_t>(a)] > score[static_cast<std::size_t>(b)];
  });
  for (Index i = 0; i < m.rigid; ++i) m.order.push_back(i);
  m.order.insert(m.order.end(), rest.begin(), rest.end());
  return m;
}

// The accepted model projected onto S_V (right) and S_W (left) at the reduced level: V' = V S_V,
// W' = W S_W (W' empty where W was empty and S_W = S_V: still Galerkin).
ReducerResult projected(const ReducerResult& accepted, const Matrix& SV, const Matrix& SW,
                        bool galerkin) {
  ReducedModel c;
  if (const auto* r = std::get_if<ReducedSecondOrderModel>(&accepted.model)) {
    ReducedSecondOrderModel so;
    so.M = SW.transpose() * r->M * SV;
    so.D = SW.transpose() * r->D * SV;
    so.K = SW.transpose() * r->K * SV;
    so.B = SW.transpose() * r->B;
    so.C = r->C * SV;
    if (r->has_velocity_output()) so.Cv = r->Cv * SV;
    c = std::move(so);
  } else {
    const auto& ds = std::get<ReducedDescriptorModel>(accepted.model);
    ReducedDescriptorModel d;
    d.E = SW.transpose() * ds.E * SV;
    d.A = SW.transpose() * ds.A * SV;
    d.B = SW.transpose() * ds.B;
    d.C = ds.C * SV;
    c = std::move(d);
  }
  ReducerResult out;
  out.model = std::move(c);
  out.V = accepted.V * SV;
  if (accepted.W.size() == 0)
    out.W = galerkin ? Matrix() : Matrix(accepted.V * SW);
  else
    out.W = accepted.W * SW;
  out.points = accepted.points;
  out.diagnostics = accepted.diagnostics;
  out.note = accepted.note;
  return out;
}

// The Galerkin projection of the accepted model onto its leading `count` ranked modes (in
// ascending eigenvalue order) and, with `residual`, the static response of the modes left out to
// the inputs, R = sum_j phi_j phi_j' Br / lambda_j over them (at most m columns, orthonormalised
// in the Mr inner product; they lie in the span of the modes left out, so they are Mr-orthogonal
// to the modes kept): modal truncation with static correction, at the reduced level. The reduced
// matrices come from the accepted ones, V' = V S.
ReducerResult truncated(const ReducerResult& accepted, const Modes& m, Index count, bool residual) {
  const Pencil& p = m.pencil;
  std::vector<Index> keep(m.order.begin(), m.order.begin() + count);
  std::sort(keep.begin(), keep.end());
  Matrix S(m.phi.rows(), count);
  for (Index j = 0; j < count; ++j) S.col(j) = m.phi.col(keep[static_cast<std::size_t>(j)]);
  if (residual && count < m.phi.cols()) {
    Matrix R = Matrix::Zero(m.phi.rows(), p.B.cols());
    for (auto it = m.order.begin() + count; it != m.order.end(); ++it) {
      const double l = m.lambda[static_cast<std::size_t>(*it)];
      if (l > 0.0) R += m.phi.col(*it) * (m.phi.col(*it).transpose() * p.B) / l;
    }
    // Mass-orthonormal columns from the eigenvectors of R' M R, with rank truncation.
    const Matrix G = R.transpose() * p.mass * R;
    Eigen::SelfAdjointEigenSolver<Matrix> eig(0.5 * (G + G.transpose()));
    const double top = eig.eigenvalues().size() > 0 ? eig.eigenvalues().maxCoeff() : 0.0;
    std::vector<Index> cols;
    for (Index i = 0; i < eig.eigenvalues().size(); ++i)
      if (eig.eigenvalues()(i) > 1e-12 * top && top > 0.0) cols.push_back(i);
    if (!cols.empty()) {
      Matrix Q(R.rows(), static_cast<Index>(cols.size()));
      for (std::size_t k = 0; k < cols.size(); ++k)
        Q.col(static_cast<Index>(k)) =
            R * eig.eigenvectors().col(cols[k]) / std::sqrt(eig.eigenvalues()(cols[k]));
      Matrix T(S.rows(), S.cols() + Q.cols());
      T << S, Q;
      S = std::move(T);
    }
  }
  return projected(accepted, S, S, true);
}

// A family of compressed models, nested by `count`: make(count) for count in [min_count,
// max_count) is smaller than the accepted model (max_count: it has all of it).
struct Family {
  std::string method;
  // A projection that need not keep stability (one- or two-sided onto directions of an
  // unsymmetric model): its candidates are checked for it in the search too.
  bool may_lose_stability = false;
  Index min_count = 1, max_count = 0;
  std::function<ReducerResult(Index)> make;
  std::function<std::string(Index count, Index order)> describe;
};

// The accepted model's response-weighted subspaces: the reduced states Pr(s)^-1 Br of the band's
// samples (right) and the dual states Pr(s)^-H (Cr + s Cv)' (left), each sample divided by
// ||Hr(s)||_F (the error measure is relative), real and imaginary parts, ranked by their singular
// values (a truncated SVD of the basis weighted by the band's responses). Second order: the
// position parts, so that the compression keeps the second-order form. Computed through the
// complex Schur form of E1^-1 A1 of a first-order realisation (one O(n^3) decomposition, then a
// triangular solve per frequency). std::nullopt with `why` when E1 (Mr or Er) is singular.
struct PodBases {
  Matrix right, left;  // orthonormal columns, leading first
  Matrix both;         // of the right and left samples together (each set scaled to norm 1)
};

// Orthonormal leading left singular vectors of [Re S, Im S] (through the eigenvectors of its Gram
// matrix: columns with singular values above 1e-7 of the largest).
Matrix leading_directions(const ComplexMatrix& S) {
  const Matrix re = S.real(), im = S.imag();
  const Matrix G = re * re.transpose() + im * im.transpose();
  Eigen::SelfAdjointEigenSolver<Matrix> eig(0.5 * (G + G.transpose()));
  const Index n = G.rows();
  const double top = n > 0 ? eig.eigenvalues()(n - 1) : 0.0;
  Index rank = 0;
  while (rank < n && top > 0.0 && eig.eigenvalues()(n - 1 - rank) > 1e-14 * top) ++rank;
  Matrix U(n, rank);
  for (Index j = 0; j < rank; ++j) U.col(j) = eig.eigenvectors().col(n - 1 - j);
  return U;
}

std::optional<PodBases> pod_bases(const ReducedModel& model, const std::vector<double>& f_hz,
                                  std::string& why) {
  Matrix E1, A1, B1, C1;
  Index n = 0;
  bool second = false;
  if (const auto* r = std::get_if<ReducedSecondOrderModel>(&model)) {
    second = true;
    n = r->M.rows();
    E1 = Matrix::Identity(2 * n, 2 * n);
    E1.bottomRightCorner(n, n) = r->M;
    A1 = Matrix::Zero(2 * n, 2 * n);
    A1.topRightCorner(n, n).setIdentity();
    A1.bottomLeftCorner(n, n) = -r->K;
    A1.bottomRightCorner(n, n) = -r->D;
    B1 = Matrix::Zero(2 * n, r->B.cols());
    B1.bottomRows(n) = r->B;
    C1 = Matrix::Zero(r->C.rows(), 2 * n);
    C1.leftCols(n) = r->C;
    if (r->has_velocity_output()) C1.rightCols(n) = r->Cv;
  } else {
    const auto& d = std::get<ReducedDescriptorModel>(model);
    n = d.E.rows();
    E1 = d.E;
    A1 = d.A;
    B1 = d.B;
    C1 = d.C;
  }
  const Eigen::PartialPivLU<Matrix> lu(E1);
  if (!(lu.rcond() > 1e-12)) {
    why = second ? "Mr is singular" : "Er is singular (a descriptor model with algebraic states)";
    return std::nullopt;
  }
  const Eigen::PartialPivLU<Matrix> lu_t(E1.transpose());
  const Eigen::ComplexSchur<ComplexMatrix> schur(lu.solve(A1).cast<Complex>());
  if (schur.info() != Eigen::Success) {
    why = "the Schur form of the accepted model did not converge";
    return std::nullopt;
  }
  const ComplexMatrix& Q = schur.matrixU();
  const ComplexMatrix& R = schur.matrixT();
  const ComplexMatrix G = Q.adjoint() * lu.solve(B1).cast<Complex>();
  const ComplexMatrix L = Q.adjoint() * C1.transpose().cast<Complex>();
  const Index m = B1.cols(), p = C1.rows();
  const auto F = static_cast<Index>(f_hz.size());
  ComplexMatrix X(n, F * m), Z(n, F * p);
  Index used = 0;
  for (double f : f_hz) {
    const Complex s(0.0, kTwoPi * f);
    ComplexMatrix Rs = -R;
    Rs.diagonal().array() += s;
    const ComplexMatrix x = Q * Rs.triangularView<Eigen::Upper>().solve(G);
    const double scale = (C1.cast<Complex>() * x).norm();
    if (!(scale > 0.0) || !std::isfinite(scale)) continue;  // at a pole, or H vanishes
    const ComplexMatrix w = Q * Rs.adjoint().triangularView<Eigen::Lower>().solve(L);
    const ComplexMatrix z = lu_t.solve(w.real()).cast<Complex>() +
                            Complex(0.0, 1.0) * lu_t.solve(w.imag()).cast<Complex>();
    X.middleCols(used * m, m) = x.topRows(n) / scale;
    Z.middleCols(used * p, p) = z.bottomRows(n) / scale;
    ++used;
  }
  if (used == 0) {
    why = "the accepted model's response vanishes on the band's samples";
    return std::nullopt;
  }
  PodBases b;
  b.right = leading_directions(X.leftCols(used * m));
  b.left = leading_directions(Z.leftCols(used * p));
  ComplexMatrix XZ(n, used * (m + p));
  XZ << X.leftCols(used * m) / X.leftCols(used * m).norm(),
      Z.leftCols(used * p) / std::max(Z.leftCols(used * p).norm(), 1e-300);
  b.both = leading_directions(XZ);
  return b;
}

// The response-weighted family: one-sided (S_W = S_V, from the right and left samples together)
// for a Galerkin model, so that it stays one; two-sided for a Petrov-Galerkin one.
std::optional<Family> pod_family(const ReducerResult& accepted, const std::vector<double>& f_hz,
                                 std::string& why) {
  const bool galerkin = accepted.W.size() == 0 || accepted.W == accepted.V;
  auto bases = pod_bases(accepted.model, f_hz, why);
  if (!bases) return std::nullopt;
  Family fam;
  fam.may_lose_stability = true;
  const Index n = accepted.V.cols();
  if (galerkin) {
    const Matrix S = bases->both;
    fam.method = "reduced response-weighted projection (one-sided)";
    fam.max_count = std::min<Index>(n, S.cols());
    fam.make = [&accepted, S](Index k) {
      return projected(accepted, S.leftCols(k), S.leftCols(k), true);
    };
  } else {
    const Matrix SV = bases->right, SW = bases->left;
    fam.method = "reduced response-weighted projection (two-sided)";
    fam.max_count = std::min<Index>({n, SV.cols(), SW.cols()});
    fam.make = [&accepted, SV, SW](Index k) {
      return projected(accepted, SV.leftCols(k), SW.leftCols(k), false);
    };
  }
  fam.describe = [n](Index, Index order) {
    return fmt::format("{} -> {}: the {} leading directions of the accepted model's band responses",
                       n, order, order);
  };
  return fam;
}

// The modes of a first-order model, Er^-1 Ar = X diag(lambda) X^-1, ranked (pole_families()).
struct PoleModes {
  // A real pole i (partner -1), or the member i with Im > 0 of a conjugate pair and its partner.
  struct Mode {
    Index i = 0, partner = -1;
  };
  std::vector<Mode> ordered;  // by rank
  ComplexVector lambda;
  ComplexMatrix X;   // right eigenvectors
  ComplexMatrix Yh;  // X^-1 Er^-1: row i is the (conjugated) left eigenvector of pole i
  ComplexMatrix b;   // Yh Br: row i is b_i'
};

// The projection of the accepted model onto its leading `count` modes: right and left invariant
// subspaces (real and imaginary parts), so that its transfer function is the sum of the kept
// poles' terms. With `residual` both bases take one more vector per input: R = sum over the modes
// left out of x_i b_i' / (-lambda_i) (their static response, real) on the right and
// sum y_i conj(b_i' / (-lambda_i)) on the left. In the modal coordinates a of the modes left out
// this is the Galerkin projection of diag(lambda) onto span{diag(lambda)^-1 b}: it matches their
// static response (a moment at s = 0), and a^H diag(lambda) a keeps their poles' real parts
// negative, so the model stays stable. Orthonormal bases of the same spans are returned (the
// transfer function depends on the spans only).
ReducerResult pole_truncated(const ReducerResult& accepted, const PoleModes& m, Index count,
                             bool residual) {
  const Index n = m.X.rows(), inputs = m.b.cols();
  std::vector<bool> kept(static_cast<std::size_t>(n), false);
  Index states = 0;
  for (Index k = 0; k < count; ++k) {
    const PoleModes::Mode& mode = m.ordered[static_cast<std::size_t>(k)];
    for (Index i : {mode.i, mode.partner}) {
      if (i < 0) continue;
      kept[static_cast<std::size_t>(i)] = true;
      ++states;
    }
  }
  const bool correct = residual && states < n;
  const Index cols = states + (correct ? inputs : 0);
  Matrix SV(n, cols), SW(n, cols);
  Index col = 0;
  for (Index k = 0; k < count; ++k) {
    const PoleModes::Mode& mode = m.ordered[static_cast<std::size_t>(k)];
    const ComplexVector x = m.X.col(mode.i), y = m.Yh.row(mode.i).adjoint();
    SV.col(col) = x.real();
    SW.col(col) = y.real();
    if (mode.partner >= 0) {
      SV.col(col + 1) = x.imag();
      SW.col(col + 1) = y.imag();
    }
    col += mode.partner >= 0 ? 2 : 1;
  }
  if (correct) {
    ComplexMatrix R = ComplexMatrix::Zero(n, inputs), L = ComplexMatrix::Zero(n, inputs);
    for (Index i = 0; i < n; ++i) {
      if (kept[static_cast<std::size_t>(i)]) continue;
      const ComplexVector a = m.b.row(i).transpose() / (-m.lambda(i));
      R += m.X.col(i) * a.transpose();
      L += m.Yh.row(i).transpose() * a.adjoint();
    }
    SV.rightCols(inputs) = R.real();
    SW.rightCols(inputs) = L.real();
    // Scaled like the eigenvectors, so that the rank test below compares directions.
    for (Index j = states; j < cols; ++j) {
      for (Matrix* S : {&SV, &SW}) {
        const double norm = S->col(j).norm();
        if (norm > 0.0) S->col(j) /= norm;
      }
    }
  }
  Eigen::ColPivHouseholderQR<Matrix> qv(SV), qw(SW);
  if (correct && (qv.rank() < cols || qw.rank() < cols)) {
    // The static responses of the rest are dependent (an input that excites none of them):
    // the plain truncation.
    return pole_truncated(accepted, m, count, false);
  }
  const Matrix QV = qv.householderQ() * Matrix::Identity(n, cols);
  const Matrix QW = qw.householderQ() * Matrix::Identity(n, cols);
  return projected(accepted, QV, QW, false);
}

// The modal family of a first-order accepted model that is not a symmetric Galerkin one (a
// Petrov-Galerkin model: IRKA, two-sided Krylov or balanced truncation of a second-order model
// through its first-order realisation): Er^-1 Ar = X diag(lambda) X^-1, each mode (a real pole,
// or a conjugate pair counted once) ranked by its largest contribution to the response over the
// band relative to the response there, as band_contributions() ranks symmetric modes. The model
// of the leading `count` modes is the projection onto their right invariant subspace (real and
// imaginary parts of the eigenvectors) and their left one (of the rows of X^-1 Er^-1): its
// transfer function is the sum of the kept poles' terms, so it is stable whenever the accepted
// model is. std::nullopt with `why` when Er is singular or Er^-1 Ar not diagonalisable.
std::vector<Family> pole_families(const ReducerResult& accepted, std::vector<double> f_hz,
                                  std::string& why) {
  const auto* d = std::get_if<ReducedDescriptorModel>(&accepted.model);
  if (d == nullptr) {
    why = "a second-order Petrov-Galerkin model (its modal truncation is not second order)";
    return {};
  }
  const Index n = d->E.rows();
  const Eigen::PartialPivLU<Matrix> lu(d->E);
  if (!(lu.rcond() > 1e-12)) {
    why = "Er is singular (a descriptor model with algebraic states)";
    return {};
  }
  const Eigen::EigenSolver<Matrix> eig(Matrix(lu.solve(d->A)));
  if (eig.info() != Eigen::Success) {
    why = "the eigenvalues of the accepted model did not converge";
    return {};
  }
  const ComplexVector lambda = eig.eigenvalues();
  const ComplexMatrix X = eig.eigenvectors();
  const Eigen::PartialPivLU<ComplexMatrix> xlu(X);
  if (!(xlu.rcond() > 1e-10)) {
    why = "the accepted model is not diagonalisable to working precision";
    return {};
  }
  // Rows of X^-1 Er^-1: the left eigenvectors (conjugated); b_i, c_i the residue directions.
  const ComplexMatrix Yh = xlu.solve(lu.solve(Matrix::Identity(n, n)).cast<Complex>());
  const ComplexMatrix b = Yh * d->B.cast<Complex>();  // row i: b_i'
  const ComplexMatrix c = d->C.cast<Complex>() * X;   // column i: c_i
  std::vector<PoleModes::Mode> modes;
  std::vector<bool> taken(static_cast<std::size_t>(n), false);
  for (Index i = 0; i < n; ++i) {
    if (lambda(i).imag() < 0.0) continue;
    PoleModes::Mode m{i, -1};
    if (lambda(i).imag() > 0.0) {
      double nearest = std::numeric_limits<double>::infinity();
      for (Index j = 0; j < n; ++j) {
        const double dist = std::abs(lambda(j) - std::conj(lambda(i)));
        if (lambda(j).imag() < 0.0 && !taken[static_cast<std::size_t>(j)] && dist < nearest) {
          nearest = dist;
          m.partner = j;
        }
      }
      if (m.partner < 0) {
        why = "the accepted model's poles are not closed under conjugation";
        return {};
      }
      taken[static_cast<std::size_t>(m.partner)] = true;
    }
    modes.push_back(m);
  }
  for (const PoleModes::Mode& m : modes) {
    const double f = lambda(m.i).imag() / kTwoPi;
    if (f >= f_hz.front() && f <= f_hz.back()) f_hz.push_back(f);
  }
  std::vector<double> score(modes.size(), 0.0);
  for (double f : f_hz) {
    const Complex s(0.0, kTwoPi * f);
    ComplexMatrix H = ComplexMatrix::Zero(c.rows(), b.cols());
    for (Index i = 0; i < n; ++i) H += c.col(i) * b.row(i) / (s - lambda(i));
    const double scale = H.norm();
    if (!(scale > 0.0) || !std::isfinite(scale)) continue;
    for (std::size_t k = 0; k < modes.size(); ++k) {
      double term = 0.0;
      for (Index i : {modes[k].i, modes[k].partner}) {
        if (i >= 0)
          term = std::max(term, c.col(i).norm() * b.row(i).norm() / std::abs(s - lambda(i)));
      }
      score[k] = std::max(score[k], term / scale);
    }
  }
  std::vector<std::size_t> ranked(modes.size());
  std::iota(ranked.begin(), ranked.end(), 0);
  std::stable_sort(ranked.begin(), ranked.end(),
                   [&](std::size_t a, std::size_t q) { return score[a] > score[q]; });
  auto data = std::make_shared<PoleModes>();
  for (std::size_t k : ranked) data->ordered.push_back({modes[k].i, modes[k].partner});
  data->lambda = lambda;
  data->X = X;
  data->Yh = Yh;
  data->b = b;
  std::vector<Family> families;
  for (bool residual : {false, true}) {
    Family fam;
    fam.method = residual ? "reduced modal truncation with static correction (Petrov-Galerkin)"
                          : "reduced modal truncation (Petrov-Galerkin)";
    fam.max_count = static_cast<Index>(data->ordered.size());
    fam.make = [&accepted, data, residual](Index count) {
      return pole_truncated(accepted, *data, count, residual);
    };
    fam.describe = [n, residual](Index count, Index order) {
      return fmt::format(
          "{} -> {}: {} modes (real poles or conjugate pairs) of the accepted model "
          "kept{}",
          n, order, count, residual ? ", and the static response of the rest" : "");
    };
    families.push_back(std::move(fam));
  }
  return families;
}

// What the families compress onto, for the note of a compression that kept the accepted model.
std::string family_names(const std::vector<Family>& families) {
  std::vector<std::string> names;
  for (const Family& f : families) {
    const std::string what =
        f.method.find("modal") != std::string::npos ? "modes" : "band responses' directions";
    if (std::find(names.begin(), names.end(), what) == names.end()) names.push_back(what);
  }
  return fmt::format("{}", fmt::join(names, " or "));
}

// The families of smaller models inside a symmetric Galerkin model: its ranked modes, without and
// with the static correction of the rest (the rigid-body modes always kept).
std::vector<Family> modal_families(const ReducerResult& accepted,
                                   std::shared_ptr<const Modes> modes) {
  const Index n = accepted.V.cols();
  std::vector<Family> families;
  for (bool residual : {false, true}) {
    Family fam;
    fam.method =
        residual ? "reduced modal truncation with static correction" : "reduced modal truncation";
    fam.min_count = std::max<Index>(1, modes->rigid);
    fam.max_count = n;
    fam.make = [&accepted, modes, residual](Index count) {
      return truncated(accepted, *modes, count, residual);
    };
    fam.describe = [n, rigid_kept = modes->rigid, residual](Index count, Index order) {
      return fmt::format(
          "{} -> {}: {} of {} modes of the accepted model kept{}{}", n, order, count, n,
          rigid_kept > 0 ? fmt::format(", its {} rigid-body modes among them", rigid_kept)
                         : std::string(),
          residual ? fmt::format(", and {} static correction vector(s) for the rest", order - count)
                   : std::string());
    };
    families.push_back(std::move(fam));
  }
  return families;
}

// One compression (compress_accepted): its inputs, what it has spent, and its phases in order:
// the frequencies that rank the candidates, the families of smaller models, the bisection for
// each family's smallest count meeting the target, and the re-check against the full model.
class Compression {
 public:
  Compression(const ReducerResult& accepted, BandErrorEstimator& estimator,
              const ResponseCache& cache, double tolerance, Index verify_factor,
              const RigidBodyModes& rigid, CompressionReport& report, BandError& verified)
      : m_accepted(accepted),
        m_estimator(estimator),
        m_cache(cache),
        m_tolerance(tolerance),
        m_verify_factor(verify_factor),
        m_rigid(rigid),
        m_report(report),
        m_verified(verified),
        m_start(std::chrono::steady_clock::now()),
        m_factorizations_before(static_cast<std::int64_t>(cache.size())),
        m_n(accepted.V.cols()) {}

  std::optional<ReducerResult> run() {
    m_report.attempted = true;
    m_report.order_before = m_report.order_after = m_n;
    m_f_hz = ranking_frequencies();
    std::string why;
    const std::vector<Family> families = families_inside(why);
    if (families.empty()) return kept("kept the accepted model: " + why);
    m_report.method = families.front().method;
    Index count = m_n;
    const Family* chosen = smallest_family(families, count);
    if (chosen) {
      if (std::optional<ReducerResult> compressed = rechecked(*chosen, count)) return compressed;
      m_report.method = chosen->method;
      return kept(fmt::format(
          "kept the accepted model: the re-check refused the {} compressed model(s) tried",
          m_report.verifications));
    }
    return kept("kept the accepted model: no smaller model of its " + family_names(families) +
                " meets the target" +
                (m_unstable > 0 ? fmt::format(" ({} of the {} tried unstable)", m_unstable,
                                              m_report.candidates)
                                : std::string()));
  }

 private:
  // Where the band error of a candidate is known without new full solves: the estimator's grid
  // (dense mode: solved there; estimate mode: the reference's values) and the accepted model's
  // resonances in the band, where a truncation departs first (estimate mode: the reference's
  // values there; dense mode: a frequency already solved within a 32nd of the resonance's
  // relative half-width, as the band error's pole samples take them, else none). The frequencies
  // solved so far (thousands, after a grown Krylov run) are left to the re-check.
  std::vector<double> ranking_frequencies() const {
    const Band& band = m_estimator.band();
    std::vector<double> f_hz = m_estimator.grid();
    try {
      const ComplexVector p = poles(m_accepted.model);
      for (Index i = 0; i < p.size(); ++i) {
        const double f = p(i).imag() / kTwoPi;
        if (!(f >= band.f_min_hz && f <= band.f_max_hz)) continue;
        if (m_estimator.mode() == ErrorVerify::Estimate) {
          f_hz.push_back(f);
        } else if (const auto near =
                       m_cache.nearest_cached(f, std::abs(p(i).real()) / std::abs(p(i)) / 32.0)) {
          f_hz.push_back(*near);
        }
      }
    } catch (const NumericalError&) {
      // No poles: the grid alone ranks the candidates.
    }
    std::sort(f_hz.begin(), f_hz.end());
    f_hz.erase(std::unique(f_hz.begin(), f_hz.end()), f_hz.end());
    if (f_hz.size() < 2) f_hz = log_grid(band.f_min_hz, band.f_max_hz, 2);
    return f_hz;
  }

  // The families of smaller models inside the accepted one: its modes (ranked, without and with
  // the static correction of the rest) where it is a symmetric Galerkin model, else its poles
  // (first order) and its band responses' leading directions, the smaller model of the two. None
  // for a free body that is not symmetric Galerkin (its rigid-body modes are kept by the modal
  // family only), nor when no family applies; `why` then says why.
  std::vector<Family> families_inside(std::string& why) const {
    std::optional<Modes> modes = ranked_modes(m_accepted, m_rigid, m_f_hz, why);
    if (modes) {
      return modal_families(m_accepted, std::make_shared<const Modes>(std::move(*modes)));
    }
    if (m_rigid.count > 0) return {};
    std::string pole_why, pod_why;
    std::vector<Family> families = pole_families(m_accepted, m_f_hz, pole_why);
    if (auto fam = pod_family(m_accepted, m_f_hz, pod_why)) families.push_back(std::move(*fam));
    if (families.empty()) why += "; " + pole_why + "; " + pod_why;
    return families;
  }

  // A candidate counts when it meets the target on f_hz and, where its family may lose it, is
  // stable (no full solve is spent on either; a modal family of a symmetric definite model keeps
  // stability, which the re-check confirms). It is tried first where the last refused candidate
  // failed (its largest local maxima above the tolerance): a candidate failing there fails on
  // f_hz too (the test is a maximum over the samples), so it is refused after a handful of
  // evaluations instead of all of f_hz; one passing there is evaluated on f_hz. The decisions are
  // those of f_hz alone; the bisection's refused half costs little.
  bool meets(const Family& fam, Index count) {
    ++m_report.candidates;
    const ReducerResult candidate = fam.make(count);
    if (fam.may_lose_stability && !reduced_model_stability(candidate.model, m_rigid).accepted()) {
      ++m_unstable;
      return false;
    }
    if (!m_failed_at.empty() &&
        !m_estimator.evaluate_on(candidate.model, m_failed_at).within(m_tolerance))
      return false;
    const BandError e = m_estimator.evaluate_on(candidate.model, m_f_hz);
    if (e.within(m_tolerance)) return true;
    m_failed_at = largest_local_maxima_hz(e, 8, m_tolerance);
    return false;
  }

  // The smallest count meeting the target on f_hz, by bisection between lo and hi (hi meets it:
  // the whole accepted model when hi = n, else checked first); n when none does.
  Index smallest(const Family& fam, Index lo, Index hi) {
    if (lo > hi || lo >= m_n) return m_n;
    if (hi < m_n && !meets(fam, hi)) return m_n;
    while (lo < hi) {
      const Index mid = lo + (hi - lo) / 2;
      if (meets(fam, mid))
        hi = mid;
      else
        lo = mid + 1;
    }
    return lo;
  }

  // The family whose smallest model is smallest, with that model's count in `count`; nullptr
  // when no family has one smaller than the accepted model. (Each family is searched whole: the
  // static correction can make a truncation worse as well as better, so the count one family
  // needs says little about the other's; measured on iss_so_krylov, 73 with the corrected
  // family's count as the other's floor, 57 without.)
  const Family* smallest_family(const std::vector<Family>& families, Index& count) {
    const Family* chosen = nullptr;
    Index best_order = m_n;
    for (const Family& fam : families) {
      const Index c = smallest(fam, fam.min_count, std::min(fam.max_count, m_n));
      if (c >= m_n) continue;
      const Index order = fam.make(c).V.cols();
      if (order < best_order) {
        chosen = &fam;
        count = c;
        best_order = order;
      }
    }
    return chosen;
  }

  // The re-check against the full model (verify_near: every frequency solved so far, and new
  // solves at the candidate's largest departures from the accepted model, within the budget),
  // from `count` of the chosen family; on failure, step up by an eighth of the distance to n, then
  // halfway (four re-checks at most). The first model that passes, with its re-check in
  // `verified`, or std::nullopt.
  std::optional<ReducerResult> rechecked(const Family& chosen, Index count) {
    const Index top = std::min(chosen.max_count, m_n);
    for (Index attempt = 0; count < top && attempt < 4; ++attempt) {
      ReducerResult candidate = chosen.make(count);
      if (candidate.V.cols() >= m_n) break;
      // Stability first: it costs no full solve.
      const bool stable = reduced_model_stability(candidate.model, m_rigid).accepted();
      BandError check;
      if (stable) {
        ++m_report.verifications;
        const Index spent = static_cast<Index>(m_cache.size()) - m_factorizations_before;
        check = m_estimator.verify_near(candidate.model, m_accepted.model, m_report.error_before,
                                        m_tolerance, m_verify_factor,
                                        std::max<Index>(0, kCheckSolves - spent));
      }
      if (stable && check.within(m_tolerance))
        return applied(chosen, count, std::move(candidate), std::move(check));
      count += std::max<Index>(1, attempt == 0 ? (top - count) / 8 : (top - count + 1) / 2);
    }
    return std::nullopt;
  }

  // The compressed model that passed its re-check, with the report and its note.
  ReducerResult applied(const Family& chosen, Index count, ReducerResult candidate,
                        BandError check) {
    const Index order = candidate.V.cols();
    m_report.applied = true;
    m_report.method = chosen.method;
    m_report.order_after = order;
    m_report.error_after = check.sup_relative;
    m_report.note = fmt::format("{} (re-checked: {:.3e} at {:.4g} Hz)",
                                chosen.describe(count, order), check.sup_relative, check.f_peak_hz);
    candidate.note = m_accepted.note.empty() ? "compressed: " + m_report.note
                                             : m_accepted.note + "; compressed " + m_report.note;
    m_verified = std::move(check);
    finish();
    return candidate;
  }

  // The accepted model stays: the report says why.
  std::optional<ReducerResult> kept(std::string note) {
    m_report.note = std::move(note);
    finish();
    return std::nullopt;
  }

  // What the compression cost: its wall time and the full-model responses computed meanwhile.
  void finish() {
    m_report.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    m_report.factorizations = static_cast<std::int64_t>(m_cache.size()) - m_factorizations_before;
  }

  const ReducerResult& m_accepted;
  BandErrorEstimator& m_estimator;
  const ResponseCache& m_cache;
  const double m_tolerance;
  const Index m_verify_factor;
  const RigidBodyModes& m_rigid;
  CompressionReport& m_report;
  BandError& m_verified;
  const std::chrono::steady_clock::time_point m_start;
  const std::int64_t m_factorizations_before;
  const Index m_n;                  // order of the accepted model
  std::vector<double> m_f_hz;       // the frequencies that rank the candidates
  std::vector<double> m_failed_at;  // where the last refused candidate failed (meets())
  Index m_unstable = 0;             // candidates refused as unstable
};

}  // namespace

std::optional<ReducerResult> compress_accepted(const ReducerResult& accepted,
                                               BandErrorEstimator& estimator,
                                               const ResponseCache& cache, double tolerance,
                                               Index verify_factor, const RigidBodyModes& rigid,
                                               CompressionReport& report, BandError& verified) {
  return Compression(accepted, estimator, cache, tolerance, verify_factor, rigid, report, verified)
      .run();
}

}  // namespace ecmor::run
