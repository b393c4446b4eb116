// pod_snapshots.cpp: the "pod_snapshots" reducer, a complete out-of-tree ecmor plugin.
//
// Proper orthogonal decomposition (POD) of frequency-response snapshots: the state responses
// X(s_k) = P(s_k)^-1 B at log-spaced frequencies across the band, s_k = i 2 pi f_k, with
// P(s) = s^2 M + s D + K (second order) or s E - A (descriptor), are stacked as real columns
// [Re X_k, Im X_k], and the leading left singular vectors of that snapshot matrix form a Galerkin
// basis V = W. See README.md for the parameters and what to expect.
//
// What a plugin must respect (docs/plugin-guide.md of ecmor): solve only through ctx.solver, never
// print, throw ecmor::Error subclasses that name the reducer, and let a failed reduce() leave the
// reducer usable. Everything expensive happens once in setup(); reduce() only slices a basis that
// is computed already, so the bases are nested and growing the order costs one projection.
#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/plugin/plugin.hpp"

namespace pod_snapshots {
namespace {

using ecmor::Complex;
using ecmor::ComplexMatrix;
using ecmor::Index;
using ecmor::Matrix;

constexpr const char* kName = "pod_snapshots";

/// The options of the reducer, read from the YAML `reducer:` mapping in create(). The
/// initialisers are the defaults; option_specs() gives each field's key, range and documentation,
/// once, for reading, validating and `ecmor plugins` alike.
struct Options {
  Index snapshots = 24;
  double rank_tolerance = 1e-10;
  bool normalize = true;
};

const ecmor::OptionSpecs<Options>& option_specs() {
  using ecmor::option;
  using ecmor::Range;
  static const ecmor::OptionSpecs<Options> specs({
      option("snapshots", &Options::snapshots,
             "frequencies sampled log-spaced across the band (ends included); each costs one "
             "complex factorisation and m solves")
          .range(Range::closed(1, 100000)),
      option("rank_tolerance", &Options::rank_tolerance,
             "singular values <= rank_tolerance * sigma_1 are dropped, which sets max_order")
          .range(Range::closed(1e-16, 0.1)),
      option("normalize", &Options::normalize,
             "scale each frequency's snapshot block to unit Frobenius norm (equal weight per "
             "frequency) before the SVD"),
  });
  return specs;
}

/// A number with three significant digits for messages ("0.0159", "3.2e-06").
std::string text(double value) {
  std::ostringstream out;
  out.precision(3);
  out << value;
  return out.str();
}

/// Frequencies f_k = f_min (f_max / f_min)^(k / (count - 1)), k = 0 .. count - 1, in Hz; one
/// snapshot sits at the geometric centre of the band.
std::vector<double> log_spaced(double f_min_hz, double f_max_hz, Index count) {
  if (count == 1) return {std::sqrt(f_min_hz * f_max_hz)};
  std::vector<double> f(static_cast<std::size_t>(count));
  const double ratio = std::log(f_max_hz / f_min_hz);
  for (Index k = 0; k < count; ++k) {
    f[static_cast<std::size_t>(k)] =
        f_min_hz * std::exp(ratio * static_cast<double>(k) / static_cast<double>(count - 1));
  }
  f.back() = f_max_hz;  // exactly the band's end, whatever exp rounds to
  return f;
}

const Matrix& input_matrix(const ecmor::Model& model) {
  return std::visit([](const auto& m) -> const Matrix& { return m.B; }, model);
}

class PodSnapshotsReducer final : public ecmor::Reducer {
 public:
  explicit PodSnapshotsReducer(Options options) : m_options(options) {}

  void setup(const ecmor::ReductionContext& ctx) override {
    if (ctx.model == nullptr || ctx.solver == nullptr) {
      throw ecmor::InputError(std::string(kName) + ": setup() needs a model and a solver");
    }
    ctx.band.validate();
    const Matrix& B = input_matrix(*ctx.model);
    const Index n = ecmor::size_of(*ctx.model);
    const Index m = B.cols();
    const std::vector<double> f_hz =
        log_spaced(ctx.band.f_min_hz, ctx.band.f_max_hz, m_options.snapshots);

    // Snapshot matrix S = [Re X_0, Im X_0, Re X_1, Im X_1, ...], N x 2 m K. Re and Im span the
    // same real space as X(s) and X(conj s), so a real basis interpolates at both.
    Matrix S(n, 2 * m * static_cast<Index>(f_hz.size()));
    const ComplexMatrix Bc = B.cast<Complex>();
    for (std::size_t k = 0; k < f_hz.size(); ++k) {
      ComplexMatrix X;
      try {
        X = ctx.solver->factorize(ecmor::s_from_hz(f_hz[k]))->solve(Bc);
      } catch (const ecmor::Error& e) {
        throw ecmor::NumericalError(std::string(kName) + ": snapshot at f = " + text(f_hz[k]) +
                                    " Hz: " + e.what());
      }
      // Unit weight per frequency: the error target is relative at every frequency, so a
      // resonance peak must not drown the quiet parts of the band in the singular values.
      const double norm = X.norm();
      if (m_options.normalize && norm > 0.0) X /= norm;
      const Index col = 2 * m * static_cast<Index>(k);
      S.middleCols(col, m) = X.real();
      S.middleCols(col + m, m) = X.imag();
    }

    // Thin SVD: the left singular vectors are the POD modes, ordered by energy. BDCSVD is exact
    // to rounding for any shape (it falls back to Jacobi on small blocks).
    const Eigen::BDCSVD<Matrix> svd(S, Eigen::ComputeThinU);
    const ecmor::Vector& sigma = svd.singularValues();
    if (sigma.size() == 0 || !(sigma(0) > 0.0)) {
      throw ecmor::InputError(std::string(kName) +
                              ": every snapshot P(s)^-1 B is zero (is B zero?)");
    }
    if (!sigma.allFinite()) {
      throw ecmor::NumericalError(std::string(kName) + ": the snapshots are not finite");
    }
    Index rank = 0;
    while (rank < sigma.size() && sigma(rank) > m_options.rank_tolerance * sigma(0)) ++rank;

    // Commit only now: a throw above leaves a previous setup's state untouched.
    m_model = ctx.model;
    m_basis = svd.matrixU().leftCols(rank);
    m_sigma = sigma;
    m_snapshot_columns = S.cols();
  }

  ecmor::ReducerResult reduce(const ecmor::ReductionRequest& request) override {
    if (m_model == nullptr) {
      throw ecmor::Error(std::string(kName) + ": reduce() called before setup()");
    }
    if (!request.points.empty()) {
      throw ecmor::ConfigError(
          std::string(kName) + ": given " + std::to_string(request.points.size()) +
          " expansion point(s), but it samples its own snapshots across the band and takes no "
          "points; use a strategy that grows the order (grow_order)");
    }
    if (request.order < 1) {
      throw ecmor::ConfigError(std::string(kName) + ": requested order " +
                               std::to_string(request.order) + ": must be >= 1");
    }
    const Index order = std::min(request.order, max_order());

    ecmor::ReducerResult result;
    result.V = m_basis.leftCols(order);
    result.W = result.V;  // Galerkin
    result.model = ecmor::project(*m_model, result.V, result.W);

    // A-posteriori indicators: the first discarded singular value relative to the first, and the
    // relative Frobenius residual ||S - V V' S||_F / ||S||_F of the snapshot matrix.
    const double next = order < m_sigma.size() ? m_sigma(order) / m_sigma(0) : 0.0;
    const double tail = m_sigma.tail(m_sigma.size() - order).norm() / m_sigma.norm();
    result.diagnostics["snapshot_singular_value_ratio"] = next;
    result.diagnostics["snapshot_projection_error"] = tail;
    result.diagnostics["snapshot_rank"] = static_cast<double>(max_order());
    result.note = std::to_string(order) + " POD modes of " + std::to_string(m_snapshot_columns) +
                  " snapshot columns (" + std::to_string(m_options.snapshots) +
                  " frequencies), sigma_" + std::to_string(order + 1) + "/sigma_1 = " + text(next);
    return result;
  }

  Index max_order() const override { return m_basis.cols(); }
  Index order_step() const override { return 1; }

 private:
  Options m_options;
  const ecmor::Model* m_model = nullptr;
  Matrix m_basis;         ///< N x rank, orthonormal POD modes, most energetic first
  ecmor::Vector m_sigma;  ///< all singular values of the snapshot matrix, descending
  Index m_snapshot_columns = 0;
};

ecmor::ReducerInfo pod_info() {
  return ecmor::reducer_info(
      kName,
      "POD of frequency-response snapshots P(s_k)^-1 B at log-spaced band frequencies, Galerkin "
      "projection on the leading left singular vectors",
      "0.1.0", option_specs(), {/*second_order=*/true, /*descriptor=*/true});
}

std::unique_ptr<ecmor::Reducer> create(const ecmor::ParameterMap& params) {
  return ecmor::create_from_specs<PodSnapshotsReducer>(params, option_specs());
}

void register_reducers(ecmor::Registry& registry) { registry.add({pod_info(), create}); }

}  // namespace
}  // namespace pod_snapshots

ECMOR_PLUGIN(pod_snapshots::register_reducers)
