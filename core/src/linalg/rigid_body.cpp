#include "ecmor/linalg/rigid_body.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <optional>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "ecmor/linalg/eigensolver.hpp"

namespace ecmor {

namespace {

// The symmetry rule of the structural stability test (stability.cpp): below it a matrix counts as
// symmetric and its Cholesky factorisation is meaningful.
constexpr double kSymmetry = 1e-10;
// Eigenpairs asked of the first Lanczos run: room for the 6 rigid-body modes of one free body and
// as many elastic ones; doubled while every computed eigenvalue is still below the ceiling
// (several free bodies in one model), up to kMaxEigenpairs.
constexpr Index kFirstEigenpairs = 12;
constexpr Index kMaxEigenpairs = 384;

/// M-orthonormalises the columns of X in place (classical Gram-Schmidt, twice).
void m_orthonormalise(Matrix& X, const SparseMatrix& M) {
  for (Index j = 0; j < X.cols(); ++j) {
    for (int pass = 0; pass < 2; ++pass) {
      const Vector Mx = M * X.col(j);
      for (Index i = 0; i < j; ++i) X.col(j) -= X.col(i).dot(Mx) * X.col(i);
    }
    const double norm = std::sqrt(X.col(j).dot(M * X.col(j)));
    if (norm > 0.0) X.col(j) /= norm;
  }
}

/// Rank of the symmetric damping block N' D N of the rigid-body modes: eigenvalues above 1e-8 of
/// the damping scale max_i D_ii / M_ii count (Rayleigh alpha > 0 gives alpha per mode, beta K
/// alone gives beta times a rounding-level eigenvalue).
Index damped_rank(const Matrix& N, const SparseMatrix& D, const SparseMatrix& M) {
  if (N.cols() == 0 || D.nonZeros() == 0) return 0;
  Matrix G = N.transpose() * (D * N);
  G = 0.5 * (G + G.transpose()).eval();
  const double scale_d = spectrum_scale(D, M);
  const Eigen::SelfAdjointEigenSolver<Matrix> eig(G, Eigen::EigenvaluesOnly);
  Index rank = 0;
  for (Index i = 0; i < eig.eigenvalues().size(); ++i)
    rank += std::abs(eig.eigenvalues()(i)) > 1e-8 * scale_d ? 1 : 0;
  return rank;
}

/// FNV-1a over the bytes of a sparse matrix's dimensions, pattern and values.
std::uint64_t fingerprint(const SparseMatrix& A, std::uint64_t h) {
  auto mix = [&h](const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ULL;
  };
  SparseMatrix c = A;
  c.makeCompressed();
  const Index dims[3] = {c.rows(), c.cols(), c.nonZeros()};
  mix(dims, sizeof dims);
  mix(c.outerIndexPtr(), sizeof(*c.outerIndexPtr()) * static_cast<std::size_t>(c.outerSize() + 1));
  mix(c.innerIndexPtr(), sizeof(*c.innerIndexPtr()) * static_cast<std::size_t>(c.nonZeros()));
  mix(c.valuePtr(), sizeof(*c.valuePtr()) * static_cast<std::size_t>(c.nonZeros()));
  return h;
}

/// One run asks for the same model's rigid-body modes up to three times (the driver, the modal or
/// balanced reducer, the full model's stability): a Cholesky factorisation, a shifted one and an
/// eigensolver run each, for a 3-D solid as much as the modal reduction's own factorisations. The
/// last result is kept, keyed by a fingerprint of every matrix it depends on (O(nnz)).
struct LastAnalysis {
  std::mutex mutex;
  std::optional<std::uint64_t> key;
  RigidBodyModes result;
};
LastAnalysis& last_analysis() {
  static LastAnalysis last;
  return last;
}

std::uint64_t model_key(const Model& model) {
  std::uint64_t h = 14695981039346656037ULL;
  if (const auto* so = std::get_if<SecondOrderModel>(&model)) {
    for (const SparseMatrix* X : {&so->K, &so->M, &so->D}) h = fingerprint(*X, h);
  } else {
    const auto& ds = std::get<DescriptorModel>(model);
    h = fingerprint(ds.A, fingerprint(ds.E, h ^ 1u));
  }
  return h;
}

RigidBodyModes analyse(const Model& model, ShiftedSolver& solver);

}  // namespace

double spectrum_scale(const SparseMatrix& A, const SparseMatrix& B) {
  double scale = 0.0;
  const Vector a = A.diagonal(), b = B.diagonal();
  for (Index i = 0; i < a.size(); ++i) {
    if (b(i) > 0.0) scale = std::max(scale, std::abs(a(i)) / b(i));
  }
  return scale > 0.0 ? scale : 1.0;
}

RigidBodyModes rigid_body_modes(const Model& model, ShiftedSolver& solver) {
  const std::uint64_t key = model_key(model);
  LastAnalysis& last = last_analysis();
  {
    const std::lock_guard<std::mutex> lock(last.mutex);
    if (last.key == key) return last.result;
  }
  RigidBodyModes r = analyse(model, solver);
  if (r.decided) {
    const std::lock_guard<std::mutex> lock(last.mutex);
    last.key = key;
    last.result = r;
  }
  return r;
}

std::string RigidBodyModes::describe() const {
  if (!decided) return "rigid-body modes not determined (" + method + ")";
  if (indefinite) return "no rigid-body mode, the stiffness is indefinite (" + method + ")";
  if (count == 0) return "no rigid-body mode (" + method + ")";
  return fmt::format("{} rigid-body mode{} ({})", count, count == 1 ? "" : "s", method);
}

namespace {

/// The stiffness pencil (Ks, Ms) the analysis works on: (K, M) of a second-order model, (-A, E)
/// of a descriptor model.
struct StiffnessPencil {
  explicit StiffnessPencil(const Model& model)
      : second(std::holds_alternative<SecondOrderModel>(model)) {
    if (second) {
      const auto& so = std::get<SecondOrderModel>(model);
      K = &so.K;
      M = &so.M;
    } else {
      const auto& ds = std::get<DescriptorModel>(model);
      negated_a = -ds.A;
      K = &negated_a;
      M = &ds.E;
    }
  }
  StiffnessPencil(const StiffnessPencil&) = delete;
  StiffnessPencil& operator=(const StiffnessPencil&) = delete;

  const char* k_name() const { return second ? "K" : "-A"; }
  const char* m_name() const { return second ? "M" : "E"; }

  bool second;
  SparseMatrix negated_a;  // -A of a descriptor model (K is used in place)
  const SparseMatrix* K = nullptr;
  const SparseMatrix* M = nullptr;
};

/// The lowest eigenvalues of the pencil and the largest gap among them.
struct LowSpectrum {
  SymmetricEigenResult eig;
  std::vector<double> x;  // sorted max(|lambda|, floor)
  Index below_gap = 0;    // the number of eigenvalues below the largest gap (0: none found)
  double gap = 0.0;       // the ratio across it
};

/// The gap test: the largest ratio between consecutive floored |lambda| among the candidates
/// (|lambda| <= ceiling). The eigenvalues come sorted by signed value; rounding-level negative
/// ones are candidates like their positive counterparts.
void find_gap(LowSpectrum& s, double floor, double ceiling) {
  const Index k = s.eig.eigenvalues.size();
  s.x.assign(static_cast<std::size_t>(k), 0.0);
  for (Index j = 0; j < k; ++j)
    s.x[static_cast<std::size_t>(j)] = std::max(std::abs(s.eig.eigenvalues(j)), floor);
  std::sort(s.x.begin(), s.x.end());
  s.below_gap = 0;
  s.gap = 0.0;
  for (Index j = 1; j < k; ++j) {
    const double below = s.x[static_cast<std::size_t>(j - 1)];
    if (below > ceiling) break;
    const double ratio = s.x[static_cast<std::size_t>(j)] / below;
    if (ratio > s.gap) {
      s.gap = ratio;
      s.below_gap = j;
    }
  }
}

/// Step 2 of analyse(): shift-invert Lanczos at sigma < 0 with a doubling number of eigenpairs
/// until a gap is found, an eigenvalue above the ceiling is known (no gap can follow among
/// candidates), or nothing more can be computed. Stops early on a negative eigenvalue below
/// -ceiling (indefinite).
LowSpectrum lowest_spectrum(ShiftedSolver& solver, const StiffnessPencil& pencil, double sigma,
                            double floor, double ceiling) {
  const Index n = pencil.K->rows();
  std::vector<Complex> w(pencil.second ? 3 : 2, Complex(0.0, 0.0));
  w[0] = 1.0;
  w[pencil.second ? 2 : 1] = -sigma;
  const auto F = solver.factorize_combination(w);
  LowSpectrum s;
  for (Index nev = std::min(kFirstEigenpairs, n - 1);; nev = std::min(2 * nev, n - 1)) {
    EigenOptions options;
    options.nev = nev;
    options.seed = 1;
    s.eig = symmetric_shift_invert(*F, *pencil.M, sigma, options);
    const Index k = s.eig.eigenvalues.size();
    if (k > 0 && s.eig.eigenvalues(0) < -ceiling) break;  // indefinite: decided by the caller
    find_gap(s, floor, ceiling);
    if (s.gap >= kRigidGap || k == 0 || s.x.back() > ceiling || nev >= n - 1 ||
        nev >= kMaxEigenpairs)
      break;
  }
  return s;
}

/// A 1 x 1 K that is not positive definite: its one eigenvalue is the ratio itself.
void analyse_scalar(const StiffnessPencil& pencil, RigidBodyModes& r) {
  const Index n = pencil.K->rows();
  const double lambda = n == 1 ? pencil.K->coeff(0, 0) / pencil.M->coeff(0, 0) : 0.0;
  r.decided = true;
  r.indefinite = lambda < 0.0;
  r.count = lambda < 0.0 ? 0 : n;
  r.zero_poles = pencil.second ? 2 * r.count : r.count;
  if (r.count > 0) {
    r.basis = Matrix::Constant(1, 1, 1.0 / std::sqrt(pencil.M->coeff(0, 0)));
    r.rigid_eigenvalues = Vector::Constant(1, lambda);
    r.zero_bound = kRigidFloor * r.scale;
  }
  r.method = fmt::format("{} is 1 x 1 and not positive", pencil.k_name());
}

/// The rigid-body eigenpairs: the s.below_gap eigenvalues of least modulus, M-orthonormal.
void take_rigid_modes(const Model& model, const StiffnessPencil& pencil, const LowSpectrum& s,
                      RigidBodyModes& r) {
  const Vector& lambda = s.eig.eigenvalues;  // ascending
  const Index k = lambda.size();
  r.count = s.below_gap;
  std::vector<Index> order(static_cast<std::size_t>(k));
  for (Index j = 0; j < k; ++j) order[static_cast<std::size_t>(j)] = j;
  std::stable_sort(order.begin(), order.end(),
                   [&](Index a, Index b) { return std::abs(lambda(a)) < std::abs(lambda(b)); });
  r.basis.resize(pencil.K->rows(), r.count);
  r.rigid_eigenvalues.resize(r.count);
  for (Index j = 0; j < r.count; ++j) {
    const Index i = order[static_cast<std::size_t>(j)];
    r.basis.col(j) = s.eig.eigenvectors.col(i);
    r.rigid_eigenvalues(j) = lambda(i);
  }
  m_orthonormalise(r.basis, *pencil.M);
  const double largest_rigid = s.x[static_cast<std::size_t>(s.below_gap - 1)];
  r.first_elastic = s.x[static_cast<std::size_t>(s.below_gap)];
  r.zero_bound = std::sqrt(largest_rigid * r.first_elastic);
  r.zero_poles =
      pencil.second
          ? 2 * r.count - damped_rank(r.basis, std::get<SecondOrderModel>(model).D, *pencil.M)
          : r.count;
}

RigidBodyModes analyse(const Model& model, ShiftedSolver& solver) {
  RigidBodyModes r;
  const StiffnessPencil pencil(model);
  r.second_order = pencil.second;
  const SparseMatrix& Ks = *pencil.K;
  const SparseMatrix& Ms = *pencil.M;
  const char* k_name = pencil.k_name();
  if (!(relative_asymmetry(Ks) <= kSymmetry) || !(relative_asymmetry(Ms) <= kSymmetry)) {
    r.method =
        fmt::format("{} or {} is not symmetric: no rigid-body analysis", k_name, pencil.m_name());
    return r;
  }
  if (!is_positive_definite(Ms)) {
    // A singular E (a DAE) or massless degrees of freedom: (K, M) has infinite eigenvalues, and
    // Lanczos on it need not converge (mna1: minutes without an answer). Such models are judged
    // by their poles alone.
    r.method = fmt::format(
        "{} is not positive definite (a DAE or massless degrees of freedom): "
        "no rigid-body analysis",
        pencil.m_name());
    return r;
  }
  r.scale = spectrum_scale(Ks, Ms);
  // Step 1: a positive definite K has no null space, whatever its condition number.
  if (is_positive_definite(Ks)) {
    r.decided = true;
    r.positive_definite = true;
    r.method =
        fmt::format("the Cholesky factorisation of {} succeeded: it is positive definite", k_name);
    return r;
  }
  if (Ks.rows() < 2) {
    analyse_scalar(pencil, r);
    return r;
  }
  // Step 2: the lowest eigenvalues, by shift-invert at sigma < 0 (K - sigma M is positive definite
  // for a positive semidefinite K, so the factorisation exists for a free body). sigma sits between
  // the floor and the ceiling (geometric mean): far enough from 0 that K - sigma M is well
  // conditioned (1 / 3e-10), near enough that the soft elastic modes of long free structures
  // (1e-10 .. 1e-8 of the scale) are well separated in the shift-inverted spectrum; at sigma =
  // -ceiling they all map to nearly the same 1 / (lambda - sigma) and Lanczos converges slowly.
  const double floor = kRigidFloor * r.scale;
  const double ceiling = kRigidCeiling * r.scale;
  const double sigma = -std::sqrt(kRigidFloor * kRigidCeiling) * r.scale;
  LowSpectrum s;
  try {
    s = lowest_spectrum(solver, pencil, sigma, floor, ceiling);
  } catch (const Interrupted&) {
    throw;  // a stop request is not a finding about the model
  } catch (const Error& e) {
    r.method = fmt::format(
        "{} is not positive definite, and the eigenvalues near 0 could not be "
        "computed: {}",
        k_name, e.what());
    return r;
  }
  r.decided = true;
  const Vector& lambda = s.eig.eigenvalues;  // ascending
  const Index k = lambda.size();
  if (k > 0 && lambda(0) < -ceiling) {
    r.indefinite = true;
    r.method = fmt::format("{} has the negative eigenvalue {:.4g} (spectrum scale {:.4g})", k_name,
                           lambda(0), r.scale);
    return r;
  }
  if (s.below_gap == 0 || s.gap < kRigidGap) {
    // Not positive definite by Cholesky, but no eigenvalue separated from the rest: a numerically
    // singular but elastic K (condition beyond 1 / (N eps)), or all computed ones are candidates.
    r.method = fmt::format(
        "{} is numerically singular for Cholesky, but its lowest eigenvalues ({} computed, "
        "{:.4g} .. {:.4g}, spectrum scale {:.4g}) show no gap of {:g} above the rounding floor: "
        "no rigid-body mode",
        k_name, k, k > 0 ? lambda(0) : 0.0, k > 0 ? lambda(k - 1) : 0.0, r.scale, kRigidGap);
    return r;
  }
  take_rigid_modes(model, pencil, s, r);
  r.method = fmt::format(
      "{} is singular: {} eigenvalue{} of ({}, {}) at most {:.3g} of the spectrum scale {:.4g}, "
      "the next {:.4g} times larger (shift-invert Lanczos at sigma = {:.3g})",
      k_name, r.count, r.count == 1 ? "" : "s", k_name, pencil.m_name(),
      s.x[static_cast<std::size_t>(s.below_gap - 1)] / r.scale, r.scale, s.gap, sigma);
  return r;
}

}  // namespace

RigidBodyModes rigid_body_modes(const Model& model) {
  std::unique_ptr<ShiftedSolver> solver = make_shifted_solver(model);
  return rigid_body_modes(model, *solver);
}

}  // namespace ecmor
