// reducer_guard.cpp: the plugin boundary checks (see reducer_guard.hpp and
// check_reducer_result() in reducer.hpp).
#include "plugin/reducer_guard.hpp"

#include <fmt/format.h>

#include <new>
#include <typeinfo>
#include <utility>

#include "ecmor/base/error.hpp"

namespace ecmor {

namespace {

bool all_finite(const Matrix& X) { return X.allFinite(); }

/// The name of the first reduced matrix with a NaN or Inf entry, or null.
const char* non_finite_matrix(const ReducedModel& model) {
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model)) {
    const std::pair<const char*, const Matrix*> matrices[] = {{"Mr", &so->M}, {"Dr", &so->D},
                                                              {"Kr", &so->K}, {"Br", &so->B},
                                                              {"Cr", &so->C}, {"Cvr", &so->Cv}};
    for (const auto& [name, A] : matrices)
      if (!all_finite(*A)) return name;
    return nullptr;
  }
  const auto& ds = std::get<ReducedDescriptorModel>(model);
  const std::pair<const char*, const Matrix*> matrices[] = {
      {"Er", &ds.E}, {"Ar", &ds.A}, {"Br", &ds.B}, {"Cr", &ds.C}};
  for (const auto& [name, A] : matrices)
    if (!all_finite(*A)) return name;
  return nullptr;
}

}  // namespace

void check_reducer_result(const Model& full, const ReductionRequest& request,
                          const ReducerResult& result, const std::string& reducer) {
  const std::string where = fmt::format(
      "reducer '{}', reduce(order {}{})", reducer, request.order,
      request.points.empty() ? std::string() : fmt::format(", {} points", request.points.size()));
  const Index n = size_of(full);
  const Index rows = result.V.rows();
  const bool second_order = kind_of(full) == ModelKind::SecondOrder;
  if (rows != n && !(second_order && rows == 2 * n)) {
    throw PluginError(
        fmt::format("{}: V has {} rows; the model has N = {} states{} (rule: V is N x n{})", where,
                    rows, n, second_order ? " (second order)" : "",
                    second_order ? ", or 2N x n for the first-order realisation x = [q; q']" : ""));
  }
  if (result.W.rows() != rows || result.W.cols() != result.V.cols()) {
    throw PluginError(fmt::format("{}: W is {} x {} but V is {} x {} (rule: W has V's shape)",
                                  where, result.W.rows(), result.W.cols(), rows, result.V.cols()));
  }
  if (result.V.cols() < 1) throw PluginError(where + ": returned an empty basis (0 columns)");
  const Index r = size_of(result.model);
  if (r != result.V.cols()) {
    throw PluginError(fmt::format(
        "{}: the reduced model has {} states but V has {} columns (rule: one state per column)",
        where, r, result.V.cols()));
  }
  if (inputs_of(result.model) != inputs_of(full) || outputs_of(result.model) != outputs_of(full)) {
    throw PluginError(fmt::format(
        "{}: the reduced model has {} input(s) and {} output(s), the full model {} and {}", where,
        inputs_of(result.model), outputs_of(result.model), inputs_of(full), outputs_of(full)));
  }
  if (rows == 2 * n && n != rows && kind_of(result.model) != ModelKind::Descriptor) {
    throw PluginError(where +
                      ": a 2N-row basis (first-order realisation) must come with a first-order "
                      "(descriptor) reduced model");
  }
  if (!all_finite(result.V)) throw NumericalError(where + ": V has a NaN or Inf entry");
  if (!all_finite(result.W)) throw NumericalError(where + ": W has a NaN or Inf entry");
  // Non-finite entries are a numerical breakdown, wrong shapes a plugin bug: the first are
  // found here, the second by validate().
  if (const char* name = non_finite_matrix(result.model))
    throw NumericalError(fmt::format("{}: reduced model: {} has a NaN or Inf entry", where, name));
  try {
    validate(result.model, where + ": reduced model");
  } catch (const InputError& e) {
    throw PluginError(e.what());
  }
}

namespace detail {

namespace {

class GuardedReducer final : public Reducer {
 public:
  GuardedReducer(std::unique_ptr<Reducer> inner, const ReducerInfo& info,
                 const std::filesystem::path& library)
      : m_inner(std::move(inner)),
        m_name(info.name),
        m_modal_block(info.modal_block),
        m_who(library.empty() ? fmt::format("reducer '{}'", m_name)
                              : fmt::format("reducer '{}' ({})", m_name, library.string())) {}

  void setup(const ReductionContext& context) override {
    if (m_model != nullptr)
      throw ConfigError(m_who + ": setup() called twice (a reducer is bound to one model)");
    if (context.model == nullptr) throw ConfigError(m_who + ": setup() needs a model");
    call("setup()", [&] { m_inner->setup(context); });
    m_model = context.model;
  }

  ReducerResult reduce(const ReductionRequest& request) override {
    const std::string what = fmt::format("reduce(order {})", request.order);
    if (m_model == nullptr) throw ConfigError(m_who + ": " + what + " called before setup()");
    if (request.order < 0 || (request.order == 0 && request.points.empty())) {
      throw ConfigError(fmt::format(
          "{}: {}: the order must be >= 1 (or 0 together with expansion points: all they imply)",
          m_who, what));
    }
    if (request.modes < 0 || (request.modes > 0 && request.points.empty())) {
      throw ConfigError(fmt::format(
          "{}: {}: modes = {}: a modal block needs expansion points and modes >= 0 (without "
          "points the order alone asks for modes)",
          m_who, what, request.modes));
    }
    if (request.modes > 0 && !m_modal_block) {
      throw ConfigError(fmt::format(
          "{}: {}: a modal block of {} modes was requested, but this reducer does not compute "
          "modes (ReducerInfo::modal_block is false); use reducer modal",
          m_who, what, request.modes));
    }
    ReducerResult result;
    call(what, [&] { result = m_inner->reduce(request); });
    check_reducer_result(*m_model, request, result, m_name);
    return result;
  }

  Index max_order() const override {
    Index value = 0;
    call("max_order()", [&] { value = m_inner->max_order(); });
    if (value < 0) throw PluginError(fmt::format("{}: max_order() returned {}", m_who, value));
    return value;
  }

  Index order_step() const override {
    Index value = 0;
    call("order_step()", [&] { value = m_inner->order_step(); });
    if (value < 1)
      throw PluginError(fmt::format("{}: order_step() returned {} (rule: >= 1)", m_who, value));
    return value;
  }

 private:
  // ecmor errors pass unchanged (they are the plugin's named errors); anything else becomes a
  // PluginError naming the reducer, its library and the call. Messages are copied while the
  // plugin's code (and its exception types) are still mapped: the reducer keeps its library alive.
  template <class F>
  void call(const std::string& what, F&& body) const {
    try {
      body();
    } catch (const Error&) {
      throw;
    } catch (const std::bad_alloc&) {
      throw NumericalError(fmt::format("{}: {}: out of memory", m_who, what));
    } catch (const std::exception& e) {
      throw PluginError(fmt::format(
          "{}: {} threw {} (not an ecmor::Error, so the plugin did not say what went wrong "
          "in its terms): {}",
          m_who, what, typeid(e).name(), e.what()));
    } catch (...) {
      throw PluginError(
          fmt::format("{}: {} threw an unknown exception (not derived from "
                      "std::exception)",
                      m_who, what));
    }
  }

  std::unique_ptr<Reducer> m_inner;
  std::string m_name;
  bool m_modal_block = false;
  std::string m_who;
  const Model* m_model = nullptr;
};

}  // namespace

std::unique_ptr<Reducer> guard_reducer(std::unique_ptr<Reducer> inner, const ReducerInfo& info,
                                       const std::filesystem::path& library) {
  return std::make_unique<GuardedReducer>(std::move(inner), info, library);
}

}  // namespace detail
}  // namespace ecmor
