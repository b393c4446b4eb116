// The failure atlas (docs/failure-atlas.md): models built to provoke the known failure modes of
// the reduction methods, each run through the driver with every bundled reducer (grow_order) and a
// portfolio of all four. Every run must end in one of the named outcomes below, never in a crash,
// a non-ecmor exception or a "converged" unstable model; the per-scenario expectations are the
// behaviour we document. With ECMOR_UPDATE_ATLAS=1 the test rewrites the table in
// docs/failure-atlas.md from what it observed.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/driver.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

// ---- generated models -------------------------------------------------------------------------

struct Chain {
  Index n = 20;
  double ground = 100.0;             ///< spring from mass 1 to the ground (0: free-floating)
  double alpha = 0.02, beta = 2e-4;  ///< Rayleigh damping D = alpha M + beta K
  double negative_spring = 0.0;      ///< if != 0: the spring between masses n/2 and n/2+1
  Index copies = 1;                  ///< decoupled identical copies (repeated eigenfrequencies)
  Index inputs = 1;                  ///< 2: a second, dependent input column (2 x the first)
  double detune = 0.0;               ///< masses of copy k scaled by (1 + k detune)
  bool observe_all = false;          ///< output: the sum of the last masses of every copy
};

SparseMatrix sparse(Index n, const Triplets& t) {
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

// Masses 1 + 0.3 sin(i), springs 100 (1 + 0.2 cos(i)) between neighbours; force on the last mass
// of the first copy, displacement of the same mass out (collocated).
void write_chain(const fs::path& dir, const Chain& c) {
  const Index n = c.n * c.copies;
  Triplets m, k;
  for (Index copy = 0; copy < c.copies; ++copy) {
    const Index o = copy * c.n;
    for (Index i = 0; i < c.n; ++i) {
      const double x = static_cast<double>(i);
      m.emplace_back(o + i, o + i,
                     (1.0 + 0.3 * std::sin(x)) * (1.0 + static_cast<double>(copy) * c.detune));
      if (i == 0) {
        if (c.ground != 0.0) k.emplace_back(o, o, c.ground);
        continue;
      }
      double s = 100.0 * (1.0 + 0.2 * std::cos(x));
      if (c.negative_spring != 0.0 && i == c.n / 2) s = c.negative_spring;
      k.emplace_back(o + i, o + i, s);
      k.emplace_back(o + i - 1, o + i - 1, s);
      k.emplace_back(o + i, o + i - 1, -s);
      k.emplace_back(o + i - 1, o + i, -s);
    }
  }
  const SparseMatrix M = sparse(n, m), K = sparse(n, k);
  SparseMatrix D = c.alpha * M + c.beta * K;
  D.prune(0.0);
  Matrix B = Matrix::Zero(n, c.inputs);
  for (Index copy = 0; copy < c.copies; ++copy) B(copy * c.n + c.n - 1, 0) = 1.0;
  if (c.inputs > 1) B.col(1) = 2.0 * B.col(0);
  Matrix C = Matrix::Zero(1, n);
  for (Index copy = 0; copy < (c.observe_all ? c.copies : 1); ++copy)
    C(0, copy * c.n + c.n - 1) = 1.0;
  fs::create_directories(dir);
  write_matrix_market(dir / "M.mtx", M);
  write_matrix_market(dir / "D.mtx", D);
  write_matrix_market(dir / "K.mtx", K);
  write_matrix_market(dir / "B.mtx", B);
  write_matrix_market(dir / "C.mtx", C);
}

// A first-order model whose transfer function has a pair of zeros on the imaginary axis:
// H(s) = sum_i c_i / (s + p_i), p = 1, 2, 3, with c chosen so that the numerator is
// s^2 + w0^2 (w0 = 2 rad/s, f0 = 1/pi Hz): c1 + c2 + c3 = 1, 5 c1 + 4 c2 + 3 c3 = 0,
// 6 c1 + 3 c2 + 2 c3 = 4, i.e. c = (2.5, -8, 6.5). The relative error is undefined at f0.
void write_zero_on_axis(const fs::path& dir) {
  const Index n = 3;
  Triplets e{{0, 0, 1.0}, {1, 1, 1.0}, {2, 2, 1.0}}, a{{0, 0, -1.0}, {1, 1, -2.0}, {2, 2, -3.0}};
  Matrix B = Matrix::Ones(n, 1);
  Matrix C(1, n);
  C << 2.5, -8.0, 6.5;
  fs::create_directories(dir);
  write_matrix_market(dir / "E.mtx", sparse(n, e));
  write_matrix_market(dir / "A.mtx", sparse(n, a));
  write_matrix_market(dir / "B.mtx", B);
  write_matrix_market(dir / "C.mtx", C);
}

// A semi-explicit index-1 DAE: 20 differential states x (E = diag(1 + 0.5 cos i)) of a stable
// diffusion-convection chain, 10 algebraic states z = x_{2j} / 2 + u fed back into x_{2j}
// (A22 = -I, so the index is 1); input into x_0 and z_0, outputs x_19 and z_9. The algebraic
// feedthrough gives H a constant part at s -> infinity, and the symmetric part of the state matrix
// after eliminating z stays negative definite: stable.
void write_index1_dae(const fs::path& dir) {
  const Index n1 = 20, n2 = 10, n = n1 + n2;
  Triplets e, a;
  for (Index i = 0; i < n1; ++i) {
    e.emplace_back(i, i, 1.0 + 0.5 * std::cos(static_cast<double>(i)));
    a.emplace_back(i, i, -20.5);
    if (i + 1 < n1) {
      a.emplace_back(i, i + 1, 10.5);
      a.emplace_back(i + 1, i, 9.5);
    }
  }
  for (Index j = 0; j < n2; ++j) {
    a.emplace_back(2 * j, n1 + j, 1.0);  // z_j drives x_2j
    a.emplace_back(n1 + j, 2 * j, 0.5);  // 0 = x_2j / 2 - z_j (+ u for j = 0)
    a.emplace_back(n1 + j, n1 + j, -1.0);
  }
  Matrix B = Matrix::Zero(n, 1);
  B(0, 0) = 1.0;
  B(n1, 0) = 1.0;
  Matrix C = Matrix::Zero(2, n);
  C(0, n1 - 1) = 1.0;
  C(1, n - 1) = 1.0;
  fs::create_directories(dir);
  write_matrix_market(dir / "E.mtx", sparse(n, e));
  write_matrix_market(dir / "A.mtx", sparse(n, a));
  write_matrix_market(dir / "B.mtx", B);
  write_matrix_market(dir / "C.mtx", C);
}

// The free-floating chain held by a constraint q_0 = 0 through a Lagrange multiplier l: the
// index-3 DAE in x = [q; v; l],
//     E = diag(I, M, 0),  A = [[0, I, 0], [-K, -D, -g], [g', 0, 0]],  g = e_0,
// force on the last mass, its displacement out. Its transfer function is that of the chain with
// mass 0 clamped (strictly proper), but E has a 3-chain of infinite eigenvalues: perturbed, they
// become finite eigenvalues of modulus ~ eps^(-1/3) of either sign.
void write_constrained_free_body(const fs::path& dir) {
  const fs::path tmp = dir / "second_order";
  Chain c;
  c.ground = 0.0;
  write_chain(tmp, c);
  const Index n = c.n, N = 2 * n + 1;
  const SparseMatrix M = read_matrix_market_sparse(tmp / "M.mtx");
  const SparseMatrix D = read_matrix_market_sparse(tmp / "D.mtx");
  const SparseMatrix K = read_matrix_market_sparse(tmp / "K.mtx");
  fs::remove_all(tmp);
  Triplets e, a;
  for (Index i = 0; i < n; ++i) {
    e.emplace_back(i, i, 1.0);
    a.emplace_back(i, n + i, 1.0);
  }
  auto add = [](Triplets& t, const SparseMatrix& S, Index r0, Index c0, double f) {
    for (Index k = 0; k < S.outerSize(); ++k)
      for (SparseMatrix::InnerIterator it(S, k); it; ++it)
        t.emplace_back(r0 + it.row(), c0 + it.col(), f * it.value());
  };
  add(e, M, n, n, 1.0);
  add(a, K, n, 0, -1.0);
  add(a, D, n, n, -1.0);
  a.emplace_back(n, 2 * n, -1.0);  // -g l on the first mass
  a.emplace_back(2 * n, 0, 1.0);   // 0 = g' q
  Matrix B = Matrix::Zero(N, 1);
  B(2 * n - 1, 0) = 1.0;
  Matrix C = Matrix::Zero(1, N);
  C(0, n - 1) = 1.0;
  fs::create_directories(dir);
  write_matrix_market(dir / "E.mtx", sparse(N, e));
  write_matrix_market(dir / "A.mtx", sparse(N, a));
  write_matrix_market(dir / "B.mtx", B);
  write_matrix_market(dir / "C.mtx", C);
}

// ---- scenarios and outcomes -------------------------------------------------------------------

/// One run of a scenario: a reducer with extra YAML parameters, under its own label.
struct AtlasRun {
  std::string label, reducer, params;  ///< params: "key: value, ..." inside reducer: {...}
};

struct Scenario {
  std::string name;
  std::string what;
  std::function<fs::path(const fs::path&)> model;  ///< writes (or names) the model directory
  Band band;
  double tolerance = 1e-2;
  Index max_order = 40;
  bool portfolio = true;  ///< false where the portfolio would only repeat its members' runs
  /// The full model's stability as the driver must report it (stability.hpp); alternatives
  /// separated by '|'.
  std::string full = "asymptotically stable";
  /// Empty: modal, krylov, irka and balanced with their defaults, and the portfolio (unless
  /// portfolio = false); else exactly these runs.
  std::vector<AtlasRun> runs = {};
  /// Minutes rather than seconds: run only with ECMOR_ATLAS_SLOW=1 (CTest failure_atlas_slow,
  /// label slow).
  bool slow = false;
};

constexpr double kTwoPi = 6.283185307179586;

fs::path shared(const std::string& name) { return fs::path("models") / name; }

std::vector<Scenario> scenarios() {
  auto chain = [](Chain c) {
    return [c](const fs::path& dir) {
      write_chain(dir, c);
      return dir;
    };
  };
  Chain undamped;
  undamped.alpha = undamped.beta = 0.0;
  Chain floating;
  floating.ground = 0.0;
  Chain negative;
  negative.negative_spring = -300.0;
  Chain repeated;
  repeated.copies = 2;
  Chain dependent;
  dependent.inputs = 2;
  Chain clustered;
  clustered.copies = 2;
  clustered.detune = 1e-3;
  clustered.observe_all = true;
  return {
      {"undamped", "second order, D = 0: poles on the imaginary axis", chain(undamped),
       Band{0.05, 1.0}, 1e-2, 40, true, "marginally stable"},
      {"free_floating", "K singular (rigid-body mode), damped", chain(floating), Band{0.05, 1.0},
       1e-2, 40, true, "marginally stable"},
      {"constrained_free_body",
       "the free-floating chain held by q_0 = 0 through a Lagrange multiplier: index-3 DAE",
       [](const fs::path& dir) {
         write_constrained_free_body(dir);
         return dir;
       },
       Band{0.05, 1.0}},
      {"negative_stiffness", "K indefinite: an unstable pole", chain(negative), Band{0.05, 1.0},
       1e-2, 40, true, "unstable"},
      {"repeated_modes", "two identical decoupled chains: every eigenfrequency twice",
       chain(repeated), Band{0.05, 1.0}},
      {"clustered_modes",
       "two chains detuned by 0.1 % (mass), both observed: eigenfrequencies in pairs 0.05 % apart",
       chain(clustered), Band{0.05, 1.0}},
      {"no_mode_in_band", "band an octave below the first eigenfrequency (0.09 Hz)", chain(Chain{}),
       Band{0.01, 0.04}},
      {"zero_in_band", "H(i 2pi f0) = 0 at f0 = 0.318 Hz inside the band (3 states)",
       [](const fs::path& dir) {
         write_zero_on_axis(dir);
         return dir;
       },
       Band{0.1, 1.0}},
      {"dependent_inputs", "B = [b, 2b]: dependent input columns", chain(dependent),
       Band{0.05, 1.0}},
      {"badly_scaled", "lf10: M eigenvalues 3e-11 .. 7e-5",
       [](const fs::path&) { return shared("lf10"); }, Band{15.9, 1.59e6}, 1e-4},
      {"dae_singular_e", "index-1 DAE: E singular (10 algebraic of 30 states), feedthrough",
       [](const fs::path& dir) {
         write_index1_dae(dir);
         return dir;
       },
       Band{0.01, 1.0}},
      // Eigen's QZ converges on mna1's pencil in a fresh process (as in test_stability) but not
      // always after other runs in the same process (root cause not found yet): then the verdict
      // is "unknown" with "dense eigenvalue computation failed", which is honest, never wrong.
      {"circuit_dae",
       "mna1 (SLICOT circuit, 578 states): E singular, finite poles from 5.7e4 to 4.5e20",
       [](const fs::path&) { return shared("mna1"); }, Band{1e3 / kTwoPi, 1e9 / kTwoPi}, 1e-2, 40,
       false, "asymptotically stable|unknown"},
      {"large_circuit_dae",
       "mna5 (SLICOT circuit, 10913 states): E singular, too large for dense checks",
       [](const fs::path&) { return shared("mna5"); },
       Band{1e3 / kTwoPi, 1e9 / kTwoPi},
       1e-2,
       40,
       false,
       "unknown",
       {},
       true},
      {"unstable_pencil", "peec: (A, E) has eigenvalues with Re up to +1.7e12",
       [](const fs::path&) { return shared("peec"); }, Band{1e7, 1e9}, 1e-2, 40, true, "unstable"},
      {"point_at_pole",
       "Krylov expansion point s0 = 0 on the free-floating chain: K singular",
       chain(floating),
       Band{0.05, 1.0},
       1e-2,
       40,
       false,
       "marginally stable",
       {{"krylov_s0_0", "krylov", "real_points: [0]"}}},
      {"unstable_projection",
       "iss (first-order form) reduced without its second-order structure, 4 points",
       [](const fs::path&) { return shared("iss"); },
       Band{0.1, 1.0},
       1e-2,
       80,
       false,
       "asymptotically stable",
       {{"krylov_two_sided", "krylov",
         "structure: first_order, projection: two_sided, point_count: 4"},
        {"krylov_one_sided", "krylov", "structure: first_order, point_count: 4"},
        {"krylov", "krylov", ""}}},
      {"irka_cycling",
       "build (SLICOT), band 0.1 .. 100 rad/s: IRKA falls into cycles",
       [](const fs::path&) { return shared("build"); },
       Band{0.1 / kTwoPi, 100.0 / kTwoPi},
       1e-2,
       30,
       false,
       "asymptotically stable",
       {{"irka_no_restarts", "irka", "restarts: 0, max_iterations: 200"},
        {"irka", "irka", "max_iterations: 200"}}},
      {"irka_budget",
       "iss, IRKA allowed 3 iterations per order",
       [](const fs::path&) { return shared("iss"); },
       Band{0.1, 1.0},
       1e-2,
       20,
       false,
       "asymptotically stable",
       {{"irka_3_iterations", "irka", "max_iterations: 3, restarts: 0"}}},
      {"adi_budget",
       "the damped chain, low-rank Gramians allowed 2 ADI iterations",
       chain(Chain{}),
       Band{0.05, 1.0},
       1e-2,
       40,
       false,
       "asymptotically stable",
       {{"balanced_adi_strict", "balanced",
         "gramians: lowrank, adi_max_iterations: 2, adi_require_convergence: true"},
        {"balanced_adi_2", "balanced", "gramians: lowrank, adi_max_iterations: 2"}}},
  };
}

struct Outcome {
  std::string scenario, reducer;
  std::string kind;  ///< refused | failed | converged | missed | BUG
  std::string detail;
  Index order = 0;
  bool stable = false;
  double band_error = 0.0;
  std::string termination;
  double seconds = 0.0;
  std::string full;              ///< the full model's stability as reported by the driver
  bool rigid_like_full = false;  ///< the reported model keeps the full model's rigid-body modes
  std::string warnings;          ///< the driver's warnings, joined
  Index unstable_iterates = 0;   ///< history records flagged unstable
  std::string notes;             ///< every distinct reducer note of the history, joined
};

// Counts the unstable iterates and keeps the reducers' notes (breakdowns, budgets, cycling).
class Recorder final : public RunObserver {
 public:
  Index unstable = 0;
  std::string notes;
  bool on_iteration(const IterationRecord& r) override {
    if (!r.stable) ++unstable;
    if (!r.note.empty() && notes.find(r.note) == std::string::npos) notes += r.note + "\n";
    return true;
  }
};

Registry& registry() {
  static Registry r;
  static bool loaded = false;
  if (!loaded) {
    for (const char* lib :
         {"libecmor_modal.so", "libecmor_krylov.so", "libecmor_irka.so", "libecmor_balanced.so"})
      r.load_plugin(fs::path(ECMOR_TEST_PLUGIN_DIR) / lib);
    loaded = true;
  }
  return r;
}

std::string first_line(const std::string& s, std::size_t max = 160) {
  std::string line = s.substr(0, s.find('\n'));
  if (line.size() > max) line = line.substr(0, max - 3) + "...";
  return line;
}

Outcome run(const Scenario& s, const fs::path& model_dir, const AtlasRun& spec,
            const fs::path& out) {
  const std::string& reducer = spec.reducer;
  Outcome o;
  o.scenario = s.name;
  o.reducer = spec.label;
  std::ostringstream yaml;
  yaml << "model: {dir: " << model_dir.string() << "}\n"
       << "band: {f_min_hz: " << s.band.f_min_hz << ", f_max_hz: " << s.band.f_max_hz << "}\n"
       << "target: {tolerance: " << s.tolerance << "}\n";
  if (reducer == "portfolio") {
    yaml << "strategy:\n  name: portfolio\n  time_limit_s: 120\n  members:\n";
    for (const char* r : {"modal", "krylov", "irka", "balanced"})
      yaml << "    - reducer: {name: " << r << "}\n      strategy: {name: grow_order, "
           << "max_order: " << s.max_order << "}\n";
  } else {
    yaml << "reducer: {name: " << reducer << (spec.params.empty() ? "" : ", ") << spec.params
         << "}\n"
         << "strategy: {name: grow_order, max_order: " << s.max_order << ", time_limit_s: 60}\n";
  }
  yaml << "output: {dir: " << out.string() << "}\n";
  const auto t0 = std::chrono::steady_clock::now();
  try {
    Recorder recorder;
    const RunSummary r =
        run_reduction(parse_run_config(yaml.str(), s.name + ".yaml"), registry(), &recorder);
    o.unstable_iterates = recorder.unstable;
    o.notes = recorder.notes;
    o.full = to_string(r.full_stability.verdict);
    for (const std::string& w : r.warnings) o.warnings += w + "\n";
    o.termination = to_string(r.termination);
    o.order = r.order;
    o.stable = r.stable;
    o.rigid_like_full = r.has_model && r.stability.verdict == ReducedVerdict::RigidLikeFull;
    o.band_error = r.verified_band_error > 0.0 ? r.verified_band_error : r.band_error;
    o.detail = first_line(r.message);
    if (!r.has_model)
      o.kind = "failed";
    else if (r.termination == Termination::Converged)
      o.kind = "converged";
    else
      o.kind = "missed";
    if (reducer == "portfolio" && r.has_model) o.detail = "kept " + r.reducer + ": " + o.detail;
  } catch (const PluginError& e) {
    o.kind = "BUG";
    o.detail = std::string("PluginError: ") + first_line(e.what());
  } catch (const InputError& e) {
    o.kind = "refused";
    o.detail = first_line(e.what());
  } catch (const ConfigError& e) {
    o.kind = "refused";
    o.detail = first_line(e.what());
  } catch (const NumericalError& e) {
    o.kind = "failed";
    o.detail = first_line(e.what());
  } catch (const Error& e) {
    o.kind = "failed";
    o.detail = first_line(e.what());
  } catch (const std::exception& e) {
    o.kind = "BUG";
    o.detail = std::string("non-ecmor exception: ") + first_line(e.what());
  }
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return o;
}

const std::vector<std::string> kReducers{"modal", "krylov", "irka", "balanced", "portfolio"};

std::vector<AtlasRun> runs_of(const Scenario& s) {
  if (!s.runs.empty()) return s.runs;
  std::vector<AtlasRun> runs;
  for (const std::string& r : kReducers)
    if (r != "portfolio" || s.portfolio) runs.push_back({r, r, ""});
  return runs;
}

// ECMOR_ATLAS_ONLY=name1,name2 runs only those scenarios (while working on one); the table in
// the docs is then not rewritten.
bool slow_enabled() {
  const char* slow = std::getenv("ECMOR_ATLAS_SLOW");
  return slow != nullptr && std::string(slow) == "1";
}

bool selected(const std::string& scenario) {
  for (const Scenario& s : scenarios())
    if (s.name == scenario && s.slow && !slow_enabled()) return false;
  const char* only = std::getenv("ECMOR_ATLAS_ONLY");
  if (only == nullptr || *only == '\0') return true;
  return ("," + std::string(only) + ",").find("," + scenario + ",") != std::string::npos;
}

// All runs, once per test binary (the scenarios take about a minute in all).
const std::vector<Outcome>& outcomes() {
  static std::vector<Outcome> all;
  static bool done = false;
  if (done) return all;
  done = true;
  const fs::path root = fs::temp_directory_path() / ("ecmor_atlas_" + std::to_string(::getpid()));
  fs::remove_all(root);
  for (const Scenario& s : scenarios()) {
    if (!selected(s.name)) continue;
    const fs::path model = s.model(root / "models" / s.name);
    for (const AtlasRun& r : runs_of(s))
      all.push_back(run(s, model, r, root / "runs" / (s.name + "_" + r.label)));
  }
  fs::remove_all(root);
  return all;
}

const Outcome& outcome(const std::string& scenario, const std::string& reducer) {
  for (const Outcome& o : outcomes())
    if (o.scenario == scenario && o.reducer == reducer) return o;
  throw std::runtime_error("no outcome " + scenario + "/" + reducer);
}

std::string describe(const Outcome& o) {
  std::ostringstream s;
  s << o.scenario << "/" << o.reducer << ": " << o.kind << " (" << o.termination << ", order "
    << o.order << ", " << (o.stable ? "stable" : "UNSTABLE") << ", error " << o.band_error << ", "
    << o.seconds << " s): " << o.detail;
  return s.str();
}

// ---- the guarantees, for every run ------------------------------------------------------------

TEST(FailureAtlas, EveryRunEndsInANamedOutcome) {
  for (const Outcome& o : outcomes()) {
    SCOPED_TRACE(describe(o));
    EXPECT_NE(o.kind, "BUG");
    EXPECT_FALSE(o.detail.empty());
    std::printf("%s\n", describe(o).c_str());
  }
}

TEST(FailureAtlas, NoUnstableModelIsReportedAsConverged) {
  for (const Outcome& o : outcomes()) {
    if (o.kind != "converged") continue;
    SCOPED_TRACE(describe(o));
    EXPECT_TRUE(o.stable);
  }
}

// ---- what each scenario must do ----------------------------------------------------------------

// The documented behaviour: `kind` is the outcome (refused, failed, converged, missed, or
// "not converged" for either of the last two or a failure), `contains` a phrase the message must
// name. Runs not listed are recorded in the table only (e.g. krylov on the unstable chain).
struct Expect {
  std::string scenario, reducer, kind, contains;
};

const std::vector<Expect> kExpected{
    // No stable model approximates poles on the imaginary axis: never "converged".
    {"undamped", "modal", "missed", "not asymptotically stable"},
    {"undamped", "krylov", "not converged", ""},
    {"undamped", "irka", "refused", "not asymptotically stable"},
    {"undamped", "balanced", "refused", "D = 0"},
    {"undamped", "portfolio", "not converged", ""},
    // A rigid-body mode: Gramians do not exist; the projection methods handle it.
    {"free_floating", "balanced", "refused", "K is singular"},
    {"free_floating", "modal", "converged", ""},
    {"free_floating", "krylov", "converged", ""},
    {"free_floating", "irka", "converged", ""},
    // The smallest member wins: krylov's model compressed below modal's.
    {"free_floating", "portfolio", "converged", "kept krylov"},
    // An unstable full model: refused by the methods that need stability.
    {"negative_stiffness", "modal", "failed", "K has a negative eigenvalue"},
    {"negative_stiffness", "irka", "refused", "not asymptotically stable"},
    {"negative_stiffness", "balanced", "refused", "Re >= 0"},
    {"repeated_modes", "modal", "converged", ""},
    {"repeated_modes", "krylov", "converged", ""},
    {"repeated_modes", "balanced", "converged", ""},
    {"repeated_modes", "portfolio", "converged", ""},
    {"no_mode_in_band", "modal", "converged", ""},
    {"no_mode_in_band", "krylov", "converged", ""},
    {"no_mode_in_band", "irka", "converged", ""},
    {"no_mode_in_band", "balanced", "converged", ""},
    {"zero_in_band", "modal", "converged", ""},
    {"zero_in_band", "krylov", "converged", ""},
    {"zero_in_band", "irka", "converged", ""},
    {"zero_in_band", "balanced", "converged", ""},
    {"dependent_inputs", "modal", "converged", ""},
    {"dependent_inputs", "krylov", "converged", ""},
    {"dependent_inputs", "balanced", "converged", ""},
    {"badly_scaled", "modal", "converged", ""},
    {"badly_scaled", "krylov", "converged", ""},
    {"badly_scaled", "portfolio", "converged", ""},
    // A DAE: Gramian- and pole-based methods refuse; Krylov reduces it.
    {"dae_singular_e", "krylov", "converged", ""},
    {"dae_singular_e", "irka", "refused", "singular"},
    {"dae_singular_e", "balanced", "refused", "singular"},
    // A circuit DAE: Gramian- and pole-based methods refuse by name; Krylov reduces it.
    {"circuit_dae", "irka", "refused", "E is singular"},
    {"circuit_dae", "balanced", "refused", "singular"},
    {"circuit_dae", "krylov", "converged", ""},
    {"large_circuit_dae", "irka", "refused", "E is singular"},
    {"large_circuit_dae", "balanced", "refused", "singular"},
    {"large_circuit_dae", "krylov", "converged", ""},
    // modal's general ARPACK run outlasts the time limit of 60 s: stopped inside the call.
    {"large_circuit_dae", "modal", "not converged", ""},
    {"unstable_pencil", "irka", "refused", "singular"},
    {"unstable_pencil", "balanced", "refused", "do not exist"},
    {"unstable_pencil", "modal", "not converged", ""},
    {"unstable_pencil", "krylov", "not converged", ""},
    {"unstable_pencil", "portfolio", "not converged", ""},
    // Pairs of eigenfrequencies 0.05 % apart: modal and krylov resolve both members of each pair
    // (irka and balanced need more than the budget of 40).
    {"clustered_modes", "modal", "converged", ""},
    {"clustered_modes", "krylov", "converged", ""},
    {"clustered_modes", "portfolio", "converged", ""},
    // An expansion point at the rigid-body pole s = 0: refused by name before any factorisation
    // (whether that of a singular K fails is a matter of rounding), with the rigid-body modes.
    {"point_at_pole", "krylov_s0_0", "refused",
     "reducer 'krylov': real_points: s0 = 0 is a pole of the model: it has 1 rigid-body mode"},
    // IRKA without restarts names its cycles; with restarts it recovers at those orders.
    {"irka_budget", "irka_3_iterations", "not converged", ""},
    // ADI out of budget: refused by name when convergence is required.
    {"adi_budget", "balanced_adi_strict", "failed", "ADI"},
    {"adi_budget", "balanced_adi_2", "not converged", ""},
    {"irka_cycling", "irka_no_restarts", "not converged", ""},
};

// Notes the reducers must leave in the history (breakdowns, budgets, cycles are named where they
// happen, with the order and the iteration).
struct ExpectNote {
  std::string scenario, reducer, contains;
};

const std::vector<ExpectNote> kExpectedNotes{
    {"irka_cycling", "irka_no_restarts", "cycling with period"},
    {"irka_budget", "irka_3_iterations", "iteration budget max_iterations = 3 used up"},
    {"unstable_projection", "krylov_two_sided", "two-sided projection lost stability"},
    {"unstable_projection", "krylov_one_sided", "one-sided projection lost stability"},
};

TEST(FailureAtlas, EachScenarioBehavesAsDocumented) {
  for (const Expect& e : kExpected) {
    if (!selected(e.scenario)) continue;
    const Outcome& o = outcome(e.scenario, e.reducer);
    SCOPED_TRACE(describe(o));
    if (e.kind == "not converged") {
      EXPECT_NE(o.kind, "converged");
    } else {
      EXPECT_EQ(o.kind, e.kind);
    }
    if (!e.contains.empty()) {
      EXPECT_NE(o.detail.find(e.contains), std::string::npos);
    }
  }
}

TEST(FailureAtlas, BreakdownsBudgetsAndCyclesAreNamedInTheHistory) {
  for (const ExpectNote& e : kExpectedNotes) {
    if (!selected(e.scenario)) continue;
    const Outcome& o = outcome(e.scenario, e.reducer);
    SCOPED_TRACE(describe(o) + "\nnotes:\n" + o.notes);
    EXPECT_NE(o.notes.find(e.contains), std::string::npos);
  }
}

// Projections that lose stability: the unstable iterates are flagged (history, note), never
// reported; the structure-preserving default on the same model is stable throughout.
TEST(FailureAtlas, UnstableIteratesAreFlaggedAndNotReported) {
  if (!selected("unstable_projection")) GTEST_SKIP();
  for (const char* label : {"krylov_two_sided", "krylov_one_sided"}) {
    const Outcome& o = outcome("unstable_projection", label);
    SCOPED_TRACE(describe(o));
    EXPECT_GT(o.unstable_iterates, 0);
    EXPECT_TRUE(o.stable);
  }
  const Outcome& structured = outcome("unstable_projection", "krylov");
  SCOPED_TRACE(describe(structured));
  EXPECT_EQ(structured.unstable_iterates, 0);
  EXPECT_EQ(structured.kind, "converged");
}

// The driver decides the full model's own stability and warns when a model is reported for a
// full model that is not asymptotically stable (a stable reduced model of an unstable structure
// is faithful in the band only).
TEST(FailureAtlas, FullModelStabilityIsReportedAndWarnedAbout) {
  for (const Scenario& s : scenarios()) {
    if (!selected(s.name)) continue;
    for (const AtlasRun& r : runs_of(s)) {
      const Outcome& o = outcome(s.name, r.label);
      if (o.termination.empty()) continue;  // thrown before a summary (refused in setup)
      SCOPED_TRACE(describe(o));
      // s.full lists the admissible verdicts, separated by '|'.
      EXPECT_NE(("|" + s.full + "|").find("|" + o.full + "|"), std::string::npos) << s.full;
      const bool warned = o.warnings.find("the full model is " + o.full) != std::string::npos;
      // A free body (marginally stable by its rigid-body poles at 0) reported with the same
      // rigid-body modes and damped elastic poles is the expected case of multibody use: no
      // warning. Any other marginal or unstable full model is warned about.
      const bool expected =
          o.full == "unstable" || (o.full == "marginally stable" && !o.rigid_like_full);
      EXPECT_EQ(warned, expected) << o.warnings;
      if ((o.kind == "converged" || o.kind == "missed") && o.stable && warned) {
        EXPECT_NE(o.warnings.find("in the band only, not in the time domain"), std::string::npos)
            << o.warnings;
      }
    }
  }
}

// A converged run's error on the independent re-check grid is within its scenario's tolerance.
TEST(FailureAtlas, ConvergedRunsMeetTheTolerance) {
  std::map<std::string, double> tolerance;
  for (const Scenario& s : scenarios()) tolerance[s.name] = s.tolerance;
  for (const Outcome& o : outcomes()) {
    if (o.kind != "converged") continue;
    SCOPED_TRACE(describe(o));
    EXPECT_LE(o.band_error, tolerance[o.scenario]);
  }
}

// ---- the table in docs/failure-atlas.md -------------------------------------------------------

std::string atlas_table() {
  std::ostringstream t;
  t << "| scenario | what | run | outcome | order | stable | band error | unstable iterates | "
       "what happened |\n"
    << "|---|---|---|---|---|---|---|---|---|\n";
  std::map<std::string, std::string> what;
  for (const Scenario& s : scenarios()) {
    std::string full = s.full;
    for (std::size_t p = full.find('|'); p != std::string::npos; p = full.find('|'))
      full.replace(p, 1, " or ");
    what[s.name] = s.what + " (full model: " + full + ")";
  }
  std::string previous;
  for (const Outcome& o : outcomes()) {
    char err[32];
    std::snprintf(err, sizeof err, "%.1e", o.band_error);
    const bool model = o.kind == "converged" || o.kind == "missed";  // a model was written
    std::string detail = o.detail;
    if (!o.warnings.empty()) detail += "; **warning: the full model is " + o.full + "**";
    for (char& c : detail)
      if (c == '|') c = '/';
    const bool first = o.scenario != previous;
    previous = o.scenario;
    t << "| " << o.scenario << " | " << (first ? what[o.scenario] : "") << " | " << o.reducer
      << " | " << o.kind << " | " << (model ? std::to_string(o.order) : "") << " | "
      << (model ? (o.stable ? "yes" : "**no**") : "") << " | " << (model ? err : "") << " | "
      << (o.kind == "refused" ? "" : std::to_string(o.unstable_iterates)) << " | " << detail
      << " |\n";
  }
  return t.str();
}

// The cells of the table's rows (header and separator left out), keyed by scenario and run.
std::map<std::pair<std::string, std::string>, std::vector<std::string>> table_rows(
    const std::string& table) {
  std::map<std::pair<std::string, std::string>, std::vector<std::string>> rows;
  std::istringstream in(table);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("| ", 0) != 0 || line.rfind("| scenario |", 0) == 0) continue;
    std::vector<std::string> cells;
    std::size_t at = 1;
    for (std::size_t bar = line.find('|', at); bar != std::string::npos;
         at = bar + 1, bar = line.find('|', at)) {
      std::string cell = line.substr(at, bar - at);
      const auto first = cell.find_first_not_of(' ');
      cell = first == std::string::npos
                 ? ""
                 : cell.substr(first, cell.find_last_not_of(' ') - first + 1);
      cells.push_back(cell);
    }
    if (cells.size() >= 8) rows[{cells[0], cells[2]}] = cells;
  }
  return rows;
}

TEST(FailureAtlas, TableInTheDocs) {
  const std::string table = atlas_table();
  const fs::path doc = fs::path(ECMOR_TEST_SOURCE_DIR) / "docs" / "failure-atlas.md";
  const std::string begin = "<!-- atlas-table:begin -->\n", end = "<!-- atlas-table:end -->";
  std::ifstream in(doc);
  ASSERT_TRUE(in.good()) << doc;
  std::string text((std::istreambuf_iterator<char>(in)), {});
  const auto b = text.find(begin), e = text.find(end);
  ASSERT_NE(b, std::string::npos);
  ASSERT_NE(e, std::string::npos);
  const char* only = std::getenv("ECMOR_ATLAS_ONLY");
  // The table in the docs holds every scenario, the slow ones too.
  if (const char* update = std::getenv("ECMOR_UPDATE_ATLAS");
      update && std::string(update) == "1" && (only == nullptr || *only == '\0') &&
      slow_enabled()) {
    text = text.substr(0, b + begin.size()) + table + text.substr(e);
    std::ofstream(doc, std::ios::trunc) << text;
  }
  std::printf("%s", table.c_str());
  // Every run made here is in the docs' table with the same outcome, order, stability and count
  // of unstable iterates, and its band error within a factor 1.5: a relative error near a
  // transmission zero moves with the last bits of a threaded BLAS (zero_in_band gave 1.7e-5 and
  // 2.3e-5 in two runs of the same build, by the threads the load left). (Regenerate:
  // ECMOR_UPDATE_ATLAS=1 with the slow scenarios enabled.)
  const auto db = text.find(begin), de = text.find(end);  // the table as it stands now
  const auto documented = table_rows(text.substr(db, de - db));
  for (const auto& [key, cells] : table_rows(table)) {
    SCOPED_TRACE(key.first + " / " + key.second);
    const auto it = documented.find(key);
    ASSERT_NE(it, documented.end()) << "not in docs/failure-atlas.md";
    const std::vector<std::string>& doc_cells = it->second;
    for (std::size_t c : {3u, 4u, 5u, 7u}) EXPECT_EQ(cells[c], doc_cells[c]) << "column " << c;
    if (!cells[6].empty() && !doc_cells[6].empty()) {
      const double a = std::stod(cells[6]), d = std::stod(doc_cells[6]);
      EXPECT_LE(std::max(a, d), 1.5 * std::min(a, d)) << cells[6] << " vs " << doc_cells[6];
    } else {
      EXPECT_EQ(cells[6], doc_cells[6]);
    }
  }
}

}  // namespace
}  // namespace ecmor
