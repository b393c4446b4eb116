// Tests of the "irka" reducer plugin, loaded through the registry like any plugin. References are
// independent of the plugin: the full transfer function and its derivative by dense LU (Eigen) on
// the benchmark models, the reduced model's poles and residues by Eigen's eigensolver on the
// returned matrices.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "../../bench/solid.hpp"
#include "common/plugin_registry.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace ecmor {
namespace {

using test::message_of;

Registry& registry() { return test::plugin_registry("libecmor_irka.so"); }

std::filesystem::path shared(const std::string& name) {
  return std::filesystem::path("models") / name;
}

/// A reducer bound to a model, the solver and a band.
struct Fixture {
  Model model;
  std::unique_ptr<ShiftedSolver> solver;
  std::shared_ptr<Reducer> reducer;
};

std::unique_ptr<Fixture> make(Model model, const ParameterMap& params, Band band) {
  auto f = std::make_unique<Fixture>();
  f->model = std::move(model);
  f->solver = make_shifted_solver(f->model);
  f->reducer = registry().create("irka", params);
  ReductionContext ctx;
  ctx.model = &f->model;
  ctx.solver = f->solver.get();
  ctx.band = band;
  f->reducer->setup(ctx);
  return f;
}

ParameterMap params(std::initializer_list<std::pair<const char*, ParameterValue::Storage>> kv) {
  ParameterMap p("reducer 'irka'");
  for (const auto& [k, v] : kv) p.set(k, ParameterValue{v, {}});
  return p;
}

/// Dense H(s) and H'(s) of a small full model (either kind), by LU of the dense P(s).
struct DenseFull {
  explicit DenseFull(const Model& model) {
    if (const auto* so = std::get_if<SecondOrderModel>(&model)) {
      second_order = true;
      M = Matrix(so->M);
      D = Matrix(so->D);
      K = Matrix(so->K);
      B = so->B;
      C = so->C;
      Cv = so->has_velocity_output() ? so->Cv : Matrix::Zero(so->C.rows(), so->C.cols());
    } else {
      const auto& ds = std::get<DescriptorModel>(model);
      M = Matrix(ds.E);  // P(s) = s E - A: "M" holds E, K holds -A
      K = -Matrix(ds.A);
      D = Matrix::Zero(K.rows(), K.cols());
      B = ds.B;
      C = ds.C;
      Cv = Matrix::Zero(C.rows(), C.cols());
    }
  }
  /// P(s) and P'(s).
  ComplexMatrix P(Complex s) const {
    if (second_order)
      return (s * s) * M.cast<Complex>() + s * D.cast<Complex>() + K.cast<Complex>();
    return s * M.cast<Complex>() + K.cast<Complex>();
  }
  ComplexMatrix dP(Complex s) const {
    if (second_order) return 2.0 * s * M.cast<Complex>() + D.cast<Complex>();
    return M.cast<Complex>();
  }
  ComplexMatrix H(Complex s) const {
    const ComplexMatrix X = P(s).partialPivLu().solve(B.cast<Complex>());
    return (C.cast<Complex>() + s * Cv.cast<Complex>()) * X;
  }
  ComplexMatrix dH(Complex s) const {
    const Eigen::PartialPivLU<ComplexMatrix> lu(P(s));
    const ComplexMatrix X = lu.solve(B.cast<Complex>());
    const ComplexMatrix Y = lu.solve(ComplexMatrix(dP(s) * X));
    return Cv.cast<Complex>() * X - (C.cast<Complex>() + s * Cv.cast<Complex>()) * Y;
  }
  bool second_order = false;
  Matrix M, D, K, B, C, Cv;
};

/// Pole-residue form of a reduced model, by Eigen on its (first-order realisation's) matrices:
/// Hr(s) = sum_i c_i b_i^T / (s - lambda_i).
struct Residues {
  ComplexVector poles;
  ComplexMatrix b, c;
};

Residues residues(const ReducedModel& reduced) {
  Matrix E, A, B, C;
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&reduced)) {
    const Index n = so->size();
    E = Matrix::Identity(2 * n, 2 * n);
    E.bottomRightCorner(n, n) = so->M;
    A = Matrix::Zero(2 * n, 2 * n);
    A.topRightCorner(n, n).setIdentity();
    A.bottomLeftCorner(n, n) = -so->K;
    A.bottomRightCorner(n, n) = -so->D;
    B = Matrix::Zero(2 * n, so->inputs());
    B.bottomRows(n) = so->B;
    C = Matrix::Zero(so->outputs(), 2 * n);
    C.leftCols(n) = so->C;
    if (so->has_velocity_output()) C.rightCols(n) = so->Cv;
  } else {
    const auto& ds = std::get<ReducedDescriptorModel>(reduced);
    E = ds.E;
    A = ds.A;
    B = ds.B;
    C = ds.C;
  }
  const Matrix F = E.partialPivLu().solve(A);
  const Eigen::EigenSolver<Matrix> eig(F);
  const ComplexMatrix X = eig.eigenvectors();
  Residues r;
  r.poles = eig.eigenvalues();
  r.c = C.cast<Complex>() * X;
  r.b = X.partialPivLu().solve(E.partialPivLu().solve(B).cast<Complex>()).transpose();
  return r;
}

/// Hr(s) and Hr'(s) from the pole-residue form.
ComplexMatrix reduced_h(const Residues& r, Complex s, int derivative) {
  ComplexMatrix H = ComplexMatrix::Zero(r.c.rows(), r.b.rows());
  for (Index i = 0; i < r.poles.size(); ++i) {
    const Complex d = s - r.poles(i);
    const Complex w = derivative == 0 ? 1.0 / d : -1.0 / (d * d);
    H += w * r.c.col(i) * r.b.col(i).transpose();
  }
  return H;
}

/// The largest relative mismatch of the three H2-optimality (tangential Hermite) conditions at
/// the mirror images of the reduced poles:
///   H(-l) b = Hr(-l) b,   c' H(-l) = c' Hr(-l),   c' H'(-l) b = c' Hr'(-l) b.
struct Mismatch {
  double right = 0.0, left = 0.0, derivative = 0.0;
};

Mismatch h2_conditions(const DenseFull& full, const ReducedModel& reduced) {
  const Residues r = residues(reduced);
  Mismatch m;
  for (Index i = 0; i < r.poles.size(); ++i) {
    const Complex s = -r.poles(i);
    const ComplexVector b = r.b.col(i).normalized(), c = r.c.col(i).normalized();
    const ComplexMatrix H = full.H(s), Hr = reduced_h(r, s, 0);
    const ComplexMatrix dH = full.dH(s), dHr = reduced_h(r, s, 1);
    const double scale = H.norm();
    m.right = std::max(m.right, (H * b - Hr * b).norm() / scale);
    m.left = std::max(m.left, (c.transpose() * H - c.transpose() * Hr).norm() / scale);
    const Complex d = (c.transpose() * dH * b)(0, 0), dr = (c.transpose() * dHr * b)(0, 0);
    m.derivative = std::max(m.derivative, std::abs(d - dr) / (std::abs(s) > 0.0 ? dH.norm() : 1.0));
  }
  return m;
}

Band band_of(double f_min, double f_max) {
  Band b;
  b.f_min_hz = f_min;
  b.f_max_hz = f_max;
  return b;
}

// ---- H2 optimality at convergence -------------------------------------------------------------

// With tolerance 1e-7 the converged shifts and directions are the mirror images of the reduced
// poles and their residue directions to 1e-7 relative. The conditions hold exactly at the data
// the model was built from, so at -lambda they hold to first order in that distance: the mismatch
// is at most about tolerance times the relative slope |s H'(s)| / |H(s)| near the shifts, which is
// below 10 on these models away from resonances: 1e-6 = 10 x tolerance. (1e-7 is near the
// rounding floor of the iteration on build and build_so: changes of 3e-8 to 1e-7 repeat there.)
void expect_h2_optimal(
    const std::string& name, Index r, Band band,
    std::initializer_list<std::pair<const char*, ParameterValue::Storage>> extra = {}) {
  SCOPED_TRACE(name + " r = " + std::to_string(r));
  ParameterMap p =
      params({{"tolerance", 1e-7}, {"model_tolerance", 0.0}, {"max_iterations", 200LL}});
  for (const auto& [k, v] : extra) p.set(k, ParameterValue{v, {}});
  auto f = make(load_model(shared(name)), p, band);
  const ReducerResult res = f->reducer->reduce(ReductionRequest{r, {}});
  ASSERT_TRUE(std::holds_alternative<ReducedDescriptorModel>(res.model));
  EXPECT_EQ(size_of(res.model), r);
  EXPECT_EQ(res.diagnostics.at("irka_converged"), 1.0) << res.note;
  EXPECT_LE(res.diagnostics.at("irka_change"), 1e-7);
  const Mismatch m = h2_conditions(DenseFull(f->model), res.model);
  EXPECT_LT(m.right, 1e-6);
  EXPECT_LT(m.left, 1e-6);
  EXPECT_LT(m.derivative, 1e-6);
  std::cout << fmt::format(
      "[ irka ] {} r = {}: {}; mismatch right {:.1e} left {:.1e} derivative "
      "{:.1e}\n",
      name, r, res.note, m.right, m.left, m.derivative);
}

TEST(Irka, SisoBuildIsH2OptimalAtConvergence) {
  expect_h2_optimal("build", 10, band_of(0.1 / kTwoPi, 100.0 / kTwoPi));
}

TEST(Irka, MimoCdplayerIsH2OptimalAlongTangentialDirections) {
  expect_h2_optimal("cdplayer", 10, band_of(1.0 / kTwoPi, 1e5 / kTwoPi));
}

TEST(Irka, MimoIssIsH2OptimalAlongTangentialDirections) {
  expect_h2_optimal("iss", 10, band_of(0.1 / kTwoPi, 100.0 / kTwoPi));
}

TEST(Irka, SecondOrderModelThroughItsFirstOrderRealisation) {
  // Solves on s^2 M + s D + K of size N (the solver is the second-order one): the 2N realisation
  // is never factorised.
  expect_h2_optimal("triplechain_cmess_n301", 10, band_of(1e-3, 1.0));
}

TEST(Irka, VelocityOutputSecondOrderModel) {
  // build_so: C = 0, y = Cv q' (the realisation's output is [0, Cv]).
  expect_h2_optimal("build_so", 8, band_of(0.1 / kTwoPi, 100.0 / kTwoPi));
}

// ---- structure-preserving variant ------------------------------------------------------------

TEST(Irka, SecondOrderVariantInterpolatesAtFirstOrderShifts) {
  // second_order_shifts: first_order projects M, D, K on the shifts first-order IRKA converged
  // to, i.e. on the mirror images of the first-order model's poles: the second-order model must
  // interpolate H there (two-sided: also along the left directions).
  const Band band = band_of(1e-3, 1.0);
  const Index r = 8;
  auto fo = make(load_model(shared("triplechain_cmess_n301")),
                 params({{"tolerance", 1e-8}, {"max_iterations", 200LL}}), band);
  const ReducerResult first = fo->reducer->reduce(ReductionRequest{r, {}});
  ASSERT_EQ(first.diagnostics.at("irka_converged"), 1.0) << first.note;
  auto so = make(load_model(shared("triplechain_cmess_n301")),
                 params({{"tolerance", 1e-8},
                         {"max_iterations", 200LL},
                         {"structure", std::string("second_order")},
                         {"second_order_shifts", std::string("first_order")}}),
                 band);
  const ReducerResult second = so->reducer->reduce(ReductionRequest{r, {}});
  ASSERT_TRUE(std::holds_alternative<ReducedSecondOrderModel>(second.model));
  EXPECT_EQ(size_of(second.model), r);
  const DenseFull full(so->model);
  const Residues fr = residues(first.model);
  double worst = 0.0;
  for (Index i = 0; i < fr.poles.size(); ++i) {
    const Complex s = -fr.poles(i);
    const ComplexMatrix H = full.H(s);
    const ComplexMatrix Hr = transfer_function(second.model, s);
    worst = std::max(worst, std::abs(H(0, 0) - Hr(0, 0)) / std::abs(H(0, 0)));
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(Irka, SecondOrderIterateVariantReturnsAStableSecondOrderModel) {
  // one-sided projection of symmetric positive definite M, D, K keeps them so: stable.
  auto f = make(load_model(shared("triplechain_cmess_n301")),
                params({{"structure", std::string("second_order")},
                        {"projection", std::string("one_sided")}}),
                band_of(1e-3, 1.0));
  const ReducerResult res = f->reducer->reduce(ReductionRequest{10, {}});
  ASSERT_TRUE(std::holds_alternative<ReducedSecondOrderModel>(res.model));
  EXPECT_EQ(size_of(res.model), 10);
  const ComplexVector p = poles(res.model);
  EXPECT_EQ(p.size(), 20);
  for (const Complex& z : p) EXPECT_LT(z.real(), 0.0);
  EXPECT_EQ(res.diagnostics.at("unstable_poles"), 0.0);
}

// ---- symmetric models: one-sided projection ---------------------------------------------------

/// A symmetric definite heat model like rail's (seeded, N = 300): E the P1 mass matrix and -A the
/// stiffness matrix of -(k u')' + u on (0, 1) with k between 0.01 and 1, 3 inputs and 2 outputs
/// from unrelated random vectors (B != C', so two-sided IRKA is Petrov-Galerkin).
DescriptorModel symmetric_heat_model() {
  const Index n = 300;
  const double h = 1.0 / static_cast<double>(n + 1);
  std::vector<Eigen::Triplet<double>> e, a;
  for (Index i = 0; i < n; ++i) {
    const double x = (static_cast<double>(i) + 1.0) * h;
    const double k = 0.01 + 0.99 * x * x;
    e.emplace_back(i, i, 4.0 * h / 6.0);
    a.emplace_back(i, i, -(2.0 * k / h + 4.0 * h / 6.0));
    if (i + 1 < n) {
      for (const auto& [r, c] : {std::pair{i, i + 1}, std::pair{i + 1, i}}) {
        e.emplace_back(r, c, h / 6.0);
        a.emplace_back(r, c, k / h - h / 6.0);
      }
    }
  }
  DescriptorModel m;
  m.E.resize(n, n);
  m.A.resize(n, n);
  m.E.setFromTriplets(e.begin(), e.end());
  m.A.setFromTriplets(a.begin(), a.end());
  std::srand(29);
  m.B = Matrix::Random(n, 3);
  m.C = Matrix::Random(2, n);
  return m;
}

TEST(Irka, SymmetricModelIsReducedOneSidedToAStableSymmetricPencil) {
  // E SPD, A symmetric negative definite, projection one_sided: W = V, so Er = V'EV is SPD and
  // Ar = V'AV symmetric negative definite: every pole real and negative, none reflected, at every
  // order of a grown sequence (warm starts included). Two-sided on the same model reflects poles.
  auto f = make(symmetric_heat_model(),
                params({{"projection", std::string("one_sided")}, {"max_iterations", 100LL}}),
                band_of(1e-3, 10.0));
  for (const Index r : {3, 6, 10}) {
    SCOPED_TRACE("r = " + std::to_string(r));
    const ReducerResult res = f->reducer->reduce(ReductionRequest{r, {}});
    std::cout << "[ irka ] symmetric heat, one-sided: " << res.note << "\n";
    EXPECT_EQ(res.diagnostics.at("irka_one_sided"), 1.0);
    EXPECT_EQ(res.diagnostics.at("irka_reflected_poles"), 0.0);
    EXPECT_EQ(res.diagnostics.at("unstable_poles"), 0.0);
    ASSERT_TRUE(std::holds_alternative<ReducedDescriptorModel>(res.model));
    const auto& red = std::get<ReducedDescriptorModel>(res.model);
    ASSERT_EQ(red.E.rows(), r);
    EXPECT_LT((red.E - red.E.transpose()).norm(), 1e-12 * red.E.norm());
    EXPECT_LT((red.A - red.A.transpose()).norm(), 1e-12 * red.A.norm());
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix>(red.E).eigenvalues().minCoeff(), 0.0);
    EXPECT_LT(Eigen::SelfAdjointEigenSolver<Matrix>(red.A).eigenvalues().maxCoeff(), 0.0);
    EXPECT_TRUE(res.W.isApprox(res.V));
  }
  auto two = make(symmetric_heat_model(), params({{"max_iterations", 100LL}}), band_of(1e-3, 10.0));
  Index reflected = 0;
  for (const Index r : {3, 6, 10}) {
    const ReducerResult res = two->reducer->reduce(ReductionRequest{r, {}});
    EXPECT_EQ(res.diagnostics.at("irka_one_sided"), 0.0);
    reflected += static_cast<Index>(res.diagnostics.at("irka_reflected_poles"));
  }
  EXPECT_GT(reflected, 0);
}

TEST(Irka, SymmetricModelDefaultsCostFewerFactorisations) {
  // On a symmetric definite model the defaults become model_tolerance 1e-3, no restarts and warm
  // starts from a larger order: over the orders a grow_order run asks for (growing, then
  // shrinking) they need fewer factorisations than the general defaults (model_tolerance 0,
  // restarts 2, warm starts from below) given explicitly. Counted in factorisations, not seconds.
  auto count = [](const ParameterMap& p) {
    auto f = make(symmetric_heat_model(), p, band_of(1e-3, 10.0));
    for (const Index r : {2, 3, 5, 8, 12, 10, 9}) {
      const ReducerResult res = f->reducer->reduce(ReductionRequest{r, {}});
      EXPECT_EQ(res.diagnostics.at("unstable_poles"), 0.0) << res.note;
    }
    return f->solver->counters().factorizations;
  };
  const Index symmetric = count(params({}));
  const Index general = count(params({{"model_tolerance", 0.0}, {"restarts", 2LL}}));
  std::cout << fmt::format(
      "[ irka ] symmetric heat, orders 2..12..9: {} factorisations with the symmetric defaults, "
      "{} with the general ones\n",
      symmetric, general);
  EXPECT_LT(symmetric, general);
}

/// IRKA with and without the surrogate over the orders `orders`, to tolerance 1e-7 with
/// model_tolerance 0 (only the strict test ends a run): the surrogate's runs must converge to
/// models that meet the H2-optimality conditions (dense LU of the full model), and with fewer
/// factorisations than plain IRKA steps. Plain runs are counted only.
void expect_surrogate_h2_optimal_and_cheaper(const Model& model, const std::string& name, Band band,
                                             std::initializer_list<Index> orders) {
  const DenseFull full{model};
  auto run = [&](bool surrogate) -> Index {
    auto f = make(model,
                  params({{"surrogate", surrogate},
                          {"model_tolerance", 0.0},
                          {"tolerance", 1e-7},
                          {"max_iterations", 200LL}}),
                  band);
    for (const Index r : orders) {
      SCOPED_TRACE(fmt::format("{}, surrogate {}, r = {}", name, surrogate, r));
      const ReducerResult res = f->reducer->reduce(ReductionRequest{r, {}});
      std::cout << "[ irka ] " << name << ", surrogate " << surrogate << ": " << res.note << "\n";
      EXPECT_EQ(res.diagnostics.at("irka_surrogate_size") > 0.0, surrogate);
      if (!surrogate) continue;
      EXPECT_EQ(res.diagnostics.at("irka_converged"), 1.0) << res.note;
      const Mismatch m = h2_conditions(full, res.model);
      EXPECT_LT(m.right, 1e-6);
      EXPECT_LT(m.left, 1e-6);
      EXPECT_LT(m.derivative, 1e-6);
    }
    return f->solver->counters().factorizations;
  };
  const Index with = run(true);
  const Index without = run(false);
  std::cout << fmt::format(
      "[ irka ] {}, to tolerance 1e-7: {} factorisations with the surrogate, {} without\n", name,
      with, without);
  EXPECT_LT(with, without);
}

TEST(Irka, SurrogateReachesH2OptimalModelsWithFewerFactorisations) {
  // The surrogate (symmetric definite models, default on) only proposes the data of the next
  // build; convergence is judged on the full model (measured: 46 factorisations against 326,
  // plain IRKA stagnating at r = 4, where it has no restarts on symmetric models).
  expect_surrogate_h2_optimal_and_cheaper(Model(symmetric_heat_model()), "symmetric heat",
                                          band_of(1e-3, 10.0), {2, 4, 6});
}

TEST(Irka, SecondOrderSurrogateReachesH2OptimalModelsWithFewerFactorisations) {
  // A clamped 3-D solid (bench/solid.cpp, 4 inputs, 6 outputs, Rayleigh damping: M, D, K SPD,
  // B != C'): IRKA through the first-order realisation keeps a second-order Galerkin surrogate
  // (M, D, K projected onto the position parts of both sides' vectors, stable, Hermite at every
  // shift used) and iterates on it between true builds (issue 46: a 2 400-DOF solid took 5 862
  // factorisations and more than 250 s). Measured: 28 factorisations against 243.
  bench::SolidOptions o;
  o.nx = 8;
  o.ny = 2;
  o.nz = 1;
  expect_surrogate_h2_optimal_and_cheaper(Model(bench::solid(o)), "solid N = 144",
                                          band_of(10.0, 3000.0), {4, 8, 12});
}

TEST(Irka, ShrinkStepsOnATrustedSurrogateMakeNoFactorisation) {
  // grow_order's shrink phase asks for orders below the largest one built: once the surrogate has
  // reproduced a full build to 1e-5 (relative H2), such an order is IRKA on the surrogate alone,
  // its model built from the surrogate's vectors lifted by U. It costs no full factorisation, is
  // a Petrov-Galerkin projection of the full model with the returned V and W (checked here
  // against the full first-order realisation), and, the surrogate reproducing G, it meets the
  // H2-optimality conditions of the full model closely (dense LU).
  bench::SolidOptions o;
  o.nx = 8;
  o.ny = 2;
  o.nz = 1;
  const SecondOrderModel model = bench::solid(o);
  auto f = make(model, params({}), band_of(10.0, 3000.0));
  for (const Index r : {4, 8, 12, 18}) (void)f->reducer->reduce(ReductionRequest{r, {}});
  const Index before = f->solver->counters().factorizations;
  const ReducerResult res = f->reducer->reduce(ReductionRequest{14, {}});
  std::cout << "[ irka ] solid N = 144, r = 14 after 18: " << res.note << "\n";
  EXPECT_NE(res.note.find("surrogate alone"), std::string::npos) << res.note;
  EXPECT_EQ(f->solver->counters().factorizations, before);
  EXPECT_EQ(res.diagnostics.at("unstable_poles"), 0.0);
  ASSERT_TRUE(std::holds_alternative<ReducedDescriptorModel>(res.model));
  const auto& red = std::get<ReducedDescriptorModel>(res.model);
  const Index n = model.size();
  ASSERT_EQ(res.V.rows(), 2 * n);
  ASSERT_EQ(res.V.cols(), 14);
  // W' E V and W' A V of the realisation E = diag(I, M), A = [0 I; -K -D], B = [0; B], C = [C 0].
  const Matrix M(model.M), D(model.D), K(model.K);
  const Matrix Vq = res.V.topRows(n), Vv = res.V.bottomRows(n);
  const Matrix Wq = res.W.topRows(n), Wv = res.W.bottomRows(n);
  const Matrix Er = Wq.transpose() * Vq + Wv.transpose() * M * Vv;
  const Matrix Ar = Wq.transpose() * Vv - Wv.transpose() * (K * Vq + D * Vv);
  EXPECT_LT((Er - red.E).norm(), 1e-10 * red.E.norm());
  EXPECT_LT((Ar - red.A).norm(), 1e-10 * red.A.norm());
  EXPECT_LT((Wv.transpose() * model.B - red.B).norm(), 1e-10 * red.B.norm());
  EXPECT_LT((model.C * Vq - red.C).norm(), 1e-10 * red.C.norm());
  const Mismatch m = h2_conditions(DenseFull(Model(model)), res.model);
  std::cout << fmt::format(
      "[ irka ] H2 conditions of the full model: right {:.1e} left {:.1e} "
      "derivative {:.1e}\n",
      m.right, m.left, m.derivative);
  EXPECT_LT(m.right, 1e-4);
  EXPECT_LT(m.left, 1e-4);
  EXPECT_LT(m.derivative, 1e-4);
}

TEST(Irka, SurrogateIsRefusedWhereItDoesNotApply) {
  // The Galerkin surrogate is stable only for symmetric definite descriptor models: asking for it
  // elsewhere is a configuration error that names the key; left unset it is simply off.
  const Band band = band_of(0.0159, 159.0);
  const std::string msg = message_of<ConfigError>([&] {
    make(load_model(shared("cdplayer")), params({{"surrogate", true}}), band);
  });
  EXPECT_NE(msg.find("surrogate"), std::string::npos) << msg;
  EXPECT_NE(msg.find("symmetric"), std::string::npos) << msg;
  auto f = make(load_model(shared("cdplayer")), params({{"tolerance", 1e-4}}), band);
  const ReducerResult res = f->reducer->reduce(ReductionRequest{4, {}});
  EXPECT_EQ(res.diagnostics.at("irka_surrogate_size"), 0.0);
  EXPECT_EQ(res.diagnostics.at("irka_surrogate_iterations"), 0.0);
}

TEST(Irka, RepeatedDataReusesThePreviousVectors) {
  // A warm start at an order run before begins with that order's final data, whose vectors the
  // last build computed: its first iteration needs no factorisation.
  auto f =
      make(load_model(shared("cdplayer")), params({{"tolerance", 1e-4}}), band_of(0.0159, 159.0));
  const ReducerResult first = f->reducer->reduce(ReductionRequest{6, {}});
  ASSERT_EQ(first.diagnostics.at("irka_converged"), 1.0) << first.note;
  const Index before = f->solver->counters().factorizations;
  const ReducerResult again = f->reducer->reduce(ReductionRequest{6, {}});
  const Index used = f->solver->counters().factorizations - before;
  EXPECT_EQ(again.diagnostics.at("irka_reused_solves"), 3.0) << again.note;  // 3 pairs
  EXPECT_LE(used, 3 * (static_cast<Index>(again.diagnostics.at("irka_iterations")) - 1));
}

// ---- safeguards -------------------------------------------------------------------------------

TEST(Irka, IterationBudgetEndsWithANamedReasonAndTheBestIterate) {
  auto f = make(load_model(shared("iss")),
                params({{"tolerance", 1e-14}, {"max_iterations", 3LL}, {"restarts", 0LL}}),
                band_of(0.1 / kTwoPi, 100.0 / kTwoPi));
  const ReducerResult res = f->reducer->reduce(ReductionRequest{12, {}});
  EXPECT_EQ(res.diagnostics.at("irka_converged"), 0.0);
  EXPECT_EQ(res.diagnostics.at("irka_iterations"), 3.0);
  EXPECT_NE(res.note.find("not converged: iteration budget max_iterations = 3 used up"),
            std::string::npos)
      << res.note;
  EXPECT_EQ(size_of(res.model), 12);
}

TEST(Irka, CyclingEndsWithANamedReasonAndRestartsRecover) {
  // build at r = 8 from the band shifts: IRKA falls into a 2-cycle (the shifts alternate between
  // two sets that differ by O(1)). Without restarts the run ends at once with the reason named,
  // long before max_iterations; with restarts from other shifts it converges.
  const Band band = band_of(0.1 / kTwoPi, 100.0 / kTwoPi);
  auto bare = make(load_model(shared("build")),
                   params({{"restarts", 0LL}, {"max_iterations", 200LL}}), band);
  const ReducerResult cycled = bare->reducer->reduce(ReductionRequest{8, {}});
  EXPECT_EQ(cycled.diagnostics.at("irka_converged"), 0.0);
  EXPECT_LT(cycled.diagnostics.at("irka_iterations"), 50.0);
  EXPECT_NE(cycled.note.find("not converged: cycling with period 2"), std::string::npos)
      << cycled.note;
  auto guarded = make(load_model(shared("build")), params({{"max_iterations", 200LL}}), band);
  const ReducerResult recovered = guarded->reducer->reduce(ReductionRequest{8, {}});
  EXPECT_EQ(recovered.diagnostics.at("irka_converged"), 1.0) << recovered.note;
  EXPECT_GE(recovered.diagnostics.at("irka_restarts"), 1.0);
  const Mismatch m = h2_conditions(DenseFull(guarded->model), recovered.model);
  EXPECT_LT(std::max({m.right, m.left, m.derivative}), 1e-4);
}

TEST(Irka, ModelChangeTestStopsBeforeTheShiftsConverge) {
  // cdplayer at r = 20 over 0.0159..159 Hz: the reduced model settles while the shifts still
  // move (by 0.5 when it settles). model_tolerance 1e-3 ends the run with that reason in fewer
  // iterations than the test on the shifts alone (measured: 3 against 35).
  const Band band = band_of(0.0159, 159.0);
  auto by_model = make(load_model(shared("cdplayer")), params({{"model_tolerance", 1e-3}}), band);
  const ReducerResult early = by_model->reducer->reduce(ReductionRequest{20, {}});
  auto by_shifts = make(load_model(shared("cdplayer")), params({{"model_tolerance", 0.0}}), band);
  const ReducerResult late = by_shifts->reducer->reduce(ReductionRequest{20, {}});
  std::cout << "[ irka ] model test: " << early.note << "\n[ irka ] shift test: " << late.note
            << "\n";
  EXPECT_EQ(early.diagnostics.at("irka_converged"), 1.0) << early.note;
  EXPECT_NE(early.note.find("converged (relative H2 change of the model"), std::string::npos)
      << early.note;
  EXPECT_LE(early.diagnostics.at("irka_model_change"), 1e-3);
  EXPECT_LT(early.diagnostics.at("irka_iterations"), late.diagnostics.at("irka_iterations"));
}

TEST(Irka, BestStartKeepsTheConvergedModelOfLargestNorm) {
  // At a stationary point ||G - Gr||^2 = ||G||^2 - ||Gr||^2, so among converged starts the one
  // with the largest ||Gr|| has the smallest error. Checked against the errors themselves, by
  // dense LU on a frequency grid (trapezoidal H2 surrogate) of iss, where the band start ends at
  // a worse local optimum than the balanced one (0.27 vs 0.23 relative H2 error at r = 10).
  const Band band = band_of(0.016, 16.0);
  auto run_with = [&](const std::string& start) {
    auto f = make(load_model(shared("iss")),
                  params({{"initial_shifts", start}, {"max_iterations", 100LL}}), band);
    ReducerResult res = f->reducer->reduce(ReductionRequest{10, {}});
    return std::make_pair(std::move(f), std::move(res));
  };
  const auto [fb, best] = run_with("best");
  const auto [fband, band_only] = run_with("band");
  const auto [fbal, balanced] = run_with("balanced");
  EXPECT_NE(best.note.find("best of 3 starts: balanced"), std::string::npos) << best.note;
  // Error surrogate: sum over a log grid of ||H - Hr||_F^2 w (rectangle rule in w), dense LU.
  const DenseFull full(fb->model);
  const Index n = 200;
  const double w0 = 1e-3, w1 = 1e4;
  std::vector<Complex> nodes;
  std::vector<ComplexMatrix> H;
  for (Index k = 0; k < n; ++k) {
    nodes.emplace_back(0.0, w0 * std::pow(w1 / w0, (static_cast<double>(k) + 0.5) / n));
    H.push_back(full.H(nodes.back()));
  }
  auto surrogate = [&](const ReducedModel& m) {
    double sum = 0.0;
    for (Index k = 0; k < n; ++k) {
      const double w = nodes[static_cast<std::size_t>(k)].imag();
      const double dw = w * std::log(w1 / w0) / static_cast<double>(n);
      sum += (H[static_cast<std::size_t>(k)] -
              transfer_function(m, nodes[static_cast<std::size_t>(k)]))
                 .squaredNorm() *
             dw;
    }
    return std::sqrt(sum);
  };
  EXPECT_LT(surrogate(best.model), surrogate(band_only.model));
  EXPECT_NEAR(surrogate(best.model), surrogate(balanced.model), 1e-12 * surrogate(best.model));
}

// ---- bad input --------------------------------------------------------------------------------

TEST(Irka, UnstableModelIsRefused) {
  // iss with A -> -A: a nonsingular E and every pole mirrored into the right half plane.
  Model model = load_model(shared("iss"));
  auto& ds = std::get<DescriptorModel>(model);
  ds.A = -ds.A;
  const std::string msg = message_of<InputError>(
      [&] { make(std::move(model), params({}), band_of(0.1 / kTwoPi, 100.0 / kTwoPi)); });
  EXPECT_NE(msg.find("irka: the model is not asymptotically stable: 270 of its 270 computed finite "
                     "poles have Re >= 0"),
            std::string::npos)
      << msg;
}

TEST(Irka, PeecIsRefusedAsADaeWithItsUnstableLookingPolesNamed) {
  // peec: E is singular and the computed finite poles include ones with Re > 0 (the models
  // README: up to +1.7e12). Whether those are genuine or perturbed infinite eigenvalues cannot be
  // told in double precision; the message gives both facts, and the model is refused either way,
  // never reduced to a NaN model.
  const std::string msg = message_of<InputError>(
      [&] { make(load_model(shared("peec")), params({}), band_of(0.1 / kTwoPi, 1e5 / kTwoPi)); });
  EXPECT_NE(msg.find("E is singular"), std::string::npos) << msg;
  EXPECT_NE(msg.find("computed finite poles have Re >= 0"), std::string::npos) << msg;
  // check_stability: false skips the poles, not the DAE refusal.
  const std::string off = message_of<InputError>([&] {
    make(load_model(shared("peec")), params({{"check_stability", false}}),
         band_of(0.1 / kTwoPi, 1e5 / kTwoPi));
  });
  EXPECT_NE(off.find("E is singular"), std::string::npos) << off;
}

TEST(Irka, ExpansionPointsAndWrongStructureAreRefused) {
  auto f = make(load_model(shared("build")), params({}), band_of(0.1, 10.0));
  std::string msg = message_of<ConfigError>([&] {
    f->reducer->reduce(ReductionRequest{4, {point_at_hz(1.0)}});
  });
  EXPECT_NE(msg.find("chooses its own interpolation points"), std::string::npos) << msg;
  msg = message_of<InputError>([&] { f->reducer->reduce(ReductionRequest{49, {}}); });
  EXPECT_NE(msg.find("order = 49: must be in [1, 48]"), std::string::npos) << msg;
  msg = message_of<ConfigError>([&] {
    make(load_model(shared("build")), params({{"structure", std::string("second_order")}}),
         band_of(0.1, 10.0));
  });
  EXPECT_NE(msg.find("needs a second-order model"), std::string::npos) << msg;
  msg = message_of<ConfigError>([&] {
    make(load_model(shared("build")), params({{"projection", std::string("one_sided")}}),
         band_of(0.1, 10.0));
  });
  EXPECT_NE(msg.find("projection = one_sided with structure first_order needs a descriptor model "
                     "with E symmetric positive definite and A symmetric negative definite"),
            std::string::npos)
      << msg;
  msg = message_of<ConfigError>([&] { registry().create("irka", params({{"tolerance", 0.5}})); });
  EXPECT_NE(msg.find("tolerance"), std::string::npos) << msg;
  msg = message_of<ConfigError>([&] {
    registry().create("irka", params({{"model_tolerance", 1e-9}}));
  });
  EXPECT_NE(msg.find("model_tolerance = 1e-09: must be 0 (off) or >= 1e-7"), std::string::npos)
      << msg;
  msg = message_of<ConfigError>([&] {
    registry().create("irka", params({{"initial_shifts", std::string("dense")}}));
  });
  EXPECT_NE(msg.find("initial_shifts"), std::string::npos) << msg;
  // A balanced start needs dense Gramians: refused above dense_check_limit states.
  auto big =
      make(load_model(shared("build")),
           params({{"initial_shifts", std::string("balanced")}, {"dense_check_limit", 40LL}}),
           band_of(0.1, 10.0));
  msg = message_of<ConfigError>([&] { big->reducer->reduce(ReductionRequest{4, {}}); });
  EXPECT_NE(msg.find("initial_shifts = balanced needs dense Gramians: the first-order state has 48 "
                     "> dense_check_limit = 40"),
            std::string::npos)
      << msg;
}

}  // namespace
}  // namespace ecmor
