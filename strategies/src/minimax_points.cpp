#include "minimax_points.hpp"

#include <IpIpoptApplication.hpp>
#include <IpTNLP.hpp>
#include <algorithm>
#include <cmath>
#include <optional>

#include "ecmor/base/error.hpp"
#include "support.hpp"

namespace ecmor {

namespace {

const char* kName = "minimax_points";

// Ipopt's Index is int; ecmor's is Eigen::Index. Keep them apart by name.
using IpIndex = Ipopt::Index;
using Number = Ipopt::Number;

std::string status_name(Ipopt::ApplicationReturnStatus s) {
  switch (s) {
    case Ipopt::Solve_Succeeded:
      return "solve succeeded";
    case Ipopt::Solved_To_Acceptable_Level:
      return "solved to acceptable level";
    case Ipopt::Infeasible_Problem_Detected:
      return "infeasible problem detected";
    case Ipopt::Search_Direction_Becomes_Too_Small:
      return "search direction too small";
    case Ipopt::Diverging_Iterates:
      return "diverging iterates";
    case Ipopt::User_Requested_Stop:
      return "stopped (evaluation budget or request)";
    case Ipopt::Feasible_Point_Found:
      return "feasible point found";
    case Ipopt::Maximum_Iterations_Exceeded:
      return "max_iter reached";
    case Ipopt::Restoration_Failed:
      return "restoration failed";
    case Ipopt::Error_In_Step_Computation:
      return "error in step computation";
    case Ipopt::Maximum_CpuTime_Exceeded:
      return "cpu time exceeded";
    case Ipopt::Not_Enough_Degrees_Of_Freedom:
      return "not enough degrees of freedom";
    case Ipopt::Invalid_Problem_Definition:
      return "invalid problem definition";
    case Ipopt::Invalid_Option:
      return "invalid option";
    case Ipopt::Invalid_Number_Detected:
      return "invalid number detected";
    case Ipopt::Unrecoverable_Exception:
      return "unrecoverable exception";
    case Ipopt::NonIpopt_Exception_Thrown:
      return "non-Ipopt exception";
    case Ipopt::Insufficient_Memory:
      return "insufficient memory";
    case Ipopt::Internal_Error:
      return "internal error";
  }
  return "status " + std::to_string(static_cast<int>(s));
}

// The epigraph program: variables (x_1..x_p, t), minimise t s.t. L_k(x) - t <= 0.
class EpigraphProgram final : public Ipopt::TNLP {
 public:
  EpigraphProgram(const MinimaxPointsOptions& options, point_search::PointObjective& objective,
                  std::vector<double> x0)
      : m_options(options),
        m_objective(objective),
        m_x0(std::move(x0)),
        m_p(static_cast<IpIndex>(m_x0.size())),
        m_s(static_cast<IpIndex>(objective.samples().size())) {}

  bool get_nlp_info(IpIndex& n, IpIndex& m, IpIndex& nnz_jac_g, IpIndex& nnz_h_lag,
                    IndexStyleEnum& index_style) override {
    n = m_p + 1;
    m = m_s;
    nnz_jac_g = m_s * (m_p + 1);  // dense: every sample depends on every point
    nnz_h_lag = 0;                // limited-memory quasi-Newton
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(IpIndex n, Number* x_l, Number* x_u, IpIndex m, Number* g_l,
                       Number* g_u) override {
    for (IpIndex i = 0; i < m_p; ++i) {
      x_l[i] = m_objective.lower();
      x_u[i] = m_objective.upper();
    }
    x_l[n - 1] = -kInfinity;  // t is free
    x_u[n - 1] = kInfinity;
    for (IpIndex k = 0; k < m; ++k) {
      g_l[k] = -kInfinity;
      g_u[k] = 0.0;
    }
    return true;
  }

  bool get_starting_point(IpIndex n, bool init_x, Number* x, bool /*init_z*/, Number* /*z_L*/,
                          Number* /*z_U*/, IpIndex /*m*/, bool /*init_lambda*/,
                          Number* /*lambda*/) override {
    if (!init_x) return true;
    std::vector<double> start = m_x0;
    const Levels* at = levels(start);
    if (at == nullptr) {
      // The warm start is unusable (e.g. a point on an eigenvalue): log-spaced points instead.
      start = point_search::log_spaced(m_objective.lower(), m_objective.upper(), m_p);
      at = levels(start);
      if (at == nullptr) return false;  // Ipopt stops; the outer loop reports the failures
    }
    std::copy(start.begin(), start.end(), x);
    // Feasible start: t just above the largest level.
    x[n - 1] = at->value + 1e-2;
    return true;
  }

  bool eval_f(IpIndex n, const Number* x, bool /*new_x*/, Number& obj_value) override {
    obj_value = x[n - 1];
    return true;
  }

  bool eval_grad_f(IpIndex n, const Number* /*x*/, bool /*new_x*/, Number* grad_f) override {
    std::fill(grad_f, grad_f + n, 0.0);
    grad_f[n - 1] = 1.0;
    return true;
  }

  bool eval_g(IpIndex n, const Number* x, bool /*new_x*/, IpIndex m, Number* g) override {
    const Levels* at = levels(std::vector<double>(x, x + m_p));
    if (at == nullptr) return false;  // Ipopt treats it as an evaluation error: shorter step
    for (IpIndex k = 0; k < m; ++k) g[k] = at->level[static_cast<std::size_t>(k)] - x[n - 1];
    return true;
  }

  bool eval_jac_g(IpIndex /*n*/, const Number* x, bool /*new_x*/, IpIndex /*m*/,
                  IpIndex /*nele_jac*/, IpIndex* iRow, IpIndex* jCol, Number* values) override {
    if (values == nullptr) {
      IpIndex e = 0;
      for (IpIndex k = 0; k < m_s; ++k) {
        for (IpIndex i = 0; i <= m_p; ++i, ++e) {
          iRow[e] = k;
          jCol[e] = i;
        }
      }
      return true;
    }
    const std::vector<double> xv(x, x + m_p);
    const Levels* at = levels(xv);
    if (at == nullptr) return false;
    if (!m_jacobian || m_jacobian_x != xv) {
      m_jacobian = m_objective.jacobian(xv, *at, m_options.fd_step, m_options.central,
                                        m_options.fd_rows_within);
      m_jacobian_x = xv;
    }
    if (!m_jacobian) return false;
    IpIndex e = 0;
    for (IpIndex k = 0; k < m_s; ++k) {
      for (IpIndex i = 0; i < m_p; ++i, ++e) values[e] = (*m_jacobian)(k, i);
      values[e++] = -1.0;  // d(L_k - t)/dt
    }
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn /*status*/, IpIndex /*n*/, const Number* /*x*/,
                         const Number* /*z_L*/, const Number* /*z_U*/, IpIndex /*m*/,
                         const Number* /*g*/, const Number* /*lambda*/, Number obj_value,
                         const Ipopt::IpoptData* /*ip_data*/,
                         Ipopt::IpoptCalculatedQuantities* /*ip_cq*/) override {
    m_final_t = obj_value;
  }

  bool intermediate_callback(Ipopt::AlgorithmMode /*mode*/, IpIndex iter, Number /*obj_value*/,
                             Number /*inf_pr*/, Number /*inf_du*/, Number /*mu*/, Number /*d_norm*/,
                             Number /*regularization_size*/, Number /*alpha_du*/,
                             Number /*alpha_pr*/, IpIndex /*ls_trials*/,
                             const Ipopt::IpoptData* /*ip_data*/,
                             Ipopt::IpoptCalculatedQuantities* /*ip_cq*/) override {
    m_iterations = iter;
    if (m_objective.stopped()) return false;
    return m_options.max_evaluations <= 0 ||
           m_objective.round_evaluations() < m_options.max_evaluations;
  }

  IpIndex iterations() const { return m_iterations; }
  double final_t() const { return m_final_t; }

 private:
  using Levels = point_search::PointObjective::Levels;
  static constexpr Number kInfinity = 1e19;  // Ipopt's default nlp_{lower,upper}_bound_inf

  // Levels at x, evaluated once per distinct x (Ipopt asks for g and its Jacobian at the same x,
  // and the objective t does not need a reduction at all). nullptr when the evaluation failed.
  const Levels* levels(const std::vector<double>& x) {
    if (!m_cache || m_cache_x != x) {
      m_cache = m_objective.evaluate(x);
      m_cache_x = x;
    }
    return m_cache->ok ? &*m_cache : nullptr;
  }

  const MinimaxPointsOptions& m_options;
  point_search::PointObjective& m_objective;
  std::vector<double> m_x0;
  IpIndex m_p, m_s;
  std::optional<Levels> m_cache;
  std::vector<double> m_cache_x;
  std::optional<Matrix> m_jacobian;
  std::vector<double> m_jacobian_x;
  IpIndex m_iterations = 0;
  double m_final_t = 0.0;
};

}  // namespace

const OptionSpecs<MinimaxPointsOptions>& MinimaxPointsOptions::specs() {
  using O = MinimaxPointsOptions;
  static const OptionSpecs<O> specs = [] {
    OptionSpecs<O> s(
        {
            option("max_iter", &O::max_iter, "Ipopt iterations per optimisation")
                .range(Range::closed(1, 100000)),
            option("tol", &O::tol,
                   "Ipopt's (scaled) convergence tolerance; t is in decades of the error, so 1e-4 "
                   "resolves the error to 0.02 %")
                .range(Range::above(0).finite()),
            option("acceptable_tol", &O::acceptable_tol, "Ipopt's \"acceptable\" tolerance, >= tol")
                .range(Range::at_least(0).finite()),
            option("max_evaluations", &O::max_evaluations,
                   "objective evaluations per optimisation, presearch included, checked after "
                   "every Ipopt iteration (so a budget the presearch uses up stops Ipopt at its "
                   "first check); 0 = no limit but max_iter")
                .range(Range::closed(0, 1e8)),
            // A zero step divides by zero; beyond a tenth of a decade the difference no longer
            // resolves a resonance at all.
            option("fd_step", &O::fd_step, "finite-difference step h in log10 f")
                .unit("decades")
                .range(Range::open_closed(0, 0.1)),
            choice("fd_scheme", &O::central, {{"central", true}, {"forward", false}},
                   "finite-difference scheme"),
            option("fd_rows_within", &O::fd_rows_within,
                   "after an optimisation's first Jacobian, difference only the samples whose "
                   "level is within this many decades of the largest (the near-active "
                   "constraints); the other rows keep their last values; 0 = every row every "
                   "time")
                .unit("decades")
                .range(Range::closed(0, 100)),
            choice("presearch", &O::presearch,
                   {{"none", std::nullopt},
                    {"bobyqa", PointAlgorithm::Bobyqa},
                    {"direct_l", PointAlgorithm::DirectL},
                    {"direct_l_then_bobyqa", PointAlgorithm::DirectLThenBobyqa}},
                   "NLopt presearch before Ipopt"),
            option("presearch_evaluations", &O::presearch_evaluations,
                   "the presearch's evaluations; 0 = 20 p")
                .range(Range::closed(0, 1e8)),
        },
        {[](const O& o, const OptionCheck<O>& c) {
          if (!(o.acceptable_tol >= o.tol)) {
            c.fail(o.acceptable_tol,
                   "must be >= " + c.key(o.tol) + " = " + strategy_support::sci(o.tol));
          }
        }});
    s.include(&O::search, point_search::PointSearchOptions::specs());
    return s;
  }();
  return specs;
}

point_search::Optimisation minimax_optimise(const MinimaxPointsOptions& o,
                                            point_search::PointObjective& objective,
                                            const std::vector<double>& x0) {
  point_search::Optimisation out;
  std::vector<double> start = x0;
  if (o.presearch) {
    OptimizePointsOptions pre;
    pre.algorithm = *o.presearch;
    pre.max_evaluations =
        o.presearch_evaluations > 0 ? o.presearch_evaluations : 20 * static_cast<Index>(x0.size());
    // Only the basin matters here; Ipopt resolves the optimum.
    pre.xtol_rel = 1e-3;
    const point_search::Optimisation r = nlopt_optimise(pre, objective, x0);
    out.status = "presearch " + r.status + "; ";
    out.diagnostics["presearch_evaluations"] = static_cast<double>(objective.round_evaluations());
    if (objective.stopped()) return out;
    if (!objective.best_x().empty()) start = objective.best_x();
  }
  Ipopt::SmartPtr<EpigraphProgram> program = new EpigraphProgram(o, objective, start);
  // No console journal at all: strategies never print (print_level 0 alone still leaves the
  // banner and some warnings on stdout).
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = new Ipopt::IpoptApplication(false);
  app->RethrowNonIpoptException(true);
  Ipopt::SmartPtr<Ipopt::OptionsList> opts = app->Options();
  bool ok = opts->SetIntegerValue("print_level", 0) && opts->SetStringValue("sb", "yes") &&
            opts->SetStringValue("hessian_approximation", "limited-memory") &&
            opts->SetIntegerValue("max_iter", static_cast<IpIndex>(o.max_iter)) &&
            opts->SetNumericValue("tol", o.tol) &&
            opts->SetNumericValue("acceptable_tol", o.acceptable_tol) &&
            opts->SetStringValue("mu_strategy", "adaptive");
  // Initialize("") skips reading an ipopt.opt file from the working directory.
  if (!ok || app->Initialize("") != Ipopt::Solve_Succeeded) {
    throw NumericalError(std::string("strategy '") + kName +
                         "': Ipopt rejected its options (internal error)");
  }
  const Ipopt::ApplicationReturnStatus status = app->OptimizeTNLP(program);
  out.status += "ipopt: " + status_name(status) + " after " +
                std::to_string(program->iterations()) + " iterations";
  out.diagnostics["ipopt_status"] = static_cast<double>(status);
  out.diagnostics["ipopt_iterations"] = static_cast<double>(program->iterations());
  if (objective.jacobian_rows_total() > 0) {
    out.diagnostics["jacobian_rows_differenced"] =
        static_cast<double>(objective.jacobian_rows()) /
        static_cast<double>(objective.jacobian_rows_total());
  }
  return out;
}

StrategyResult MinimaxPoints::run(StrategyContext& ctx) {
  strategy_support::require_point_reducer(ctx, kName);
  const MinimaxPointsOptions o = m_options;
  return point_search::run_point_search(
      ctx, o.search, kName,
      [o](point_search::PointObjective& objective, const std::vector<double>& x0) {
        return minimax_optimise(o, objective, x0);
      });
}

}  // namespace ecmor
