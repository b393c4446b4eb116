// The compression of an accepted model (compress: true; run/src/compression.hpp), through
// the driver on models held in memory.
//
// Independent references: the full model's response by Eigen's SparseLU (not ecmor's solvers, cache
// or estimator) on a grid of the test's own plus every resonance of the compressed model in the
// band; the bases' consistency W' A V = Ar computed here; the rigid-body poles of a free solid
// (six poles at s = 0 for Rayleigh damping, test_free_body.cpp's argument).
#include <gtest/gtest.h>

#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "../../bench/solid.hpp"
#include "../../bench/triple_chain.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/driver.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

Registry& registry() {
  static Registry r;
  if (r.entries().empty())
    for (const char* lib : {"libecmor_modal.so", "libecmor_krylov.so", "libecmor_balanced.so"})
      r.load_plugin(fs::path(ECMOR_TEST_PLUGIN_DIR) / lib);
  return r;
}

RunResult run(const Model& model, const std::string& yaml) {
  ConfigRequirements in_memory;
  in_memory.model = false;
  in_memory.output = false;
  return run_reduction(parse_run_config(yaml, "test", in_memory), model, registry());
}

// max |a - b| / max(|a|, |b|) over the entries.
double relative_difference(const Matrix& a, const Matrix& b) {
  const double scale = std::max(a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff());
  return scale == 0.0 ? 0.0 : (a - b).cwiseAbs().maxCoeff() / scale;
}

// sup of ||H - Hr||_2 / ||H||_2 on log-spaced samples of the band and at the reduced model's
// resonances in it; H by Eigen's SparseLU, Hr by a dense LU.
double independent_sup_error(const SecondOrderModel& full, const ReducedSecondOrderModel& r,
                             const Band& band, Index samples) {
  std::vector<double> f = log_grid(band.f_min_hz, band.f_max_hz, samples);
  for (const Complex& p : poles(ReducedModel(r))) {
    const double fp = std::abs(p.imag()) / kTwoPi;
    if (fp >= band.f_min_hz && fp <= band.f_max_hz) f.push_back(fp);
  }
  double sup = 0.0;
  for (double fk : f) {
    const Complex s(0.0, kTwoPi * fk);
    const ComplexSparseMatrix P =
        (s * s) * full.M.cast<Complex>() + s * full.D.cast<Complex>() + full.K.cast<Complex>();
    Eigen::SparseLU<ComplexSparseMatrix> lu(P);
    const ComplexMatrix H = full.C.cast<Complex>() * lu.solve(full.B.cast<Complex>());
    const ComplexMatrix Pr =
        (s * s) * r.M.cast<Complex>() + s * r.D.cast<Complex>() + r.K.cast<Complex>();
    const ComplexMatrix Hr = r.C.cast<Complex>() * Pr.partialPivLu().solve(r.B.cast<Complex>());
    const Eigen::JacobiSVD<ComplexMatrix> e(H - Hr), h(H);
    sup = std::max(sup, e.singularValues()(0) / h.singularValues()(0));
  }
  return sup;
}

// sup of ||H - Hr||_2 / ||H||_2 over f for a descriptor model; H by Eigen's SparseLU, Hr by a
// dense LU.
double independent_sup_error(const DescriptorModel& full, const ReducedDescriptorModel& r,
                             const std::vector<double>& f) {
  double sup = 0.0;
  for (double fk : f) {
    const Complex s(0.0, kTwoPi * fk);
    const ComplexSparseMatrix P = s * full.E.cast<Complex>() - full.A.cast<Complex>();
    Eigen::SparseLU<ComplexSparseMatrix> lu(P);
    const ComplexMatrix H = full.C.cast<Complex>() * lu.solve(full.B.cast<Complex>());
    const ComplexMatrix Pr = s * r.E.cast<Complex>() - r.A.cast<Complex>();
    const ComplexMatrix Hr = r.C.cast<Complex>() * Pr.partialPivLu().solve(r.B.cast<Complex>());
    const Eigen::JacobiSVD<ComplexMatrix> e(H - Hr), h(H);
    sup = std::max(sup, e.singularValues()(0) / h.singularValues()(0));
  }
  return sup;
}

const std::string kChain = R"(
band:     {f_min_hz: 1.0e-5, f_max_hz: 0.02}
target:   {tolerance: 1.0e-3}
reducer:  {name: modal, static_correction: true}
strategy: {name: grow_order, max_order: 200}
)";

// The triple chain of the shipped example: the accepted model is compressed, the compressed one
// meets the target against the test's own full solves, keeps the second-order form, symmetry and
// consistent bases; compress: false gives the uncompressed run (the strategy's accepted model,
// which the compressed one is searched inside: c.order_before).
TEST(Compression, TripleChainShrinksAndMeetsTheTargetAgainstIndependentSolves) {
  const SecondOrderModel chain = bench::triple_chain(150, 0.01, 0.01, 5.0);
  const Model model = chain;
  const RunResult plain = run(model, kChain + "compress: false\n");
  const RunResult compressed = run(model, kChain);  // compress: true is the default
  const RunResult explicit_on = run(model, kChain + "compress: true\n");

  ASSERT_EQ(plain.summary.termination, Termination::Converged) << plain.summary.message;
  EXPECT_FALSE(plain.summary.compression.attempted);
  for (const IterationRecord& r : plain.history) EXPECT_NE(r.phase, "compress");
  EXPECT_EQ(explicit_on.summary.order, compressed.summary.order);
  EXPECT_EQ(explicit_on.summary.band_error, compressed.summary.band_error);

  const CompressionReport& c = compressed.summary.compression;
  ASSERT_EQ(compressed.summary.termination, Termination::Converged) << compressed.summary.message;
  ASSERT_TRUE(c.applied) << c.note;
  EXPECT_EQ(c.order_before, plain.summary.order);
  EXPECT_EQ(c.order_after, compressed.summary.order);
  EXPECT_LT(compressed.summary.order, plain.summary.order);
  EXPECT_LE(c.factorizations, 5) << "the compression's check";
  ASSERT_FALSE(compressed.history.empty());
  EXPECT_EQ(compressed.history.back().phase, "compress");
  EXPECT_EQ(compressed.history.back().order, compressed.summary.order);

  ASSERT_TRUE(compressed.model.has_value());
  const auto* r = std::get_if<ReducedSecondOrderModel>(&compressed.model->model);
  ASSERT_NE(r, nullptr) << "the second-order form is kept";
  EXPECT_LE(relative_asymmetry(r->M), 1e-12);
  EXPECT_LE(relative_asymmetry(r->K), 1e-12);
  const Matrix& V = compressed.model->V;
  const Matrix& W = compressed.model->W;
  ASSERT_EQ(V.cols(), compressed.summary.order);
  EXPECT_LE(relative_difference(W.transpose() * (chain.M * V), r->M), 1e-10);
  EXPECT_LE(relative_difference(W.transpose() * (chain.D * V), r->D), 1e-10);
  EXPECT_LE(relative_difference(W.transpose() * (chain.K * V), r->K), 1e-10);
  EXPECT_LE(relative_difference(W.transpose() * chain.B, r->B), 1e-10);
  EXPECT_LE(relative_difference(chain.C * V, r->C), 1e-10);

  const Band band{1.0e-5, 0.02};
  const double sup = independent_sup_error(chain, *r, band, 400);
  EXPECT_LE(sup, 1.0e-3) << "order " << compressed.summary.order;
  EXPECT_EQ(compressed.summary.compression.error_after, compressed.summary.verified_band_error);
}

// A free-floating solid keeps its six rigid-body modes through the compression of a greedy
// Krylov model (whose smallest step is a whole moment at a point: room to compress).
TEST(Compression, FreeSolidKeepsItsRigidBodyModes) {
  bench::SolidOptions o;
  o.nx = 12;
  o.ny = 2;
  o.nz = 1;
  o.clamped = false;
  const Model model = bench::solid(o);
  const RunResult result = run(model, R"(
band:     {f_min_hz: 10.0, f_max_hz: 3000.0}
target:   {tolerance: 1.0e-3}
reducer:  {name: krylov}
strategy: {name: greedy_points}
compress: true
)");
  ASSERT_EQ(result.summary.termination, Termination::Converged) << result.summary.message;
  const CompressionReport& c = result.summary.compression;
  EXPECT_TRUE(c.applied) << c.note << " order " << result.summary.order << " error "
                         << result.summary.band_error << " " << result.summary.message;
  EXPECT_EQ(result.summary.stability.full_rigid_modes, 6);
  EXPECT_EQ(result.summary.stability.rigid_modes, 6) << result.summary.stability.label;
  EXPECT_TRUE(result.summary.stable) << result.summary.stability.reason;
  // Rayleigh damping: each rigid-body mode has a pole at s = 0; count them in the reduced model.
  Index at_zero = 0;
  for (const Complex& p : poles(result.model->model)) at_zero += std::abs(p) <= 1e-3 ? 1 : 0;
  EXPECT_EQ(at_zero, 6);
}

// A heat model (rail_371: first order, E and A symmetric) through modal truncation: compressed as
// a first-order model (with the static correction of the modes left out), still first order and
// symmetric, meeting the target against the test's own solves.
TEST(Compression, SymmetricFirstOrderModelShrinksAndMeetsTheTarget) {
  const Model model = load_model(fs::path("models") / "rail_371");
  const auto& heat = std::get<DescriptorModel>(model);
  const RunResult result = run(model, R"(
band:     {f_min_hz: 1.6e-7, f_max_hz: 1.6e-3}
target:   {tolerance: 1.0e-2}
reducer:  {name: modal}
strategy: {name: grow_order, max_order: 371}
compress: true
)");
  ASSERT_EQ(result.summary.termination, Termination::Converged) << result.summary.message;
  const CompressionReport& c = result.summary.compression;
  ASSERT_TRUE(c.applied) << c.note;
  EXPECT_LT(c.order_after, c.order_before);
  const auto* r = std::get_if<ReducedDescriptorModel>(&result.model->model);
  ASSERT_NE(r, nullptr) << "first order stays first order";
  EXPECT_LE(relative_asymmetry(r->E), 1e-12);
  EXPECT_LE(relative_asymmetry(r->A), 1e-12);
  const Matrix& V = result.model->V;
  EXPECT_LE(relative_difference(V.transpose() * (heat.A * V), r->A), 1e-10);
  EXPECT_LE(relative_difference(V.transpose() * (heat.E * V), r->E), 1e-10);
  const double sup = independent_sup_error(heat, *r, log_grid(1.6e-7, 1.6e-3, 300));
  EXPECT_LE(sup, 1.0e-2) << "order " << result.summary.order;
}

// A Petrov-Galerkin model (balanced truncation of cdplayer: first order, W != V, unsymmetric)
// has no symmetric modes to truncate: it is compressed two-sided, onto the right and left
// invariant subspaces of its most dominant poles in the band (20 -> 16; its band responses'
// leading directions, the other family tried, reach 18). The compressed model is stable,
// W' E V = Er and W' A V = Ar with the written bases, and it meets the target against the test's
// own solves (Eigen's SparseLU).
TEST(Compression, PetrovGalerkinModelShrinksTwoSidedAndMeetsTheTarget) {
  const Model model = load_model(fs::path("models") / "cdplayer");
  const auto& full = std::get<DescriptorModel>(model);
  const double tol = 1.0e-2;
  const RunResult result = run(model, R"(
band:     {f_min_hz: 0.0159, f_max_hz: 159.0}
target:   {tolerance: 1.0e-2}
reducer:  {name: balanced}
strategy: {name: grow_order, max_order: 100}
)");
  ASSERT_EQ(result.summary.termination, Termination::Converged) << result.summary.message;
  const CompressionReport& c = result.summary.compression;
  ASSERT_TRUE(c.applied) << c.note;
  EXPECT_EQ(c.method.find("reduced modal truncation"), 0u) << c.method;
  EXPECT_NE(c.method.find("(Petrov-Galerkin)"), std::string::npos) << c.method;
  EXPECT_LT(c.order_after, c.order_before);
  EXPECT_LE(c.factorizations, 5);
  const auto* r = std::get_if<ReducedDescriptorModel>(&result.model->model);
  ASSERT_NE(r, nullptr);
  const Matrix& V = result.model->V;
  const Matrix& W = result.model->W;
  ASSERT_EQ(V.cols(), result.summary.order);
  ASSERT_EQ(W.cols(), result.summary.order);
  EXPECT_LE(relative_difference(W.transpose() * (full.E * V), r->E), 1e-10);
  EXPECT_LE(relative_difference(W.transpose() * (full.A * V), r->A), 1e-10);
  EXPECT_LE(relative_difference(W.transpose() * full.B, r->B), 1e-10);
  EXPECT_LE(relative_difference(full.C * V, r->C), 1e-10);
  const ComplexVector p = poles(ReducedModel(*r));
  std::vector<double> f = log_grid(0.0159, 159.0, 300);
  for (Index i = 0; i < p.size(); ++i) {
    EXPECT_LT(p(i).real(), 0.0) << "pole " << i << " of the compressed model";
    const double fp = std::abs(p(i).imag()) / kTwoPi;
    if (fp >= 0.0159 && fp <= 159.0) f.push_back(fp);
  }
  EXPECT_LE(independent_sup_error(full, *r, f), tol) << "order " << result.summary.order;
}

// An unsymmetric second-order model (build_so, modal with a two-sided basis): no symmetric modes
// to truncate, so the compression keeps the leading directions of its band responses, the position
// parts, and the model stays second order with W' M V = Mr, and meets the target against the
// test's own solves.
TEST(Compression, UnsymmetricSecondOrderModelStaysSecondOrder) {
  const Model model = load_model(fs::path("models") / "build_so");
  const auto& full = std::get<SecondOrderModel>(model);
  const RunResult result = run(model, R"(
band:     {f_min_hz: 0.0159, f_max_hz: 159.0}
target:   {tolerance: 5.0e-2}
reducer:  {name: modal}
strategy: {name: grow_order, max_order: 24}
)");
  ASSERT_EQ(result.summary.termination, Termination::Converged) << result.summary.message;
  const CompressionReport& c = result.summary.compression;
  ASSERT_TRUE(c.applied) << c.note;
  EXPECT_NE(c.method.find("response-weighted"), std::string::npos) << c.method;
  const auto* r = std::get_if<ReducedSecondOrderModel>(&result.model->model);
  ASSERT_NE(r, nullptr) << "the second-order form is kept";
  const Matrix& V = result.model->V;
  const Matrix W = result.model->W.size() == 0 ? V : result.model->W;
  ASSERT_EQ(V.cols(), result.summary.order);
  EXPECT_LE(relative_difference(W.transpose() * (full.M * V), r->M), 1e-10);
  EXPECT_LE(relative_difference(W.transpose() * (full.D * V), r->D), 1e-10);
  EXPECT_LE(relative_difference(W.transpose() * (full.K * V), r->K), 1e-10);
  EXPECT_LE(relative_difference(W.transpose() * full.B, r->B), 1e-10);
  EXPECT_LE(relative_difference(full.C * V, r->C), 1e-10);
  EXPECT_LE(independent_sup_error(full, *r, Band{0.0159, 159.0}, 300), 5.0e-2)
      << "order " << result.summary.order;
}

TEST(Compression, TheKeyIsTrueOrFalse) {
  const std::string head = "model: {dir: m}\n" + kChain + "output: {dir: o}\n";
  EXPECT_TRUE(parse_run_config(head + "compress: true\n", "run.yaml").compress);
  EXPECT_FALSE(parse_run_config(head + "compress: false\n", "run.yaml").compress);
  EXPECT_TRUE(parse_run_config(head, "run.yaml").compress) << "the default";
  try {
    parse_run_config(head + "compress: maybe\n", "run.yaml");
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()),
              "run.yaml:8: compress = 'maybe': must be true or false, not a string");
  }
}

}  // namespace
}  // namespace ecmor
