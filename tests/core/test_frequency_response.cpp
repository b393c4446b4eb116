// Tests of transfer functions, band responses, poles and the response cache: closed-form small
// systems, full-order "reductions", and the benchmark models' independent reference responses.
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/builders.hpp"
#include "common/reference_response.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/response/reduced_response.hpp"

namespace {

using ecmor::test::sparse;

using namespace ecmor;

// ---------------------------------------------------------------------------------------------
// The benchmark models (loaded with ecmor::load_model) and their reference responses.

std::string models_dir() { return std::string(ECMOR_TEST_SOURCE_DIR) + "/models/"; }

bool has_model(const std::string& name) {
  return std::ifstream(models_dir() + name + "/info.json").good();
}

Model read_model(const std::string& name) { return load_model(models_dir() + name); }

test::ReferenceResponse read_reference(const std::string& name, Index p, Index m) {
  return test::read_reference_response(models_dir() + name + "/ref_freq_response.csv", p, m);
}

// ---------------------------------------------------------------------------------------------
// Small systems with closed-form responses.

constexpr double km = 2.0, kd = 0.3, kk = 50.0, kb = 1.5, kc = -0.7;

SecondOrderModel one_dof() {
  SecondOrderModel m;
  m.M = sparse(Matrix::Constant(1, 1, km));
  m.D = sparse(Matrix::Constant(1, 1, kd));
  m.K = sparse(Matrix::Constant(1, 1, kk));
  m.B = Matrix::Constant(1, 1, kb);
  m.C = Matrix::Constant(1, 1, kc);
  return m;
}

/// 2-DOF with position and velocity outputs (p = 2) and two inputs.
SecondOrderModel two_dof() {
  Matrix M(2, 2), K(2, 2), B(2, 2), C(2, 2), Cv(2, 2);
  M << 2.0, 0.0, 0.0, 1.0;
  K << 30.0, -10.0, -10.0, 10.0;
  B << 1.0, 0.0, 0.5, 1.0;
  C << 1.0, 0.0, 0.0, 1.0;
  Cv << 0.0, 0.2, 0.1, 0.0;
  SecondOrderModel m;
  m.M = sparse(M);
  m.K = sparse(K);
  m.D = sparse(0.1 * M + 0.01 * K);
  m.B = B;
  m.C = C;
  m.Cv = Cv;
  return m;
}

/// Closed-form inverse of a 2 x 2 matrix.
ComplexMatrix inverse2(const ComplexMatrix& P) {
  const Complex det = P(0, 0) * P(1, 1) - P(0, 1) * P(1, 0);
  ComplexMatrix Q(2, 2);
  Q << P(1, 1), -P(0, 1), -P(1, 0), P(0, 0);
  return Q / det;
}

/// Descriptor with singular E (a DAE), p = 1, m = 2: H via a closed-form 2x2 Schur complement.
DescriptorModel descriptor() {
  Matrix E = Matrix::Zero(3, 3), A(3, 3);
  E(0, 0) = 1.0;
  E(1, 1) = 2.0;
  A << -1.0, 2.0, 0.0,  //
      -3.0, -1.0, 1.0,  //
      0.5, 0.0, 1.0;
  DescriptorModel m;
  m.E = sparse(E);
  m.A = sparse(A);
  m.B = Matrix::Ones(3, 2);
  m.B(2, 1) = -1.0;
  m.C = Matrix::Ones(1, 3);
  m.C(0, 1) = 2.0;
  return m;
}

ComplexMatrix descriptor_exact(const DescriptorModel& m, Complex s) {
  // P = sE - A = [[P11, p12], [p21, p22]] with a scalar p22 = -A(2,2): eliminate x_2.
  ComplexMatrix P = s * Matrix(m.E).cast<Complex>() - Matrix(m.A).cast<Complex>();
  const Complex p22 = P(2, 2);
  ComplexMatrix S = P.topLeftCorner(2, 2) - P.topRightCorner(2, 1) * P.bottomLeftCorner(1, 2) / p22;
  ComplexMatrix Sinv = inverse2(S);
  ComplexMatrix B = m.B.cast<Complex>();
  // x_top = S^-1 (b_top - p12 b_2 / p22), x_2 = (b_2 - p21 x_top) / p22.
  ComplexMatrix rhs = B.topRows(2) - P.topRightCorner(2, 1) * B.bottomRows(1) / p22;
  ComplexMatrix xt = Sinv * rhs;
  ComplexMatrix x2 = (B.bottomRows(1) - P.bottomLeftCorner(1, 2) * xt) / p22;
  ComplexMatrix X(3, 2);
  X << xt, x2;
  return m.C.cast<Complex>() * X;
}

ReducedModel dense_copy(const Model& model) {
  if (const auto* so = std::get_if<SecondOrderModel>(&model)) {
    ReducedSecondOrderModel r;
    r.M = Matrix(so->M);
    r.D = Matrix(so->D);
    r.K = Matrix(so->K);
    r.B = so->B;
    r.C = so->C;
    r.Cv = so->Cv;
    return r;
  }
  const auto& ds = std::get<DescriptorModel>(model);
  ReducedDescriptorModel r;
  r.E = Matrix(ds.E);
  r.A = Matrix(ds.A);
  r.B = ds.B;
  r.C = ds.C;
  return r;
}

double rel(const ComplexMatrix& X, const ComplexMatrix& Y) { return (X - Y).norm() / Y.norm(); }

// ---------------------------------------------------------------------------------------------

TEST(LogGrid, EndPointsAndSpacing) {
  const auto f = log_grid(0.1, 1000.0, 5);
  ASSERT_EQ(f.size(), 5u);
  EXPECT_EQ(f.front(), 0.1);
  EXPECT_EQ(f.back(), 1000.0);
  for (std::size_t i = 1; i < f.size(); ++i) EXPECT_NEAR(f[i] / f[i - 1], 10.0, 1e-12);
}

TEST(LogGrid, InvalidArgumentsNameTheProblem) {
  EXPECT_THROW(log_grid(1.0, 10.0, 1), ConfigError);
  EXPECT_THROW(log_grid(0.0, 10.0, 5), ConfigError);
  EXPECT_THROW(log_grid(10.0, 1.0, 5), ConfigError);
  try {
    log_grid(-1.0, 10.0, 5);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("f_min_hz"), std::string::npos) << e.what();
  }
}

TEST(TransferFunction, OneDofClosedForm) {
  Model model = one_dof();
  auto solver = make_shifted_solver(model);
  for (double f : {0.01, 0.5, 0.795, 1.0, 10.0, 1e3}) {
    const Complex s = s_from_hz(f);
    const Complex exact = kc * kb / (km * s * s + kd * s + kk);
    ComplexMatrix H = transfer_function(model, *solver, s);
    ASSERT_EQ(H.rows(), 1);
    ASSERT_EQ(H.cols(), 1);
    EXPECT_LT(std::abs(H(0, 0) - exact) / std::abs(exact), 1e-14) << f;
    ComplexMatrix Hr = transfer_function(dense_copy(model), s);
    EXPECT_LT(std::abs(Hr(0, 0) - exact) / std::abs(exact), 1e-14) << f;
  }
  // Real s (s = 0: static gain) takes the real path.
  ComplexMatrix H0 = transfer_function(model, *solver, Complex(0.0, 0.0));
  EXPECT_NEAR(H0(0, 0).real(), kc * kb / kk, 1e-15);
  EXPECT_EQ(H0(0, 0).imag(), 0.0);
}

TEST(TransferFunction, TwoDofClosedFormWithVelocityOutput) {
  const auto sys = two_dof();
  Model model = sys;
  auto solver = make_shifted_solver(model);
  for (double f : {0.0, 0.05, 0.4, 0.7, 3.0}) {
    const Complex s = s_from_hz(f);
    ComplexMatrix P = (s * s) * Matrix(sys.M).cast<Complex>() + s * Matrix(sys.D).cast<Complex>() +
                      Matrix(sys.K).cast<Complex>();
    ComplexMatrix exact =
        (sys.C.cast<Complex>() + s * sys.Cv.cast<Complex>()) * inverse2(P) * sys.B.cast<Complex>();
    EXPECT_LT(rel(transfer_function(model, *solver, s), exact), 1e-14) << f;
    EXPECT_LT(rel(transfer_function(dense_copy(model), s), exact), 1e-14) << f;
  }
}

TEST(TransferFunction, MoreInputsThanOutputsUsesTransposedSolves) {
  auto sys = two_dof();
  sys.C = sys.C.topRows(1).eval();
  sys.Cv = sys.Cv.topRows(1).eval();  // p = 1 < m = 2
  Model model = sys;
  auto solver = make_shifted_solver(model);
  const Complex s = s_from_hz(0.6);
  ComplexMatrix P = (s * s) * Matrix(sys.M).cast<Complex>() + s * Matrix(sys.D).cast<Complex>() +
                    Matrix(sys.K).cast<Complex>();
  ComplexMatrix exact =
      (sys.C.cast<Complex>() + s * sys.Cv.cast<Complex>()) * inverse2(P) * sys.B.cast<Complex>();
  const auto before = solver->counters().solves;
  EXPECT_LT(rel(transfer_function(model, *solver, s), exact), 1e-14);
  EXPECT_EQ(solver->counters().solves - before, 1);  // one transposed solve, not two
}

TEST(TransferFunction, DescriptorClosedForm) {
  const auto sys = descriptor();
  Model model = sys;
  auto solver = make_shifted_solver(model);
  for (double f : {0.0, 0.01, 0.3, 2.0, 100.0}) {
    const Complex s = s_from_hz(f);
    ComplexMatrix exact = descriptor_exact(sys, s);
    EXPECT_LT(rel(transfer_function(model, *solver, s), exact), 1e-14) << f;
    EXPECT_LT(rel(transfer_function(dense_copy(model), s), exact), 1e-14) << f;
  }
}

TEST(TransferFunction, ReducedSingularThrows) {
  // Undamped 1-DOF: pole at s = 2i.
  ReducedSecondOrderModel r;
  r.M = Matrix::Constant(1, 1, 1.0);
  r.D = Matrix::Zero(1, 1);
  r.K = Matrix::Constant(1, 1, 4.0);
  r.B = Matrix::Ones(1, 1);
  r.C = Matrix::Ones(1, 1);
  try {
    transfer_function(ReducedModel(r), Complex(0.0, 2.0));
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
  }
}

TEST(FrequencyResponse, ParallelEqualsSerial) {
  ASSERT_TRUE(has_model("triplechain_saak09_n451"))
      << "benchmark model not found in " << models_dir();
  Model model = read_model("triplechain_saak09_n451");
  auto solver = make_shifted_solver(model);
  const auto f = log_grid(1e-4, 10.0, 40);
  const auto serial = frequency_response(model, *solver, f, 1);
  const auto parallel = frequency_response(model, *solver, f, 2);
  const auto dflt = frequency_response(model, *solver, f);
  ASSERT_EQ(parallel.size(), f.size());
  for (std::size_t i = 0; i < f.size(); ++i) {
    EXPECT_EQ((parallel[i] - serial[i]).norm(), 0.0) << i;
    EXPECT_EQ((dflt[i] - serial[i]).norm(), 0.0) << i;
  }
  EXPECT_EQ(solver->counters().symbolic_analyses, 1);
  EXPECT_EQ(solver->counters().complex_factorizations, 120);
}

TEST(FrequencyResponse, ExceptionInsideParallelRegionIsRethrown) {
  // Undamped 1-DOF s^2 + 4: f = 2 / (2 pi) Hz is a pole.
  SecondOrderModel m;
  m.M = sparse(Matrix::Constant(1, 1, 1.0));
  m.D = SparseMatrix(1, 1);
  m.K = sparse(Matrix::Constant(1, 1, 4.0));
  m.B = Matrix::Ones(1, 1);
  m.C = Matrix::Ones(1, 1);
  Model model = m;
  auto solver = make_shifted_solver(model);
  std::vector<double> f = log_grid(0.01, 10.0, 30);
  f[17] = 2.0 / kTwoPi;
  // s = i 2 pi (2 / 2 pi) may differ from 2i by round-off; then P is tiny but not zero: both the
  // singular-warning and the rcond test must catch it.
  try {
    frequency_response(model, *solver, f, 2);
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
  }
  f[17] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(frequency_response(model, *solver, f, 2), NumericalError);
}

TEST(FrequencyResponse, ReducedFullOrderReductionReproducesFull) {
  for (const std::string name : {"lf10", "build_so", "cdplayer", "build"}) {
    ASSERT_TRUE(has_model(name)) << "benchmark model " << name << " not found in " << models_dir();
    Model model = read_model(name);
    auto solver = make_shifted_solver(model);
    const Index p = std::visit([](const auto& sys) { return sys.C.rows(); }, model);
    const Index m = std::visit([](const auto& sys) { return sys.B.cols(); }, model);
    const test::ReferenceResponse ref =
        read_reference(name, p, m);  // only the omegas are used here
    std::vector<double> f;
    for (std::size_t i = 0; i < ref.omega.size(); i += 7) f.push_back(ref.omega[i] / kTwoPi);
    const auto Hfull = frequency_response(model, *solver, f);
    const auto Hred = frequency_response(dense_copy(model), f);
    double worst = 0.0;
    for (std::size_t i = 0; i < f.size(); ++i) worst = std::max(worst, rel(Hred[i], Hfull[i]));
    EXPECT_LT(worst, 1e-9) << name;
    std::printf("[ full-order reduction ] %-10s worst rel. diff reduced vs full %.2e\n",
                name.c_str(), worst);
  }
}

TEST(Poles, OneDofAndTwoDof) {
  // m s^2 + d s + k = 0.
  ReducedSecondOrderModel r;
  r.M = Matrix::Constant(1, 1, km);
  r.D = Matrix::Constant(1, 1, kd);
  r.K = Matrix::Constant(1, 1, kk);
  r.B = Matrix::Ones(1, 1);
  r.C = Matrix::Ones(1, 1);
  ComplexVector p = poles(ReducedModel(r));
  ASSERT_EQ(p.size(), 2);
  const Complex disc = std::sqrt(Complex(kd * kd - 4.0 * km * kk, 0.0));
  const Complex p1 = (-kd + disc) / (2.0 * km), p2 = (-kd - disc) / (2.0 * km);
  const double e1 = std::min(std::abs(p(0) - p1), std::abs(p(0) - p2));
  const double e2 = std::min(std::abs(p(1) - p1), std::abs(p(1) - p2));
  EXPECT_LT(e1, 1e-12);
  EXPECT_LT(e2, 1e-12);
  // 2-DOF: every pole makes P(lambda) singular.
  const auto sys = two_dof();
  const auto red = dense_copy(Model(sys));
  ComplexVector q = poles(red);
  ASSERT_EQ(q.size(), 4);
  for (Index i = 0; i < q.size(); ++i) {
    const Complex s = q(i);
    ComplexMatrix P = (s * s) * Matrix(sys.M).cast<Complex>() + s * Matrix(sys.D).cast<Complex>() +
                      Matrix(sys.K).cast<Complex>();
    EXPECT_LT(std::abs(P.determinant()) / P.norm() / P.norm(), 1e-12) << s;
    EXPECT_LT(s.real(), 0.0);
  }
}

// The reduced model's dense path (LU with partial pivoting by LAPACK, after row equilibration):
// against Eigen's full-pivoting LU of the same P_r(s), MIMO, second order and descriptor, from a
// well-conditioned to a badly scaled model; at an undamped pole it names the pole instead of
// returning digits that mean nothing.
TEST(FrequencyResponse, ReducedDenseLuAgreesWithFullPivotingAndNamesAPole) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  auto random = [&](Index rows, Index cols) {
    Matrix A(rows, cols);
    for (Index i = 0; i < A.size(); ++i) A.data()[i] = normal(rng);
    return A;
  };
  for (Index n : {3, 40, 150}) {
    ReducedSecondOrderModel so;
    const Matrix X = random(n, n);
    so.M = X * X.transpose() + Matrix::Identity(n, n);
    const Matrix Y = random(n, n);
    so.K = 1e4 * (Y * Y.transpose()) + Matrix::Identity(n, n);
    so.D = 1e-3 * so.K;
    so.B = random(n, 3);
    so.C = random(2, n);
    ReducedDescriptorModel ds;
    ds.E = so.M;
    ds.E.row(0) *= 1e-9;  // rows nine decades apart: the equilibration's case
    ds.A = -so.K;
    ds.B = so.B;
    ds.C = so.C;
    for (const ReducedModel& model : {ReducedModel(so), ReducedModel(ds)}) {
      for (double w : {0.3, 17.0, 900.0}) {
        const Complex s(0.0, w);
        ComplexMatrix P, B, C;
        if (const auto* m = std::get_if<ReducedSecondOrderModel>(&model)) {
          P = (s * s) * m->M.cast<Complex>() + s * m->D.cast<Complex>() + m->K.cast<Complex>();
          B = m->B.cast<Complex>();
          C = m->C.cast<Complex>();
        } else {
          const auto& d = std::get<ReducedDescriptorModel>(model);
          P = s * d.E.cast<Complex>() - d.A.cast<Complex>();
          B = d.B.cast<Complex>();
          C = d.C.cast<Complex>();
        }
        const ComplexMatrix expected = C * P.fullPivLu().solve(B);
        const ComplexMatrix H = transfer_function(model, s);
        ASSERT_EQ(H.rows(), 2);
        ASSERT_EQ(H.cols(), 3);
        EXPECT_LT((H - expected).norm(), 1e-10 * expected.norm()) << "n " << n << " w " << w;
      }
    }
  }
  // Undamped: s^2 + 4 vanishes at s = 2i exactly.
  ReducedSecondOrderModel one;
  one.M = Matrix::Ones(1, 1);
  one.D = Matrix::Zero(1, 1);
  one.K = Matrix::Constant(1, 1, 4.0);
  one.B = Matrix::Ones(1, 1);
  one.C = Matrix::Ones(1, 1);
  try {
    (void)transfer_function(ReducedModel(one), Complex(0.0, 2.0));
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("singular at s = "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("pole of the reduced model"), std::string::npos)
        << e.what();
  }
  EXPECT_NEAR(transfer_function(ReducedModel(one), Complex(0.0, 1.0))(0, 0).real(), 1.0 / 3.0,
              1e-15);
}

TEST(Poles, SingularMassAndDescriptorDropInfiniteEigenvalues) {
  // Descriptor with E of rank 2 (n = 3): 2 finite poles.
  const auto red = dense_copy(Model(descriptor()));
  ComplexVector p = poles(red);
  ASSERT_EQ(p.size(), 2);
  const auto& ds = std::get<ReducedDescriptorModel>(red);
  for (Index i = 0; i < p.size(); ++i) {
    ComplexMatrix P = p(i) * ds.E.cast<Complex>() - ds.A.cast<Complex>();
    EXPECT_LT(std::abs(P.determinant()) / std::pow(P.norm(), 3), 1e-12) << p(i);
  }
  // Second order with a singular M (one massless DOF): 2n - 1 finite poles.
  auto sys = two_dof();
  Matrix M = Matrix(sys.M);
  M(1, 1) = 0.0;
  ReducedSecondOrderModel r = std::get<ReducedSecondOrderModel>(dense_copy(Model(sys)));
  r.M = M;
  EXPECT_EQ(poles(ReducedModel(r)).size(), 3);
}

// poles() remembers the last few models (compared exactly): a repeated model gets the same
// poles, and a model differing in one entry of M, D or K, or in size, gets its own.
TEST(Poles, RepeatedModelsShareTheirPolesChangedOnesDoNot) {
  const auto sys = two_dof();
  const auto red = dense_copy(Model(sys));
  const ComplexVector p = poles(red);
  const ComplexVector again = poles(red);
  ASSERT_EQ(again.size(), p.size());
  EXPECT_EQ((again - p).cwiseAbs().maxCoeff(), 0.0);
  for (const int which : {0, 1, 2}) {
    ReducedSecondOrderModel r = std::get<ReducedSecondOrderModel>(red);
    Matrix& X = which == 0 ? r.M : which == 1 ? r.D : r.K;
    X(1, 1) *= 1.5;
    const ComplexVector q = poles(ReducedModel(r));
    ASSERT_EQ(q.size(), 4);
    // Every new pole makes the new P(lambda) singular, and they differ from the old ones.
    double moved = 0.0;
    for (Index i = 0; i < q.size(); ++i) {
      const Complex s = q(i);
      const ComplexMatrix P =
          (s * s) * r.M.cast<Complex>() + s * r.D.cast<Complex>() + r.K.cast<Complex>();
      EXPECT_LT(std::abs(P.determinant()) / P.norm() / P.norm(), 1e-12) << which << " " << s;
      double nearest = std::numeric_limits<double>::infinity();
      for (Index j = 0; j < p.size(); ++j) nearest = std::min(nearest, std::abs(s - p(j)));
      moved = std::max(moved, nearest);
    }
    EXPECT_GT(moved, 1e-6) << "matrix " << which << ": the old poles came back";
  }
  // A NaN model is never matched to a cached one (NaN != NaN): it reaches the eigensolver.
  ReducedSecondOrderModel bad = std::get<ReducedSecondOrderModel>(red);
  bad.K(0, 0) = std::numeric_limits<double>::quiet_NaN();
  bool threw = false;
  ComplexVector pb;
  try {
    pb = poles(ReducedModel(bad));
  } catch (const NumericalError&) {
    threw = true;
  }
  if (!threw) {
    EXPECT_FALSE(pb.allFinite());
  }
}

// The poles come from LAPACK on the calling thread alone (dense_lapack.hpp): on a model large
// enough for the blocked code paths (first-order size 300), they agree with Eigen's unblocked QR,
// an independent implementation, and the caller's OpenMP thread count is restored afterwards.
TEST(Poles, AgreeWithAnIndependentEigensolverAndRestoreTheThreadCount) {
  const Index n = 150;
  const Matrix R = test::random_matrix(n, n, 7), S = test::random_matrix(n, n, 8);
  ReducedSecondOrderModel r;
  r.M = Matrix::Identity(n, n) + 0.01 * R * R.transpose();
  r.K = S * S.transpose() + Matrix::Identity(n, n);
  r.D = 0.02 * r.M + 0.001 * r.K;
  r.B = test::random_matrix(n, 2, 9);
  r.C = test::random_matrix(3, n, 10);
  const int threads_before = 2;
  omp_set_num_threads(threads_before);
  const ComplexVector p = poles(ReducedModel(r));
  EXPECT_EQ(omp_get_max_threads(), threads_before);
  Matrix F = Matrix::Zero(2 * n, 2 * n);
  F.topRightCorner(n, n).setIdentity();
  F.bottomLeftCorner(n, n) = -r.M.lu().solve(r.K);
  F.bottomRightCorner(n, n) = -r.M.lu().solve(r.D);
  const Eigen::EigenSolver<Matrix> es(F, false);
  ASSERT_EQ(es.info(), Eigen::Success);
  const ComplexVector q = es.eigenvalues();
  ASSERT_EQ(p.size(), q.size());
  double worst = 0.0;
  for (Index i = 0; i < q.size(); ++i) {
    double nearest = std::numeric_limits<double>::infinity();
    for (Index j = 0; j < p.size(); ++j) nearest = std::min(nearest, std::abs(q(i) - p(j)));
    worst = std::max(worst, nearest / std::abs(q(i)));
  }
  EXPECT_LT(worst, 1e-9);
  // The response set-up (LAPACK's Hessenberg form) restores the count too.
  const ReducedResponse response{ReducedModel(r)};
  EXPECT_TRUE(response.hessenberg());
  EXPECT_EQ(omp_get_max_threads(), threads_before);
}

TEST(ResponseCache, ComputesOnlyMissingFrequencies) {
  const auto sys = two_dof();
  Model model = sys;
  auto solver = make_shifted_solver(model);
  ResponseCache cache(model, *solver, 2);
  const auto f1 = log_grid(0.01, 10.0, 20);
  const auto H1 = cache.evaluate(f1);
  EXPECT_EQ(cache.size(), 20);
  EXPECT_EQ(solver->counters().factorizations, 20);
  // Overlapping request: only the 10 new frequencies (and the duplicate one once) are factorised.
  std::vector<double> f2(f1.begin(), f1.begin() + 5);
  for (double f : log_grid(20.0, 30.0, 10)) f2.push_back(f);
  f2.push_back(25.0);
  f2.push_back(25.0);
  const auto H2 = cache.evaluate(f2);
  EXPECT_EQ(cache.size(), 31);
  EXPECT_EQ(solver->counters().factorizations, 31);
  ASSERT_EQ(H2.size(), f2.size());
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ((H2[i] - H1[i]).norm(), 0.0);
  EXPECT_EQ((cache.evaluate(f1[3]) - H1[3]).norm(), 0.0);
  EXPECT_EQ(solver->counters().factorizations, 31);
  EXPECT_EQ((H2[16] - transfer_function(model, *solver, s_from_hz(25.0))).norm(), 0.0);
}

// ---------------------------------------------------------------------------------------------
// The benchmark models' independent references (SciPy SuperLU) on all 200 frequencies.

class SharedReference : public ::testing::TestWithParam<std::string> {};

TEST_P(SharedReference, MatchesIndependentResponse) {
  const std::string name = GetParam();
  ASSERT_TRUE(has_model(name)) << "benchmark model " << name << " not found in " << models_dir();
  Model model = read_model(name);
  const Index p = std::visit([](const auto& s) { return s.C.rows(); }, model);
  const Index m = std::visit([](const auto& s) { return s.B.cols(); }, model);
  const test::ReferenceResponse ref = read_reference(name, p, m);
  ASSERT_EQ(ref.omega.size(), 200u);
  std::vector<double> f;
  for (double w : ref.omega) f.push_back(w / kTwoPi);
  // Both factorisations of complex symmetric P(s): UMFPACK's LU and MUMPS's LDL^T (unsymmetric
  // models take the LU either way).
  for (const char* method : {"lu", "ldlt"}) {
    SolverOptions options;
    options.complex_symmetric = method;
    auto solver = make_shifted_solver(model, options);
    const auto t0 = std::chrono::steady_clock::now();
    const auto H = frequency_response(model, *solver, f);
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    double worst = 0.0;
    std::size_t worst_i = 0;
    for (std::size_t i = 0; i < f.size(); ++i) {
      const double e = rel(H[i], ref.H[i]);
      if (e > worst) {
        worst = e;
        worst_i = i;
      }
    }
    const std::string used = solver->factorize(s_from_hz(f[0]))->method();
    std::printf(
        "[ reference ] %-24s N = %6ld %-10s worst ||H - Href||_F / ||Href||_F = %.2e at omega = "
        "%.4g (200 freqs in %.3f s)\n",
        name.c_str(), static_cast<long>(std::visit([](const auto& s) { return s.size(); }, model)),
        used.c_str(), worst, ref.omega[worst_i], dt);
    EXPECT_LT(worst, 1e-10) << name << " (" << used << ") at omega = " << ref.omega[worst_i];
  }
}

INSTANTIATE_TEST_SUITE_P(Models, SharedReference,
                         ::testing::Values("triplechain_saak09_n451", "lf10", "build_so", "iss_so",
                                           "build", "cdplayer", "rail_1357",
                                           // further well-conditioned models (all <= 3e-11 now)
                                           "triplechain_cmess_n301", "triplechain_mess_n1501",
                                           "iss", "fom", "heat_cont", "pde", "random200",
                                           "filter2D", "rail_371"));
// Not here: beam (rcond of P(s) 4e-9: 9e-10 from the reference, 7e-10 from a dense full-pivoting
// LU, 5 s), mna1 (rcond 5e-12 at 2.8e12 rad/s: 7e-8 from the reference, 5e-8 from dense LU), peec
// (unstable; its reference is not one), mna5 (no reference file).

}  // namespace
