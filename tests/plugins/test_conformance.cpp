// The conformance suite (ecmor/plugin/conformance.hpp) and the plugin boundary checks of the
// registry (core/src/plugin/reducer_guard.cpp). The bundled reducers must pass the suite; a toy
// reducer with one injected defect at a time shows that each check can fail, and for the reason it
// names.
#include <gtest/gtest.h>

#include <chrono>
#include <random>
#include <stdexcept>
#include <string>

#include "common/plugin_registry.hpp"
#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/plugin/conformance.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace ecmor {
namespace {

using conformance::Report;
using conformance::Status;

// ---- a toy reducer: a correct, simple method and the defects one can inject into it -----------

// Galerkin projection on the block Krylov space of P(sigma)^-1 T with start P(sigma)^-1 B, where
// sigma = 2 pi f_c (real) for the band's centre f_c and T = M (second order) or E (descriptor). The
// whole basis is built in setup(); reduce(n) returns its first n columns, so growth is exact.
class ToyReducer final : public Reducer {
 public:
  explicit ToyReducer(std::string defect) : m_defect(std::move(defect)) {}

  void setup(const ReductionContext& ctx) override {
    m_model = ctx.model;
    const double sigma = kTwoPi * std::sqrt(ctx.band.f_min_hz * ctx.band.f_max_hz);
    const auto f = ctx.solver->factorize(Complex(sigma, 0.0));
    const Index n = size_of(*m_model);
    const bool so = kind_of(*m_model) == ModelKind::SecondOrder;
    const SparseMatrix& T =
        so ? std::get<SecondOrderModel>(*m_model).M : std::get<DescriptorModel>(*m_model).E;
    const Matrix& B =
        so ? std::get<SecondOrderModel>(*m_model).B : std::get<DescriptorModel>(*m_model).B;
    m_basis = Matrix(n, 0);
    Matrix block = f->solve(B);
    for (Index k = 0; k < n && m_basis.cols() < n; ++k) {
      if (orthonormalize_append(m_basis, block) == 0) break;
      block = f->solve(Matrix(T * m_basis.rightCols(std::min<Index>(B.cols(), m_basis.cols()))));
    }
  }

  ReducerResult reduce(const ReductionRequest& request) override {
    ++m_calls;
    if (!request.points.empty() && m_defect != "ignores_points")
      throw ConfigError("toy: no expansion points");
    if (m_defect == "throws") throw std::runtime_error("toy: something broke");
    const Index r = std::min<Index>(std::max<Index>(request.order, 1), m_basis.cols());
    ReducerResult result;
    result.V = m_basis.leftCols(r);
    if (m_defect == "random") {
      std::mt19937_64 rng(
          static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count()));
      std::normal_distribution<double> normal;
      for (Index j = 0; j < r; ++j) result.V(0, j) += 1e-2 * normal(rng);
    }
    // Tilts the subspace by an amount that grows with each call (scaling a column would not do:
    // a projection depends on the span of V only).
    if (m_defect == "history") result.V.col(0) += 1e-3 * m_calls * Vector::Ones(result.V.rows());
    result.W = result.V;
    result.model = project(*m_model, result.V, result.W);
    if (m_defect == "scaled_input") std::visit([](auto& m) { m.B *= 2.0; }, result.model);
    if (m_defect == "wrong_rows") {
      result.V.conservativeResize(result.V.rows() + 1, Eigen::NoChange);
      result.V.row(result.V.rows() - 1).setZero();
      result.W = result.V;
    }
    return result;
  }

  Index max_order() const override { return m_basis.cols(); }

 private:
  std::string m_defect;
  const Model* m_model = nullptr;
  Matrix m_basis;
  int m_calls = 0;
};

// The toy as a registry entry; "accepts_all" declares second-order models only yet accepts any.
Registry& toy_registry() {
  static Registry registry;
  static bool filled = false;
  if (!filled) {
    ReducerFactory f;
    f.info.name = "toy";
    f.info.description = "block Krylov at a real shift (conformance test)";
    f.info.version = "1";
    f.info.second_order = true;
    f.info.descriptor = true;
    f.create = [](const ParameterMap& p) {
      return std::make_unique<ToyReducer>(p.get_string("defect", "none"));
    };
    registry.add(f);
    ReducerFactory g = f;
    g.info.name = "toy_second_order_only";
    g.info.descriptor = false;
    registry.add(g);
    filled = true;
  }
  return registry;
}

Report run_toy(const std::string& defect, const std::string& name = "toy") {
  ParameterMap p("reducer '" + name + "'");
  if (defect != "none") p.set("defect", defect);
  return conformance::run(toy_registry(), name, p);
}

// Status of `check` on `model` ("" = any model: the first failure, else the first result).
Status status_of(const Report& r, const std::string& check, const std::string& model = "") {
  const conformance::CheckResult* found = nullptr;
  for (const auto& c : r.checks) {
    if (c.check != check || (!model.empty() && c.model != model)) continue;
    if (c.status == Status::Failed) return Status::Failed;
    if (found == nullptr) found = &c;
  }
  if (found == nullptr) ADD_FAILURE() << "no check '" << check << "' on '" << model << "'";
  return found != nullptr ? found->status : Status::Skipped;
}

std::string detail_of(const Report& r, const std::string& check) {
  for (const auto& c : r.checks)
    if (c.check == check && c.status == Status::Failed) return c.detail;
  return "";
}

std::string failures(const Report& r) {
  std::string out;
  for (const auto& c : r.checks)
    if (c.status == Status::Failed) out += c.check + " on " + c.model + ": " + c.detail + "\n";
  return out;
}

// ---- the suite on the toy
// -------------------------------------------------------------------------

TEST(Conformance, CorrectToyPassesEveryCheckOnBothModelKinds) {
  const Report r = run_toy("none");
  EXPECT_TRUE(r.passed()) << failures(r);
  EXPECT_EQ(r.count(Status::Skipped), 0);
  // bad_input once; eight checks on each of the two built-in models.
  EXPECT_EQ(r.checks.size(), 1u + 2u * 8u);
  EXPECT_EQ(status_of(r, "full_order", "chain_so"), Status::Passed);
  EXPECT_EQ(status_of(r, "full_order", "stable_descriptor"), Status::Passed);
}

TEST(Conformance, EachInjectedDefectFailsItsCheck) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"wrong_rows", "dimensions"},   {"random", "determinism"},    {"history", "growth"},
      {"scaled_input", "projection"}, {"ignores_points", "points"}, {"throws", "dimensions"}};
  for (const auto& [defect, check] : cases) {
    SCOPED_TRACE(defect);
    const Report r = run_toy(defect);
    EXPECT_FALSE(r.passed());
    EXPECT_EQ(status_of(r, check), Status::Failed) << failures(r);
  }
  // The failures name the cause.
  EXPECT_NE(detail_of(run_toy("wrong_rows"), "dimensions").find("rows"), std::string::npos);
  EXPECT_NE(detail_of(run_toy("throws"), "dimensions").find("not an ecmor::Error"),
            std::string::npos);
  // A defect in one place leaves the other checks passing.
  const Report h = run_toy("history");
  EXPECT_EQ(status_of(h, "determinism"), Status::Passed);
  EXPECT_EQ(status_of(h, "projection"), Status::Passed);
}

TEST(Conformance, AReducerThatAcceptsAnUndeclaredModelKindFails) {
  const Report r = run_toy("none", "toy_second_order_only");
  EXPECT_EQ(status_of(r, "accepts", "chain_so"), Status::Passed);
  EXPECT_EQ(status_of(r, "accepts", "stable_descriptor"), Status::Failed);
  EXPECT_NE(detail_of(r, "accepts").find("declares no descriptor"), std::string::npos);
}

TEST(Conformance, UnknownReducerAndBadOptionsAreConfigErrors) {
  ParameterMap p("reducer 'tyo'");
  EXPECT_THROW(conformance::run(toy_registry(), "tyo", p), ConfigError);
  conformance::Options o;
  o.orders = {4, 2};
  EXPECT_THROW(conformance::run(toy_registry(), "toy", p, o), ConfigError);
  // Invalid parameters are the caller's error, thrown before any check.
  ParameterMap q("reducer 'toy'");
  q.set("defect", 3);
  EXPECT_THROW(conformance::run(toy_registry(), "toy", q), ConfigError);
}

TEST(Conformance, BuiltinModelsAreStableWithPolesInTheirBands) {
  for (const auto& m : conformance::builtin_models()) {
    SCOPED_TRACE(m.name);
    EXPECT_NO_THROW(validate(m.model, m.name));
    EXPECT_EQ(size_of(m.model), 30);
    // Dense poles (the suite's premise: asymptotically stable, dynamics inside both bands).
    ReducedModel dense;
    if (const auto* so = std::get_if<SecondOrderModel>(&m.model)) {
      dense = ReducedSecondOrderModel{Matrix(so->M), Matrix(so->D), Matrix(so->K),
                                      so->B,         so->C,         Matrix()};
    } else {
      const auto& d = std::get<DescriptorModel>(m.model);
      dense = ReducedDescriptorModel{Matrix(d.E), Matrix(d.A), d.B, d.C};
    }
    const ComplexVector p = poles(dense);
    int in_band = 0, in_other = 0;
    for (Index i = 0; i < p.size(); ++i) {
      EXPECT_LT(p(i).real(), 0.0);
      const double f = std::abs(p(i)) / kTwoPi;
      in_band += f >= m.band.f_min_hz && f <= m.band.f_max_hz;
      in_other += f >= m.other_band.f_min_hz && f <= m.other_band.f_max_hz;
    }
    EXPECT_GE(in_band, 3);
    EXPECT_GE(in_other, 3);
  }
}

// ---- the bundled reducers pass
// --------------------------------------------------------------------

struct Bundled {
  std::string library, name;
  bool irka_cold = false;  // irka with warm_start: false (see the IRKA test below)
};

class BundledReducer : public ::testing::TestWithParam<Bundled> {};

TEST_P(BundledReducer, PassesTheSuite) {
  const Bundled& b = GetParam();
  Registry& registry = test::plugin_registry(b.library);
  ParameterMap p("reducer '" + b.name + "'");
  if (b.irka_cold) p.set("warm_start", false);
  const Report r = conformance::run(registry, b.name, p);
  EXPECT_TRUE(r.passed()) << failures(r);
  for (const auto& c : r.checks)
    std::printf("  %-12s %-18s %-5s %s\n", c.check.c_str(), c.model.c_str(),
                conformance::to_string(c.status).c_str(), c.detail.c_str());
}

// IRKA started warm (its default: each order starts from the shifts of the nearest smaller order
// run before) is path-dependent: the model at order r depends on the orders asked before. The
// suite reports it; cold starts conform.
INSTANTIATE_TEST_SUITE_P(Plugins, BundledReducer,
                         ::testing::Values(Bundled{"libecmor_modal.so", "modal"},
                                           Bundled{"libecmor_krylov.so", "krylov"},
                                           Bundled{"libecmor_irka.so", "irka", true},
                                           Bundled{"libecmor_balanced.so", "balanced"}),
                         [](const auto& p) { return p.param.name; });

TEST(Conformance, WarmStartedIrkaIsReportedAsPathDependent) {
  Registry& registry = test::plugin_registry("libecmor_irka.so");
  const Report r = conformance::run(registry, "irka", ParameterMap("reducer 'irka'"));
  EXPECT_EQ(status_of(r, "growth", "chain_so"), Status::Failed) << failures(r);
}

// ---- the plugin boundary checks of the registry
// ---------------------------------------------------

struct Bound {
  Model model;
  std::unique_ptr<ShiftedSolver> solver;
  std::shared_ptr<Reducer> reducer;
};

std::unique_ptr<Bound> bind(const std::string& defect, bool setup = true) {
  auto b = std::make_unique<Bound>();
  const auto m = conformance::builtin_models().front();
  b->model = m.model;
  b->solver = make_shifted_solver(b->model);
  ParameterMap p("reducer 'toy'");
  p.set("defect", defect);
  b->reducer = toy_registry().create("toy", p);
  if (setup) b->reducer->setup(ReductionContext{&b->model, b->solver.get(), m.band});
  return b;
}

TEST(PluginBoundary, WrongShapeIsAPluginErrorNamingTheReducer) {
  auto b = bind("wrong_rows");
  const std::string what = test::message_of<PluginError>([&] { b->reducer->reduce({4, {}}); });
  EXPECT_NE(what.find("reducer 'toy'"), std::string::npos) << what;
  EXPECT_NE(what.find("31 rows"), std::string::npos) << what;
  EXPECT_NE(what.find("N = 30"), std::string::npos) << what;
}

TEST(PluginBoundary, ForeignExceptionBecomesAPluginError) {
  auto b = bind("throws");
  const std::string what = test::message_of<PluginError>([&] { b->reducer->reduce({4, {}}); });
  EXPECT_NE(what.find("reducer 'toy'"), std::string::npos) << what;
  EXPECT_NE(what.find("toy: something broke"), std::string::npos) << what;
}

TEST(PluginBoundary, CallsOutOfOrderAreRefused) {
  auto b = bind("none", /*setup=*/false);
  EXPECT_THROW(b->reducer->reduce({4, {}}), ConfigError);
  auto c = bind("none");
  EXPECT_THROW(c->reducer->setup(ReductionContext{&c->model, c->solver.get(), Band{1, 2}}),
               ConfigError);
  EXPECT_THROW(c->reducer->reduce({0, {}}), ConfigError);
  EXPECT_THROW(c->reducer->reduce({-3, {}}), ConfigError);
  EXPECT_EQ(c->reducer->reduce({4, {}}).V.cols(), 4);
}

TEST(PluginBoundary, NonFiniteResultIsANumericalError) {
  auto b = bind("none");
  ReducerResult r = b->reducer->reduce({3, {}});
  r.V(1, 1) = std::nan("");
  EXPECT_THROW(check_reducer_result(b->model, {3, {}}, r, "toy"), NumericalError);
  ReducerResult s = b->reducer->reduce({3, {}});
  std::get<ReducedSecondOrderModel>(s.model).K(0, 0) = INFINITY;
  try {
    check_reducer_result(b->model, {3, {}}, s, "toy");
    ADD_FAILURE() << "an Inf in Kr was accepted";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("Kr has a NaN or Inf entry"), std::string::npos)
        << e.what();
  }
  // A wrong shape with finite entries is the plugin's bug, whatever its message says.
  ReducerResult t = b->reducer->reduce({3, {}});
  std::get<ReducedSecondOrderModel>(t.model).D = Matrix::Zero(2, 2);
  EXPECT_THROW(check_reducer_result(b->model, {3, {}}, t, "toy"), PluginError);
}

}  // namespace
}  // namespace ecmor
