// Tests of the "modal" reducer plugin, loaded through the registry like any plugin. References are
// dense Eigen eigensolvers on the same (small) pencils, analytic chain spectra and the exact static
// response C K^-1 B; bases are compared by principal angles, never by entries.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "common/builders.hpp"
#include "common/dense_reference.hpp"
#include "common/plugin_registry.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"

namespace ecmor {
namespace {

using test::shared_model;

// ---- helpers ----------------------------------------------------------------------------------

Registry& registry() { return test::plugin_registry("libecmor_modal.so"); }

struct Fixture {
  Model model;
  std::unique_ptr<ShiftedSolver> solver;
  std::shared_ptr<Reducer> reducer;
};

// model must be stored before the solver is made (the solver references it).
std::unique_ptr<Fixture> make(Model model, Band band, const ParameterMap& params) {
  auto f = std::make_unique<Fixture>();
  f->model = std::move(model);
  f->solver = make_shifted_solver(f->model);
  f->reducer = registry().create("modal", params);
  ReductionContext ctx;
  ctx.model = &f->model;
  ctx.solver = f->solver.get();
  ctx.band = band;
  f->reducer->setup(ctx);
  return f;
}

ParameterMap params(bool static_correction, int batch_size = 20) {
  ParameterMap p("reducer 'modal'");
  p.set("static_correction", static_correction);
  p.set("batch_size", batch_size);
  return p;
}

// Band in Hz from the models' suggested angular band (info.json lists rad/s).
Band band_rad(double w_min, double w_max) { return {w_min / kTwoPi, w_max / kTwoPi}; }

double largest_angle_sin(const Matrix& X, const Matrix& Y) {
  const Matrix Qx =
      Eigen::HouseholderQR<Matrix>(X).householderQ() * Matrix::Identity(X.rows(), X.cols());
  const Matrix Qy =
      Eigen::HouseholderQR<Matrix>(Y).householderQ() * Matrix::Identity(Y.rows(), Y.cols());
  return Eigen::JacobiSVD<Matrix>(Matrix(Qx - Qy * (Qy.transpose() * Qx))).singularValues()(0);
}

// The ranking the plugin documents (README): rigid first, then modes within the band margin by log
// distance to the band (ascending f on ties), then the rest by ascending f. Written from the spec.
// Returns all indices in rank order.
std::vector<Index> ranked_by_frequency(const std::vector<double>& f_hz,
                                       const std::vector<bool>& rigid, const Band& band,
                                       double margin) {
  struct K {
    int tier;
    double d, f;
    Index j;
  };
  std::vector<K> keys;
  for (std::size_t j = 0; j < f_hz.size(); ++j) {
    const double f = f_hz[j];
    const auto jj = static_cast<Index>(j);
    if (rigid[j]) {
      keys.push_back({0, 0, f, jj});
    } else if (f < band.f_min_hz / margin || f > band.f_max_hz * margin) {
      keys.push_back({2, 0, f, jj});
    } else {
      const double d = f < band.f_min_hz   ? std::log(band.f_min_hz / f)
                       : f > band.f_max_hz ? std::log(f / band.f_max_hz)
                                           : 0.0;
      keys.push_back({1, d, f, jj});
    }
  }
  std::stable_sort(keys.begin(), keys.end(), [](const K& a, const K& b) {
    return std::tie(a.tier, a.d, a.f) < std::tie(b.tier, b.d, b.f);
  });
  std::vector<Index> out;
  for (const K& k : keys) out.push_back(k.j);
  return out;
}

// The first `count` modes of the symmetric pencil with eigenvalues lambda (f = sqrt(lambda)/2pi).
std::vector<Index> expected_selection(const Vector& lambda, const Band& band, double margin,
                                      double rigid_abs, Index count) {
  std::vector<double> f;
  std::vector<bool> rigid;
  for (Index j = 0; j < lambda.size(); ++j) {
    f.push_back(std::sqrt(std::max(lambda[j], 0.0)) / kTwoPi);
    rigid.push_back(std::abs(lambda[j]) <= rigid_abs);
  }
  std::vector<Index> all = ranked_by_frequency(f, rigid, band, margin);
  all.resize(static_cast<std::size_t>(count));
  return all;
}

// Checks that V holds M-orthonormal eigenvectors of (K, M), each matching the dense eigenpair with
// the nearest eigenvalue; returns their Rayleigh quotients.
Vector check_modes(const SecondOrderModel& m, const Matrix& V,
                   const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix>& dense,
                   double value_tol) {
  const Index n = V.cols();
  const Matrix gram = V.transpose() * (m.M * V);
  EXPECT_LT((gram - Matrix::Identity(n, n)).cwiseAbs().maxCoeff(), 1e-11) << "M-orthonormality";
  const double k_norm = Matrix(m.K).norm();
  const double scale = dense.eigenvalues().cwiseAbs().maxCoeff();
  Vector rq(n);
  for (Index j = 0; j < n; ++j) {
    const Vector phi = V.col(j);
    rq[j] = phi.dot(m.K * phi);
    const double res = (m.K * phi - rq[j] * (m.M * phi)).norm() / (k_norm * phi.norm());
    EXPECT_LT(res, 1e-12) << "residual of column " << j;
    Index best = 0;
    for (Index k = 1; k < dense.eigenvalues().size(); ++k) {
      if (std::abs(dense.eigenvalues()[k] - rq[j]) < std::abs(dense.eigenvalues()[best] - rq[j]))
        best = k;
    }
    EXPECT_NEAR(rq[j], dense.eigenvalues()[best],
                value_tol * std::max(std::abs(dense.eigenvalues()[best]), 1e-14 * scale))
        << "column " << j;
  }
  return rq;
}

// H(0) of a reduced second-order model: C Kr^-1 Br.
Matrix reduced_static(const ReducedModel& r) {
  const auto& so = std::get<ReducedSecondOrderModel>(r);
  return so.C * so.K.partialPivLu().solve(so.B);
}

// Free-floating chain of n unit masses and unit springs (no ground): K singular, one rigid mode.
// Spectrum: lambda_j = 4 sin^2(j pi / (2 n)), j = 0 .. n-1.
SecondOrderModel free_chain(Index n) {
  std::vector<Eigen::Triplet<double, int>> t;
  for (int i = 0; i + 1 < n; ++i) {
    t.emplace_back(i, i, 1.0);
    t.emplace_back(i + 1, i + 1, 1.0);
    t.emplace_back(i, i + 1, -1.0);
    t.emplace_back(i + 1, i, -1.0);
  }
  SecondOrderModel m;
  m.K.resize(n, n);
  m.K.setFromTriplets(t.begin(), t.end());
  m.M.resize(n, n);
  m.M.setIdentity();
  m.D = 0.01 * m.K;
  m.B = Matrix::Zero(n, 1);
  m.B(0, 0) = 1.0;
  m.C = Matrix::Zero(1, n);
  m.C(0, n - 1) = 1.0;
  return m;
}

// ---- eigenpairs -------------------------------------------------------------------------------

TEST(Modal, Lf10AllModesMatchDenseEigenpairs) {
  auto f = make(shared_model("lf10"), band_rad(1e2, 1e7), params(false));
  const auto& m = std::get<SecondOrderModel>(f->model);
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> dense{Matrix(m.K), Matrix(m.M)};
  const ReducerResult r = f->reducer->reduce({18, {}});
  ASSERT_EQ(r.V.cols(), 18);
  const Vector rq = check_modes(m, r.V, dense, 1e-10);
  // All 18 distinct eigenvalues appear once: sorted Rayleigh quotients = dense spectrum.
  Vector sorted = rq;
  std::sort(sorted.data(), sorted.data() + sorted.size());
  for (Index j = 0; j < 18; ++j) {
    EXPECT_NEAR(sorted[j], dense.eigenvalues()[j], 1e-10 * dense.eigenvalues()[j]) << j;
    // One mode at a time (the lf10 spectrum is simple).
    Index col = 0;
    while (rq[col] != sorted[j]) ++col;
    EXPECT_LT(largest_angle_sin(r.V.col(col), dense.eigenvectors().col(j)), 1e-8) << j;
  }
  // Reduced model: Mr = I, Kr = diag(lambda).
  const auto& red = std::get<ReducedSecondOrderModel>(r.model);
  EXPECT_LT((red.M - Matrix::Identity(18, 18)).cwiseAbs().maxCoeff(), 1e-11);
  EXPECT_LT((red.K - Matrix(rq.asDiagonal())).cwiseAbs().maxCoeff(), 1e-11 * rq.maxCoeff());
}

// A band in the middle of the spectrum, between the eigenfrequencies of modes lo and hi (0-based,
// ascending), so that the selection differs from "lowest modes first".
Band mid_band(const Vector& lambda, Index lo, Index hi) {
  return {std::sqrt(lambda[lo]) / kTwoPi, std::sqrt(lambda[hi]) / kTwoPi};
}

TEST(Modal, TriplechainSelectsBandModesLikeTheDenseReference) {
  const Model model = shared_model("triplechain_saak09_n451");
  const auto& m0 = std::get<SecondOrderModel>(model);
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> dense{Matrix(m0.K), Matrix(m0.M)};
  const Band band = mid_band(dense.eigenvalues(), 150, 170);
  auto f = make(model, band, params(false, 12));
  const auto& m = std::get<SecondOrderModel>(f->model);
  const Index n = 40;
  const ReducerResult r = f->reducer->reduce({n, {}});
  ASSERT_EQ(r.V.cols(), n);
  check_modes(m, r.V, dense, 1e-10);
  const std::vector<Index> sel = expected_selection(dense.eigenvalues(), band, 10.0, 0.0, n);
  Matrix ref(m.K.rows(), n);
  for (Index k = 0; k < n; ++k)
    ref.col(k) = dense.eigenvectors().col(sel[static_cast<std::size_t>(k)]);
  EXPECT_LT(largest_angle_sin(r.V, ref), 1e-8);
  EXPECT_GT(r.diagnostics.at("batches"), 1.0) << "the slicing must have been exercised";
}

TEST(Modal, NestedAndIncrementalGrowthEqualsFreshComputation) {
  // A band high in the spectrum: its modes lie many slices above sigma_0.
  const Model model = shared_model("triplechain_saak09_n451");
  const auto& m0 = std::get<SecondOrderModel>(model);
  const Band band = mid_band(Eigen::GeneralizedSelfAdjointEigenSolver<Matrix>(
                                 Matrix(m0.K), Matrix(m0.M), Eigen::EigenvaluesOnly)
                                 .eigenvalues(),
                             100, 110);
  auto grown = make(model, band, params(false, 8));
  const ReducerResult r10 = grown->reducer->reduce({10, {}});
  const ReducerResult r25 = grown->reducer->reduce({25, {}});
  const ReducerResult r60 = grown->reducer->reduce({60, {}});
  // Nested: leading columns of larger orders span the smaller bases.
  EXPECT_LT(largest_angle_sin(r10.V, r25.V.leftCols(10)), 1e-12);
  EXPECT_LT(largest_angle_sin(r25.V, r60.V.leftCols(25)), 1e-12);
  // Re-requesting a smaller order computes nothing new.
  const double batches = r60.diagnostics.at("batches");
  const ReducerResult again = grown->reducer->reduce({25, {}});
  EXPECT_EQ(again.diagnostics.at("batches"), batches);
  EXPECT_LT(largest_angle_sin(again.V, r25.V), 1e-12);

  auto fresh = make(model, band, params(false, 8));
  const ReducerResult f60 = fresh->reducer->reduce({60, {}});
  EXPECT_LT(largest_angle_sin(r60.V, f60.V), 1e-8);
}

TEST(Modal, FreeFloatingChainReturnsTheRigidModeFirst) {
  const Index n = 80;
  auto f = make(Model(free_chain(n)), Band{1e-3, 0.1}, params(false, 10));
  const ReducerResult r = f->reducer->reduce({12, {}});
  ASSERT_EQ(r.V.cols(), 12);
  EXPECT_EQ(r.diagnostics.at("rigid_modes"), 1.0);
  EXPECT_LT(largest_angle_sin(r.V.col(0), Vector::Ones(n)), 1e-8);
  const auto& red = std::get<ReducedSecondOrderModel>(r.model);
  EXPECT_LT(std::abs(red.K(0, 0)), 1e-10);
  // Elastic modes: analytic free-free chain eigenvalues, all in the band here ascending.
  std::vector<double> got;
  for (Index j = 1; j < 12; ++j) got.push_back(red.K(j, j));
  std::sort(got.begin(), got.end());
  for (Index j = 1; j < 12; ++j) {
    const double s = std::sin(static_cast<double>(j) * kPi / (2.0 * n));
    EXPECT_NEAR(got[static_cast<std::size_t>(j - 1)], 4 * s * s, 1e-10 * 4 * s * s) << j;
  }
  EXPECT_NE(r.note.find("1 rigid"), std::string::npos) << r.note;
}

// 20 identical decoupled oscillators: one eigenvalue (4) of multiplicity 20. ARPACK's Lanczos
// finds a few copies of it; the slices above the spectrum then return Ritz pairs that are not
// eigenpairs. Before, those were taken as modes (residuals up to 1e18, "rigid" and 1e9 Hz modes)
// and the slicing climbed for 75 batches; now they are dropped, the slicing stops after three
// empty slices, and the reducer says how many modes it has.
TEST(Modal, MultipleEigenvalueEndsTheSlicingWithOnlyTrueModes) {
  const Index n = 20;
  SecondOrderModel m;
  m.M = SparseMatrix(n, n);
  m.M.setIdentity();
  m.K = 4.0 * m.M;
  m.D = 0.1 * m.M;
  m.B = Matrix::Ones(n, 1);
  m.C = Matrix::Ones(1, n);
  auto f = make(Model(m), Band{0.01, 1.0}, params(false, 3));
  const ReducerResult r = f->reducer->reduce({n, {}});
  EXPECT_LT(r.V.cols(), n);
  EXPECT_GE(r.V.cols(), 1);
  EXPECT_LT(r.diagnostics.at("max_eigen_residual"), 1e-10);
  EXPECT_EQ(r.diagnostics.at("rigid_modes"), 0.0);
  EXPECT_LT(r.diagnostics.at("batches"), 12.0);
  const auto& red = std::get<ReducedSecondOrderModel>(r.model);
  for (Index j = 0; j < red.K.rows(); ++j) EXPECT_NEAR(red.K(j, j), 4.0, 1e-10) << j;
  EXPECT_NE(r.note.find("spectrum slicing found"), std::string::npos) << r.note;
  EXPECT_NE(r.note.find(fmt::format("order {} requested, {} available", n, r.V.cols())),
            std::string::npos)
      << r.note;
}

// ---- static correction ------------------------------------------------------------------------

TEST(Modal, StaticCorrectionReproducesTheStaticResponse) {
  const Band band = band_rad(1e-4, 1e2);
  const Model model = shared_model("triplechain_saak09_n451");
  const auto& m = std::get<SecondOrderModel>(model);
  // Independent of the plugin and the shifted solver: Eigen's sparse LDL'.
  const Matrix h0 = m.C * Matrix(Eigen::SimplicialLDLT<SparseMatrix>(m.K).solve(m.B));
  auto with = make(model, band, params(true));
  auto without = make(model, band, params(false));
  for (const Index n : {2, 6, 15}) {
    const ReducerResult rw = with->reducer->reduce({n, {}});
    const ReducerResult ro = without->reducer->reduce({n, {}});
    EXPECT_EQ(rw.V.cols(), n);
    EXPECT_EQ(rw.diagnostics.at("static_columns"), 1.0);
    const double err_with = (reduced_static(rw.model) - h0).norm() / h0.norm();
    const double err_without = (reduced_static(ro.model) - h0).norm() / h0.norm();
    EXPECT_LT(err_with, 1e-10) << "order " << n;
    EXPECT_GT(err_without, 1e-6) << "order " << n << ": plain truncation should miss H(0)";
    // The static column is M-orthogonal to the modes: Mr = I still.
    const auto& red = std::get<ReducedSecondOrderModel>(rw.model);
    EXPECT_LT((red.M - Matrix::Identity(n, n)).cwiseAbs().maxCoeff(), 1e-11);
  }
  // Order 1 = m: no room for a mode and the static column: one mode, said in the note.
  const ReducerResult r1 = with->reducer->reduce({1, {}});
  EXPECT_EQ(r1.V.cols(), 1);
  EXPECT_NE(r1.note.find("static correction omitted"), std::string::npos) << r1.note;
}

// ---- mixed basis: a modal block and Krylov columns at expansion points -------------------------

// H(s) = C P(s)^-1 B and H'(s) = -C P^-1 (2 s M + D) P^-1 B of a SISO second-order model of
// either size, by dense LU (independent of the shifted solver).
std::pair<Complex, Complex> dense_h_and_derivative(const Matrix& M, const Matrix& D,
                                                   const Matrix& K, const Matrix& B,
                                                   const Matrix& C, Complex s) {
  const ComplexMatrix P = (s * s) * M.cast<Complex>() + s * D.cast<Complex>() + K.cast<Complex>();
  const auto lu = P.partialPivLu();
  const ComplexMatrix x = lu.solve(B.cast<Complex>());
  const ComplexMatrix dx =
      lu.solve(ComplexMatrix(-((2.0 * s) * M.cast<Complex>() + D.cast<Complex>()) * x));
  return {(C.cast<Complex>() * x)(0, 0), (C.cast<Complex>() * dx)(0, 0)};
}

TEST(Modal, MixedBasisLeadsWithTheModalBlockAndInterpolatesAtItsPoints) {
  // 60 unit masses, Rayleigh damping: modes up to 2 sqrt(k) / 2 pi = 10 Hz, all in the band.
  const SecondOrderModel chain = test::spring_chain(60, 1e3, 0.05, 1e-4);
  const Band band{0.1, 10.0};
  auto f = make(Model(chain), band, params(true));
  const ReducerResult block = f->reducer->reduce({12, {}});
  const ExpansionPoint p1{Complex(0.0, kTwoPi * 2.0), 2}, p2{Complex(0.0, kTwoPi * 5.5), 1};
  const ReducerResult mixed = f->reducer->reduce({0, {p1, p2}, 12});
  // SISO: each moment of a complex point gives its real and imaginary part.
  ASSERT_EQ(mixed.V.cols(), 12 + 2 * 2 + 2);
  EXPECT_EQ(mixed.diagnostics.at("block_columns"), 12.0);
  EXPECT_EQ(mixed.diagnostics.at("krylov_columns"), 6.0);
  EXPECT_LT(largest_angle_sin(block.V, mixed.V.leftCols(12)), 1e-12);
  const auto& red = std::get<ReducedSecondOrderModel>(mixed.model);
  EXPECT_LT((red.M - Matrix::Identity(18, 18)).cwiseAbs().maxCoeff(), 1e-10);  // M-orthonormal
  // One-sided projection: H_r matches H at each point and its conjugate, and H' where 2 moments.
  const Matrix M(chain.M), D(chain.D), K(chain.K);
  for (const ExpansionPoint& p : {p1, p2}) {
    for (const Complex s : {p.s, std::conj(p.s)}) {
      const auto [h, dh] = dense_h_and_derivative(M, D, K, chain.B, chain.C, s);
      const auto [hr, dhr] = dense_h_and_derivative(red.M, red.D, red.K, red.B, red.C, s);
      EXPECT_LT(std::abs(hr - h), 1e-8 * std::abs(h)) << "at s = " << s;
      if (p.moments >= 2) {
        EXPECT_LT(std::abs(dhr - dh), 1e-6 * std::abs(dh)) << "H' at " << s;
      }
    }
  }
  // order caps the basis and keeps its first columns.
  const ReducerResult capped = f->reducer->reduce({14, {p1, p2}, 12});
  ASSERT_EQ(capped.V.cols(), 14);
  EXPECT_LT(largest_angle_sin(mixed.V.leftCols(14), capped.V), 1e-10);
  // Without a block: Krylov columns only, still interpolating (the conformance suite's case).
  const ReducerResult krylov = f->reducer->reduce({0, {p2}});
  EXPECT_EQ(krylov.V.cols(), 2);
}

// The general descriptor path (unsymmetric pencil): the block is Petrov-Galerkin, and the
// Krylov columns join V and W alike. H_r interpolates H at the point (they lie in span V).
TEST(Modal, MixedBasisOnTheGeneralDescriptorPathInterpolatesAtItsPoints) {
  const Model model = shared_model("build");
  const auto& d = std::get<DescriptorModel>(model);
  auto f = make(model, band_rad(1e-1, 1e3), params(false));
  const ExpansionPoint p{Complex(0.0, 5.0), 1};
  const ReducerResult block = f->reducer->reduce({6, {}});
  const ReducerResult r = f->reducer->reduce({0, {p}, 6});
  ASSERT_EQ(r.V.cols(), block.V.cols() + 2);
  EXPECT_LT(largest_angle_sin(block.V, r.V.leftCols(block.V.cols())), 1e-12);
  const Matrix E(d.E), A(d.A);
  for (const Complex s : {p.s, std::conj(p.s)}) {
    const ComplexMatrix P = s * E.cast<Complex>() - A.cast<Complex>();
    const ComplexMatrix h = d.C.cast<Complex>() * P.partialPivLu().solve(d.B.cast<Complex>());
    const auto& red = std::get<ReducedDescriptorModel>(r.model);
    const ComplexMatrix Pr = s * red.E.cast<Complex>() - red.A.cast<Complex>();
    const ComplexMatrix hr = red.C.cast<Complex>() * Pr.partialPivLu().solve(red.B.cast<Complex>());
    EXPECT_LT((hr - h).norm(), 1e-8 * h.norm()) << "at s = " << s;
  }
  // Without a block: the Krylov columns alone (the conformance suite's case).
  EXPECT_EQ(f->reducer->reduce({0, {p}}).V.cols(), 2);
}

TEST(Modal, MixedBasisBadRequestsAreRefusedByName) {
  const SecondOrderModel chain = test::spring_chain(20, 1e3, 0.05, 1e-4);
  auto f = make(Model(chain), Band{0.1, 10.0}, params(true));
  const ExpansionPoint p{Complex(0.0, kTwoPi * 2.0), 1};
  // A modal block without points: the order asks for modes (reducer_guard.cpp).
  try {
    f->reducer->reduce({4, {}, 3});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("a modal block needs expansion points"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(f->reducer->reduce({0, {p}, -1}), ConfigError);
  try {
    f->reducer->reduce({0, {ExpansionPoint{Complex(0.0, kTwoPi), 0}}, 2});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("moments >= 1"), std::string::npos) << e.what();
  }
}

// ---- general and descriptor paths --------------------------------------------------------------

// Dense finite eigenvalues of the pencil (A, E).
std::vector<Complex> pencil_eigenvalues(const Matrix& A, const Matrix& E) {
  Eigen::GeneralizedEigenSolver<Matrix> ges(A, E, false);
  std::vector<Complex> out;
  for (Index j = 0; j < A.rows(); ++j) {
    if (std::abs(ges.betas()[j]) > 1e-13 * std::abs(ges.alphas()[j]))
      out.push_back(ges.alphas()[j] / ges.betas()[j]);
  }
  return out;
}

// Each of `got` is one of `ref` (relative tol), and `got` are distinct.
void expect_subset(const std::vector<Complex>& got, const std::vector<Complex>& ref, double tol) {
  for (const Complex& g : got) {
    double best = std::numeric_limits<double>::infinity();
    for (const Complex& r : ref) best = std::min(best, std::abs(r - g));
    EXPECT_LT(best, tol * std::abs(g)) << "eigenvalue " << g;
  }
}

TEST(Modal, BuildDescriptorPetrovGalerkinKeepsTheSelectedPoles) {
  const Band band = band_rad(1e-1, 1e3);
  auto f = make(shared_model("build"), band, params(true));
  const auto& m = std::get<DescriptorModel>(f->model);
  const ReducerResult r = f->reducer->reduce({10, {}});
  ASSERT_GE(r.V.cols(), 9);
  const auto& red = std::get<ReducedDescriptorModel>(r.model);
  EXPECT_LT((red.E - Matrix::Identity(r.V.cols(), r.V.cols())).cwiseAbs().maxCoeff(), 1e-10);
  // Modal truncation on exact invariant subspaces: the reduced poles are full poles.
  const Eigen::VectorXcd reduced = red.A.eigenvalues();
  std::vector<Complex> got(reduced.data(), reduced.data() + reduced.size());
  expect_subset(got, pencil_eigenvalues(Matrix(m.A), Matrix(m.E)), 1e-8);
  // ... and they are the first poles in the documented ranking by f = |lambda| / 2pi.
  const std::vector<Complex> ref = pencil_eigenvalues(Matrix(m.A), Matrix(m.E));
  std::vector<double> f_ref;
  for (const Complex& l : ref) f_ref.push_back(std::abs(l) / kTwoPi);
  const std::vector<Index> order =
      ranked_by_frequency(f_ref, std::vector<bool>(ref.size(), false), band, 10.0);
  std::vector<Complex> first;
  for (std::size_t k = 0; k < got.size(); ++k)
    first.push_back(ref[static_cast<std::size_t>(order[k])]);
  expect_subset(first, got, 1e-8);
}

TEST(Modal, Rail371SymmetricDescriptorIsGalerkin) {
  const Band band{1e-5, 1e-1};
  auto f = make(shared_model("rail_371"), band, params(false));
  const auto& m = std::get<DescriptorModel>(f->model);
  const ReducerResult r = f->reducer->reduce({15, {}});
  ASSERT_EQ(r.V.cols(), 15);
  EXPECT_LT(largest_angle_sin(r.V, r.W), 1e-14);
  const auto& red = std::get<ReducedDescriptorModel>(r.model);
  const Vector poles = Eigen::GeneralizedSelfAdjointEigenSolver<Matrix>(red.A, red.E).eigenvalues();
  // Dense reference: -A phi = mu E phi; the reduced poles are -mu of the selected modes.
  const Vector mu =
      Eigen::GeneralizedSelfAdjointEigenSolver<Matrix>(Matrix(-m.A), Matrix(m.E)).eigenvalues();
  const std::vector<Index> sel = [&] {
    // mu is the angular frequency here: rank on lambda = mu^2 with the second-order formula.
    return expected_selection(Vector(mu.array().square()), band, 10.0, 0.0, 15);
  }();
  std::vector<double> expected;
  for (Index j : sel) expected.push_back(-mu[j]);
  std::sort(expected.begin(), expected.end());
  for (Index j = 0; j < 15; ++j) {
    EXPECT_NEAR(poles[j], expected[static_cast<std::size_t>(j)],
                1e-10 * std::abs(expected[static_cast<std::size_t>(j)]));
  }
}

TEST(Modal, BuildSoUnsymmetricStiffnessUsesTheGeneralEigenproblem) {
  auto f = make(shared_model("build_so"), band_rad(1e-1, 1e3), params(true));
  const auto& m = std::get<SecondOrderModel>(f->model);
  const ReducerResult r = f->reducer->reduce({8, {}});
  ASSERT_GE(r.V.cols(), 7);
  EXPECT_NE(r.note.find("general"), std::string::npos) << r.note;
  const auto& red = std::get<ReducedSecondOrderModel>(r.model);
  EXPECT_LT((red.M - Matrix::Identity(r.V.cols(), r.V.cols())).cwiseAbs().maxCoeff(), 1e-11);
  // The span is invariant under M^-1 K: eigenvalues of (Kr, Mr) are eigenvalues of (K, M).
  const Eigen::VectorXcd reduced = red.K.eigenvalues();
  std::vector<Complex> got(reduced.data(), reduced.data() + reduced.size());
  expect_subset(got, pencil_eigenvalues(Matrix(m.K), Matrix(m.M)), 1e-8);
}

// ---- mode_ranking: dominance -------------------------------------------------------------------

// Fixed-fixed chain of n (odd) unit masses and unit springs, Rayleigh damping, force and position
// sensor at the middle mass. Modes antisymmetric about the middle vanish there: they are neither
// controllable nor observable, so half of the band's modes do not contribute to H at all.
SecondOrderModel collocated_chain(Index n) {
  SecondOrderModel m = test::spring_chain(n, 1.0, 1e-4, 2e-3);
  m.B = Matrix::Zero(n, 1);
  m.B(n / 2, 0) = 1.0;
  m.C = m.B.transpose();
  return m;
}

ParameterMap dominance_params(bool static_correction, int batch_size = 10) {
  ParameterMap p = params(static_correction, batch_size);
  p.set("mode_ranking", "dominance");
  return p;
}

// Log grid over the band plus every eigenfrequency inside it (the resonance peaks), with the full
// model's response there by dense solves (independent of the plugin and of the shifted solver).
struct Reference {
  std::vector<double> f_hz;
  std::vector<ComplexMatrix> H;
};

Reference dense_reference(const SecondOrderModel& m, const Band& band, const Vector& lambda) {
  Reference ref;
  for (int i = 0; i < 200; ++i) {
    ref.f_hz.push_back(band.f_min_hz * std::pow(band.f_max_hz / band.f_min_hz, i / 199.0));
  }
  for (Index j = 0; j < lambda.size(); ++j) {
    const double fj = std::sqrt(lambda[j]) / kTwoPi;
    if (fj >= band.f_min_hz && fj <= band.f_max_hz) ref.f_hz.push_back(fj);
  }
  const Matrix M = Matrix(m.M), D = Matrix(m.D), K = Matrix(m.K);
  for (const double f : ref.f_hz) {
    const double w = kTwoPi * f;
    const ComplexMatrix A = (K - w * w * M).cast<Complex>() + Complex(0.0, w) * D.cast<Complex>();
    ref.H.push_back(m.C.cast<Complex>() * A.partialPivLu().solve(m.B.cast<Complex>()));
  }
  return ref;
}

// Relative spectral band error of a reduced second-order model on the reference's grid.
double band_error(const Reference& ref, const ReducedModel& reduced) {
  const auto& r = std::get<ReducedSecondOrderModel>(reduced);
  double worst = 0.0;
  for (std::size_t i = 0; i < ref.f_hz.size(); ++i) {
    const double w = kTwoPi * ref.f_hz[i];
    const ComplexMatrix Ar =
        (r.K - w * w * r.M).cast<Complex>() + Complex(0.0, w) * r.D.cast<Complex>();
    const ComplexMatrix Hr = r.C.cast<Complex>() * Ar.partialPivLu().solve(r.B.cast<Complex>());
    const Eigen::JacobiSVD<ComplexMatrix> e(ref.H[i] - Hr), h(ref.H[i]);
    worst = std::max(worst, e.singularValues()(0) / h.singularValues()(0));
  }
  return worst;
}

// Smallest order whose reduced model meets `tol` on the reference grid (N + 1 if none does).
Index smallest_order(Fixture& fx, const Reference& ref, double tol) {
  const Index n = fx.reducer->max_order();
  for (Index order = 1; order <= n; ++order) {
    if (band_error(ref, fx.reducer->reduce({order, {}}).model) <= tol) return order;
  }
  return n + 1;
}

TEST(Modal, DominanceSkipsUnobservableModesAndReachesTheToleranceWithFewerStates) {
  const Index n = 61;
  const SecondOrderModel chain = collocated_chain(n);
  const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> dense{Matrix(chain.K), Matrix(chain.M)};
  // The band holds the lowest 16 modes (8 of them antisymmetric: invisible at the middle mass).
  const Band band{0.5 * std::sqrt(dense.eigenvalues()[0]) / kTwoPi,
                  std::sqrt(0.5 * (dense.eigenvalues()[15] + dense.eigenvalues()[16])) / kTwoPi};
  const Reference ref = dense_reference(chain, band, dense.eigenvalues());
  auto by_band = make(Model(chain), band, params(false));
  auto by_dominance = make(Model(chain), band, dominance_params(false));
  const auto& m = std::get<SecondOrderModel>(by_band->model);

  // The leading dominance-ranked modes are the ones the input and output see: |c_j b_j| well
  // above rounding for each of the 8 symmetric band modes, which come first.
  const ReducerResult r8 = by_dominance->reducer->reduce({8, {}});
  ASSERT_EQ(r8.V.cols(), 8);
  for (Index k = 0; k < 8; ++k) {
    const double residue = std::abs((m.C * r8.V.col(k))(0) * (r8.V.col(k).transpose() * m.B)(0));
    EXPECT_GT(residue, 1e-3) << "column " << k << " is a mode the middle mass cannot see";
  }

  const double tol = 1e-2;
  const Index order_band = smallest_order(*by_band, ref, tol);
  const Index order_dominance = smallest_order(*by_dominance, ref, tol);
  EXPECT_LE(order_band, n) << "band ranking never met the tolerance";
  // Without the static correction the band ranking needs every mode (here N: the invisible modes
  // rank among the visible ones, and all quasi-static contributions count), dominance the visible
  // half.
  EXPECT_LE(2 * order_dominance, order_band + 2)
      << "dominance " << order_dominance << ", band " << order_band;

  // With the static correction the saving stays.
  auto band_sc = make(Model(chain), band, params(true));
  auto dominance_sc = make(Model(chain), band, dominance_params(true));
  const Index sc_band = smallest_order(*band_sc, ref, tol);
  const Index sc_dominance = smallest_order(*dominance_sc, ref, tol);
  EXPECT_LE(3 * sc_dominance, 2 * sc_band);
  std::printf("smallest order for %g: band %td, dominance %td; with static correction %td, %td\n",
              tol, order_band, order_dominance, sc_band, sc_dominance);
}

TEST(Modal, DominanceBasesAreNestedAndEqualAFreshComputation) {
  const Model model(collocated_chain(61));
  const Band band{1e-3, 0.1};
  auto grown = make(model, band, dominance_params(false, 8));
  const ReducerResult r5 = grown->reducer->reduce({5, {}});
  const ReducerResult r12 = grown->reducer->reduce({12, {}});
  const ReducerResult r40 = grown->reducer->reduce({40, {}});
  ASSERT_EQ(r40.V.cols(), 40);
  EXPECT_LT(largest_angle_sin(r5.V, r12.V.leftCols(5)), 1e-12);
  EXPECT_LT(largest_angle_sin(r12.V, r40.V.leftCols(12)), 1e-12);
  auto fresh = make(model, band, dominance_params(false, 8));
  EXPECT_LT(largest_angle_sin(fresh->reducer->reduce({40, {}}).V, r40.V), 1e-8);
  EXPECT_LT(largest_angle_sin(fresh->reducer->reduce({12, {}}).V, r12.V), 1e-8);
  // With the static correction: nested as subspaces.
  auto sc = make(model, band, dominance_params(true, 8));
  const ReducerResult s6 = sc->reducer->reduce({6, {}});
  const ReducerResult s20 = sc->reducer->reduce({20, {}});
  EXPECT_LT(largest_angle_sin(s6.V, s20.V), 1e-10);
}

TEST(Modal, DominanceIsRefusedByNameOnTheGeneralPath) {
  ParameterMap p = dominance_params(true);
  try {
    make(shared_model("build_so"), band_rad(1e-1, 1e3), p);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(
        std::string(e.what()).find("mode_ranking: dominance needs the symmetric eigenproblem"),
        std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("general"), std::string::npos) << e.what();
  }
  ParameterMap q("reducer 'modal'");
  q.set("mode_ranking", "dominant");
  try {
    registry().create("modal", q);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("mode_ranking"), std::string::npos) << e.what();
  }
}

// ---- requests, parameters and bad input ---------------------------------------------------------

TEST(Modal, OrderBeyondNReturnsAllModesAndSaysSo) {
  auto f = make(shared_model("lf10"), band_rad(1e2, 1e7), params(true));
  EXPECT_EQ(f->reducer->max_order(), 18);
  const ReducerResult r = f->reducer->reduce({30, {}});
  EXPECT_EQ(r.V.cols(), 18);
  EXPECT_NE(r.note.find("order 30 requested, 18 available"), std::string::npos) << r.note;
}

TEST(Modal, IndefiniteMassIsAnInputErrorNamingM) {
  SecondOrderModel m = free_chain(40);
  m.M.coeffRef(7, 7) = -1.0;
  try {
    make(Model(m), Band{1e-3, 1.0}, params(true));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("M"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("positive definite"), std::string::npos) << e.what();
  }
}

TEST(Modal, NegativeStiffnessIsAnInputErrorNamingK) {
  SecondOrderModel m = free_chain(40);
  m.K.coeffRef(5, 5) -= 3.0;  // an unstable spring: K indefinite
  auto f = make(Model(m), Band{1e-3, 1.0}, params(false));
  try {
    f->reducer->reduce({5, {}});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("K has a negative eigenvalue"), std::string::npos)
        << e.what();
  }
}

TEST(Modal, InvalidParametersAreNamed) {
  ParameterMap p("reducer 'modal'");
  p.set("batch_size", 0);
  try {
    registry().create("modal", p);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("batch_size"), std::string::npos) << e.what();
  }
  ParameterMap q("reducer 'modal'");
  q.set("band_margn", 3.0);
  try {
    registry().create("modal", q);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("band_margin"), std::string::npos) << e.what();
  }
  // The former relative threshold is refused with the reason, not silently ignored.
  ParameterMap r("reducer 'modal'");
  r.set("rigid_tolerance", 1e-8);
  try {
    registry().create("modal", r);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("rigid_tolerance is no longer a parameter: rigid-body "
                                         "modes are the null space of K"),
              std::string::npos)
        << e.what();
  }
  auto f = make(shared_model("lf10"), band_rad(1e2, 1e7), params(true));
  // Order 0 without points is refused at the plugin boundary (reducer_guard.cpp).
  EXPECT_THROW(f->reducer->reduce({0, {}}), ConfigError);
}

// The documented keys are generated from the option specs and checked against create() for every
// reducer in test_option_docs.cpp; here the capabilities and the default the README discusses.
TEST(Modal, InfoDocumentsParametersAndCapabilities) {
  const auto entries = registry().entries();
  const auto it = std::find_if(entries.begin(), entries.end(),
                               [](const Registry::Entry& e) { return e.info.name == "modal"; });
  ASSERT_NE(it, entries.end());
  const auto batch = std::find_if(it->info.parameters.begin(), it->info.parameters.end(),
                                  [](const ParameterDoc& d) { return d.name == "batch_size"; });
  ASSERT_NE(batch, it->info.parameters.end());
  EXPECT_EQ(batch->default_value, "20");
  // The cap that create() enforces is in the text (it was once undocumented).
  EXPECT_NE(batch->description.find("in [1, 100000]"), std::string::npos) << batch->description;
  EXPECT_TRUE(it->info.second_order);
  EXPECT_TRUE(it->info.descriptor);
  EXPECT_TRUE(it->info.uses_expansion_points);
  EXPECT_TRUE(it->info.modal_block);
}

}  // namespace
}  // namespace ecmor
