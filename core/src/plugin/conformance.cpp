// conformance.cpp: the reducer conformance suite (conformance.hpp). The references are the full
// model's transfer function by sparse solves; nothing here trusts what the reducer says about
// itself.
#include "ecmor/plugin/conformance.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <utility>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/plugin/reducer.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace ecmor::conformance {

std::string to_string(Status status) {
  switch (status) {
    case Status::Passed:
      return "pass";
    case Status::Failed:
      return "FAIL";
    case Status::Skipped:
      return "skip";
  }
  return "?";
}

bool Report::passed() const { return count(Status::Failed) == 0; }

Index Report::count(Status status) const {
  return static_cast<Index>(std::count_if(
      checks.begin(), checks.end(), [&](const CheckResult& c) { return c.status == status; }));
}

void Options::validate() const {
  if (orders.empty()) throw ConfigError("conformance options: orders must not be empty");
  for (std::size_t i = 0; i < orders.size(); ++i) {
    if (orders[i] < 1)
      throw ConfigError(
          fmt::format("conformance options: orders[{}] = {}: must be >= 1", i, orders[i]));
    if (i > 0 && orders[i] <= orders[i - 1])
      throw ConfigError("conformance options: orders must be strictly ascending");
  }
  auto positive = [](const char* name, double v) {
    if (!(v > 0.0) || !std::isfinite(v))
      throw ConfigError(fmt::format("conformance options: {} = {}: must be > 0", name, v));
  };
  positive("tolerance", tolerance);
  positive("growth_tolerance", growth_tolerance);
  positive("determinism_tolerance", determinism_tolerance);
  positive("band_tolerance", band_tolerance);
  if (frequencies < 2)
    throw ConfigError(
        fmt::format("conformance options: frequencies = {}: must be >= 2", frequencies));
  for (const TestModel& m : models) {
    ecmor::validate(m.model, "conformance model '" + m.name + "'");
    m.band.validate();
    m.other_band.validate();
  }
}

// ---- the generated models ---------------------------------------------------------------------

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

SparseMatrix from_triplets(Index n, const Triplets& t) {
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

// Masses m_i and springs k_i vary smoothly so that no two modes coincide; the chain is fixed to the
// ground at its first mass. Rayleigh damping D = a M + b K gives modal damping ratios of 0.5..2 %
// across the band 0.05..1 Hz.
TestModel chain_so() {
  constexpr Index n = 30;
  Triplets m, k;
  for (Index i = 0; i < n; ++i) {
    const double x = static_cast<double>(i);
    m.emplace_back(i, i, 1.0 + 0.5 * std::sin(x));
    const double k_left = 100.0 * (1.0 + 0.3 * std::cos(x));  // spring to the left neighbour
    k.emplace_back(i, i, k_left);
    if (i > 0) {
      k.emplace_back(i - 1, i - 1, k_left);
      k.emplace_back(i, i - 1, -k_left);
      k.emplace_back(i - 1, i, -k_left);
    }
  }
  SecondOrderModel s;
  s.M = from_triplets(n, m);
  s.K = from_triplets(n, k);
  s.D = 0.02 * s.M + 2e-4 * s.K;
  s.D.makeCompressed();
  s.B = Matrix::Zero(n, 2);
  s.B(n - 1, 0) = 1.0;
  s.B(n / 2, 1) = 1.0;
  s.C = Matrix::Zero(2, n);
  s.C(0, n - 1) = 1.0;
  s.C(1, 0) = 1.0;
  return {"chain_so", Model(std::move(s)), Band{0.05, 1.0}, Band{1.2, 4.0}};
}

// A diffusion-like operator with a convection (skew) part: A = -(10 L + 0.5 I) + 0.5 (S - S'),
// L the 1-D Laplacian. A + A' = -2 (10 L + 0.5 I) is negative definite and E diagonal positive
// definite, so every eigenvalue of (A, E) has a negative real part (|lambda| from 0.5 to about 40).
TestModel stable_descriptor() {
  constexpr Index n = 30;
  Triplets e, a;
  for (Index i = 0; i < n; ++i) {
    e.emplace_back(i, i, 1.0 + 0.5 * std::cos(static_cast<double>(i)));
    a.emplace_back(i, i, -(20.0 + 0.5));
    if (i + 1 < n) {
      a.emplace_back(i, i + 1, 10.0 + 0.5);
      a.emplace_back(i + 1, i, 10.0 - 0.5);
    }
  }
  DescriptorModel d;
  d.E = from_triplets(n, e);
  d.A = from_triplets(n, a);
  d.B = Matrix::Zero(n, 1);
  d.B(0, 0) = 1.0;
  d.C = Matrix::Zero(2, n);
  d.C(0, n - 1) = 1.0;
  d.C(1, n / 3) = 1.0;
  return {"stable_descriptor", Model(std::move(d)), Band{0.01, 1.0}, Band{2.0, 20.0}};
}

}  // namespace

std::vector<TestModel> builtin_models() { return {chain_so(), stable_descriptor()}; }

// ---- the suite ----------------------------------------------------------------------------------

namespace {

using Clock = std::chrono::steady_clock;

/// A reducer set up on one model: its own solver, so counters and caches are its own.
struct Instance {
  std::unique_ptr<ShiftedSolver> solver;
  std::shared_ptr<Reducer> reducer;
};

/// The full model's response on a grid, computed once per band.
struct Reference {
  std::vector<Complex> s;
  std::vector<ComplexMatrix> h;
  std::vector<double> norm;  // ||H(s_k)||_2
};

std::vector<Complex> grid_of(const Band& band, Index points) {
  std::vector<Complex> s;
  for (double f : log_grid(band.f_min_hz, band.f_max_hz, points)) s.push_back(s_from_hz(f));
  return s;
}

Reference reference(const Model& model, ShiftedSolver& solver, std::vector<Complex> s) {
  Reference r;
  r.s = std::move(s);
  for (const Complex& sk : r.s) {
    r.h.push_back(transfer_function(model, solver, sk));
    r.norm.push_back(matrix_norm(r.h.back(), ErrorNorm::Spectral));
  }
  return r;
}

/// max_k ||G1(s_k) - G2(s_k)||_2 / ||H(s_k)||_2 over the reference grid.
double relative_gap(const ReducedModel& g1, const ReducedModel& g2, const Reference& ref) {
  double worst = 0.0;
  for (std::size_t k = 0; k < ref.s.size(); ++k) {
    const ComplexMatrix d = transfer_function(g1, ref.s[k]) - transfer_function(g2, ref.s[k]);
    worst = std::max(worst, matrix_norm(d, ErrorNorm::Spectral) / ref.norm[k]);
  }
  return worst;
}

/// max_k ||H(s_k) - G(s_k)||_2 / ||H(s_k)||_2: the relative band error (Eq. 22) on the grid.
double relative_error(const ReducedModel& g, const Reference& ref) {
  double worst = 0.0;
  for (std::size_t k = 0; k < ref.s.size(); ++k) {
    const ComplexMatrix d = ref.h[k] - transfer_function(g, ref.s[k]);
    const double e = matrix_norm(d, ErrorNorm::Spectral) / ref.norm[k];
    worst = std::max(worst, std::isfinite(e) ? e : std::numeric_limits<double>::infinity());
  }
  return worst;
}

std::string sci(double v) { return fmt::format("{:.2e}", v); }

class Suite {
 public:
  Suite(const Registry& registry, std::string name, const ParameterMap& parameters,
        const Options& options, const std::function<void(const CheckResult&)>& progress)
      : m_registry(registry),
        m_name(std::move(name)),
        m_parameters(parameters),
        m_options(options),
        m_progress(progress) {
    for (const auto& e : registry.entries())
      if (e.info.name == m_name) m_info = e.info;
  }

  Report run() {
    m_report.reducer = m_name;
    check_unknown_key();
    std::vector<TestModel> models = m_options.models.empty() ? builtin_models() : m_options.models;
    for (TestModel& m : models) run_model(m);
    return std::move(m_report);
  }

 private:
  // Runs `body`, which returns the status and detail; an escaping exception is a failure with the
  // exception's message (the suite never throws for a misbehaving reducer).
  template <class F>
  void check(const std::string& name, const std::string& model, F&& body) {
    CheckResult c;
    c.check = name;
    c.model = model;
    const auto t0 = Clock::now();
    try {
      std::tie(c.status, c.detail) = body();
    } catch (const std::exception& e) {
      c.status = Status::Failed;
      c.detail = e.what();
    }
    c.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    m_report.checks.push_back(c);
    if (m_progress) m_progress(c);
  }

  using Outcome = std::pair<Status, std::string>;
  static Outcome pass(std::string d) { return {Status::Passed, std::move(d)}; }
  static Outcome fail(std::string d) { return {Status::Failed, std::move(d)}; }
  static Outcome skip(std::string d) { return {Status::Skipped, std::move(d)}; }

  ParameterMap copy_parameters() const { return m_parameters; }

  Instance make(const TestModel& m, const Band& band) const {
    Instance in;
    in.solver = make_shifted_solver(m.model);
    in.reducer = m_registry.create(m_name, copy_parameters());
    in.reducer->setup(ReductionContext{&m.model, in.solver.get(), band});
    return in;
  }

  void check_unknown_key() {
    check("bad_input", "-", [&]() -> Outcome {
      const std::string key = "conformance_no_such_key";
      ParameterMap p = copy_parameters();
      p.set(key, 1);
      try {
        m_registry.create(m_name, p);
      } catch (const ConfigError& e) {
        if (std::string(e.what()).find(key) == std::string::npos)
          return fail(
              fmt::format("ConfigError does not name the unknown key '{}': {}", key, e.what()));
        return pass("unknown parameter key refused by name");
      }
      return fail(fmt::format("unknown parameter key '{}' was accepted", key));
    });
  }

  void run_model(const TestModel& m) {
    const bool second_order = kind_of(m.model) == ModelKind::SecondOrder;
    const bool declared = second_order ? m_info.second_order : m_info.descriptor;
    const std::string kind = second_order ? "second-order" : "descriptor";
    std::optional<Instance> grown;
    check("accepts", m.name, [&]() -> Outcome {
      try {
        grown = make(m, m.band);
      } catch (const PluginError& e) {
        return fail(fmt::format("setup() failed at the plugin boundary: {}", e.what()));
      } catch (const Error& e) {
        if (declared)
          return fail(fmt::format("declares {} models but setup() refused: {}", kind, e.what()));
        return pass(fmt::format("{} model refused by name: {}", kind, e.what()));
      }
      if (!declared) {
        grown.reset();
        return fail(
            fmt::format("ReducerInfo declares no {} models, but setup() accepted one "
                        "(refuse it with an InputError, or declare it)",
                        kind));
      }
      return pass(fmt::format("{} model, N = {}", kind, size_of(m.model)));
    });
    if (!grown) return;

    auto solver = make_shifted_solver(m.model);
    const Reference in_band = reference(m.model, *solver, grid_of(m.band, m_options.frequencies));
    const Index inputs = inputs_of(m.model);

    // dimensions: grow through the orders on one instance.
    std::vector<std::pair<Index, ReducerResult>> grown_results;
    check("dimensions", m.name, [&]() -> Outcome {
      std::string delivered;
      for (Index order : m_options.orders) {
        ReducerResult r = grown->reducer->reduce(ReductionRequest{order, {}});
        const Index n = r.V.cols();
        if (n > order + inputs)
          return fail(
              fmt::format("order {} requested, {} columns delivered (rule: at most "
                          "order + inputs = {})",
                          order, n, order + inputs));
        delivered += fmt::format("{}{}->{}", delivered.empty() ? "" : ", ", order, n);
        grown_results.emplace_back(order, std::move(r));
      }
      return pass("requested->delivered " + delivered);
    });
    if (grown_results.size() != m_options.orders.size()) return;

    check("projection", m.name, [&]() -> Outcome {
      double worst = 0.0;
      for (const auto& [order, r] : grown_results) {
        ReducedModel projected;
        if (r.V.rows() == size_of(m.model)) {
          projected = project(m.model, r.V, r.W);
        } else {
          const FirstOrderView view(m.model, *solver);
          projected = view.project_first_order(r.V, r.W);
        }
        worst = std::max(worst, relative_gap(r.model, projected, in_band));
      }
      const std::string d = fmt::format("reduced model vs W'(.)V of its bases: {}", sci(worst));
      return worst <= m_options.tolerance ? pass(d) : fail(d + " > " + sci(m_options.tolerance));
    });

    const Index largest = m_options.orders.back();
    const Index middle = m_options.orders[m_options.orders.size() / 2];
    std::optional<ReducerResult> fresh_largest, fresh_middle;
    check("growth", m.name, [&]() -> Outcome {
      const ReducerResult shrunk = grown->reducer->reduce(ReductionRequest{middle, {}});
      Instance b = make(m, m.band);
      fresh_largest = b.reducer->reduce(ReductionRequest{largest, {}});
      Instance c = make(m, m.band);
      fresh_middle = c.reducer->reduce(ReductionRequest{middle, {}});
      const double up =
          relative_gap(grown_results.back().second.model, fresh_largest->model, in_band);
      const double down = relative_gap(shrunk.model, fresh_middle->model, in_band);
      const std::string d = fmt::format("grown to {} vs fresh: {}; shrunk back to {} vs fresh: {}",
                                        largest, sci(up), middle, sci(down));
      return std::max(up, down) <= m_options.growth_tolerance
                 ? pass(d)
                 : fail(d + " > " + sci(m_options.growth_tolerance));
    });

    check("determinism", m.name, [&]() -> Outcome {
      Instance c = make(m, m.band);
      const ReducerResult first = c.reducer->reduce(ReductionRequest{middle, {}});
      Instance d = make(m, m.band);
      const ReducerResult second = d.reducer->reduce(ReductionRequest{middle, {}});
      const double gap = relative_gap(first.model, second.model, in_band);
      const std::string text = fmt::format("two fresh builds at order {}: {}", middle, sci(gap));
      return gap <= m_options.determinism_tolerance
                 ? pass(text)
                 : fail(text + " > " + sci(m_options.determinism_tolerance));
    });

    check("full_order", m.name, [&]() -> Outcome { return full_order(m, *solver); });

    check("band", m.name, [&]() -> Outcome { return band(m, in_band); });

    check("points", m.name, [&]() -> Outcome { return points(m, *solver); });
  }

  Outcome full_order(const TestModel& m, ShiftedSolver& solver) {
    Instance in = make(m, m.band);
    const Index n = size_of(m.model);
    const Index cap = in.reducer->max_order();
    ReducerResult r;
    try {
      r = in.reducer->reduce(ReductionRequest{std::min(n, cap), {}});
      // A first-order realisation of a second-order model needs 2N columns to be square.
      if (r.V.cols() < r.V.rows() && r.V.rows() > n && cap >= r.V.rows())
        r = in.reducer->reduce(ReductionRequest{r.V.rows(), {}});
    } catch (const PluginError&) {
      throw;
    } catch (const Error& e) {
      // Refusing an order it cannot build (e.g. IRKA's shifts coinciding at r = N) with a named
      // error is within the contract; a wrong full-order model is not.
      return skip(fmt::format("refused the full order by name: {}", e.what()));
    }
    if (r.V.cols() < r.V.rows()) {
      return skip(fmt::format(
          "delivers {} of {} columns (max_order {}): no square basis to test", r.V.cols(),
          r.V.rows(), cap == kUnlimitedOrder ? std::string("unlimited") : std::to_string(cap)));
    }
    // Inside the band, below and above it: a full-rank projection is exact everywhere (up to
    // rounding amplified by the conditioning of the basis; far outside the band ||H|| may be tiny).
    std::vector<Complex> s = grid_of(m.band, m_options.frequencies);
    s.push_back(s_from_hz(0.5 * m.band.f_min_hz));
    s.push_back(s_from_hz(2.0 * m.band.f_max_hz));
    const Reference ref = reference(m.model, solver, std::move(s));
    const double e = relative_error(r.model, ref);
    const std::string d =
        fmt::format("order {}: relative error {} in, below and above the band", r.V.cols(), sci(e));
    return e <= m_options.tolerance ? pass(d) : fail(d + " > " + sci(m_options.tolerance));
  }

  // The smallest order (on the ladder 2, 4, ... up to N) whose relative error over the band is at
  // most band_tolerance: set up for that band, the reducer must need no more columns than set up
  // for the other band. A method that ignores the band needs the same order either way.
  Outcome band(const TestModel& m, const Reference& in_band) {
    const Index n = size_of(m.model);
    struct Reached {
      Index order = 0;  // 0: not reached
      double error = std::numeric_limits<double>::infinity();
      Index tried = 0;
    };
    auto ladder = [&](const Band& setup_band) {
      Instance in = make(m, setup_band);
      // Up to the first-order state dimension: 2N for reducers of a second-order model's
      // realisation (a structure-preserving reducer stops delivering new columns at N).
      const Index states = kind_of(m.model) == ModelKind::SecondOrder ? 2 * n : n;
      const Index cap = std::min(states, in.reducer->max_order());
      Reached out;
      Index previous = -1;
      for (Index order = 2; order <= cap; order += 2) {
        const ReducerResult r = in.reducer->reduce(ReductionRequest{order, {}});
        if (r.V.cols() == previous) continue;
        previous = r.V.cols();
        out.tried = r.V.cols();
        out.error = relative_error(r.model, in_band);
        if (out.error <= m_options.band_tolerance) {
          out.order = r.V.cols();
          break;
        }
      }
      return out;
    };
    const Reached own = ladder(m.band);
    const Reached other = ladder(m.other_band);
    auto text = [](const Reached& r) {
      return r.order > 0 ? fmt::format("order {} ({})", r.order, sci(r.error))
                         : fmt::format("not reached up to order {} ({})", r.tried, sci(r.error));
    };
    const std::string d = fmt::format(
        "error <= {} over [{:g}, {:g}] Hz: set up for this band {}, set up for [{:g}, {:g}] Hz {}",
        sci(m_options.band_tolerance), m.band.f_min_hz, m.band.f_max_hz, text(own),
        m.other_band.f_min_hz, m.other_band.f_max_hz, text(other));
    if (own.order == 0 && other.order == 0) return skip(d);
    if (own.order == 0) return fail(d);
    return other.order == 0 || own.order <= other.order ? pass(d) : fail(d);
  }

  Outcome points(const TestModel& m, ShiftedSolver& solver) {
    Instance in = make(m, m.band);
    const double f0 = std::sqrt(m.band.f_min_hz * m.band.f_max_hz);
    const ExpansionPoint p = point_at_hz(f0, 1);
    if (!m_info.uses_expansion_points) {
      try {
        in.reducer->reduce(ReductionRequest{m_options.orders.front(), {p}});
      } catch (const ConfigError& e) {
        return pass(fmt::format("a request with points refused: {}", e.what()));
      }
      return fail(
          "ReducerInfo::uses_expansion_points is false, but a request with points was "
          "accepted (throw a ConfigError)");
    }
    const ReducerResult r = in.reducer->reduce(ReductionRequest{0, {p}});
    const Reference ref = reference(m.model, solver, {p.s, std::conj(p.s)});
    const double e = relative_error(r.model, ref);
    const std::string d = fmt::format(
        "H_r(s0) vs H(s0) at s0 = i 2pi {:g} Hz and its conjugate "
        "(order {}): {}",
        f0, r.V.cols(), sci(e));
    return e <= m_options.tolerance ? pass(d) : fail(d + " > " + sci(m_options.tolerance));
  }

  const Registry& m_registry;
  std::string m_name;
  const ParameterMap& m_parameters;
  const Options& m_options;
  const std::function<void(const CheckResult&)>& m_progress;
  ReducerInfo m_info;
  Report m_report;
};

}  // namespace

Report run(const Registry& registry, const std::string& reducer, const ParameterMap& parameters,
           const Options& options, const std::function<void(const CheckResult&)>& progress) {
  options.validate();
  // An unknown name or invalid parameters are the caller's configuration errors, not the
  // reducer's: thrown here (with the registry's suggestions) before any check runs.
  const ParameterMap copy = parameters;
  registry.create(reducer, copy);
  return Suite(registry, reducer, parameters, options, progress).run();
}

}  // namespace ecmor::conformance
