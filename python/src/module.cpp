// module.cpp: the C++ side of the Python module (ecmor._ecmor). It holds models and run results
// in ecmor's own storage and hands their matrices to Python as read-only views; the Python layer
// (python/ecmor/__init__.py) turns these into SciPy matrices, dicts and exceptions. The GIL is
// released around every computation; SIGINT stops a run at its next safe point, as in the CLI.
#include <fmt/format.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <atomic>
#include <csignal>
#include <cstring>
#include <memory>
#include <type_traits>
#include <variant>

#include "arrays.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/interop/body_export.hpp"
#include "ecmor/interop/fe_geometry.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/driver.hpp"
#include "ecmor/run/history.hpp"
#include "ecmor/version.hpp"

namespace ecmor::python {
namespace {

/// A full (sparse) model; shared so that views and runs keep it alive.
struct FullModel {
  std::shared_ptr<const Model> model;
};

/// A reduced (dense) model, possibly one part of a run's result (aliasing shared_ptr).
struct Reduced {
  std::shared_ptr<const ReducedModel> model;
};

/// A finished (or stopped) run, with the full model it reduced.
struct Run {
  std::shared_ptr<const RunResult> result;
  std::shared_ptr<const Model> model;
};

// ---- models in ------------------------------------------------------------------------------

// The N x N matrices of a full model are sparse, of a reduced one dense; B, C, Cv dense in both.
template <class Mat>
Mat square_from(const py::tuple& input, const std::string& origin) {
  if constexpr (std::is_same_v<Mat, SparseMatrix>) {
    return sparse_from(input, origin);
  } else {
    return dense_from(input, origin);
  }
}

// A model of kind Model (Model or ReducedModel) holding `system`, validated.
template <class Variant, class System>
std::shared_ptr<const Variant> validated(System system, const std::string& origin) {
  auto model = std::make_shared<const Variant>(std::move(system));
  validate(*model, origin);
  return model;
}

template <class Variant, class Mat>
std::shared_ptr<const Variant> second_order_of(const py::tuple& M, const py::tuple& D,
                                               const py::tuple& K, const py::tuple& B,
                                               const py::tuple& C, const py::object& Cv,
                                               const std::string& origin) {
  SecondOrderSystem<Mat> m;
  m.M = square_from<Mat>(M, origin);
  m.D = square_from<Mat>(D, origin);
  m.K = square_from<Mat>(K, origin);
  m.B = dense_from(B, origin);
  m.C = dense_from(C, origin);
  if (!Cv.is_none()) m.Cv = dense_from(Cv.cast<py::tuple>(), origin);
  return validated<Variant>(std::move(m), origin);
}

template <class Variant, class Mat>
std::shared_ptr<const Variant> descriptor_of(const py::tuple& E, const py::tuple& A,
                                             const py::tuple& B, const py::tuple& C,
                                             const std::string& origin) {
  DescriptorSystem<Mat> m;
  m.E = square_from<Mat>(E, origin);
  m.A = square_from<Mat>(A, origin);
  m.B = dense_from(B, origin);
  m.C = dense_from(C, origin);
  return validated<Variant>(std::move(m), origin);
}

FullModel second_order(const py::tuple& M, const py::tuple& D, const py::tuple& K,
                       const py::tuple& B, const py::tuple& C, const py::object& Cv,
                       const std::string& origin) {
  return {second_order_of<Model, SparseMatrix>(M, D, K, B, C, Cv, origin)};
}

FullModel descriptor(const py::tuple& E, const py::tuple& A, const py::tuple& B, const py::tuple& C,
                     const std::string& origin) {
  return {descriptor_of<Model, SparseMatrix>(E, A, B, C, origin)};
}

Reduced reduced_second_order(const py::tuple& M, const py::tuple& D, const py::tuple& K,
                             const py::tuple& B, const py::tuple& C, const py::object& Cv,
                             const std::string& origin) {
  return {second_order_of<ReducedModel, Matrix>(M, D, K, B, C, Cv, origin)};
}

Reduced reduced_descriptor(const py::tuple& E, const py::tuple& A, const py::tuple& B,
                           const py::tuple& C, const std::string& origin) {
  return {descriptor_of<ReducedModel, Matrix>(E, A, B, C, origin)};
}

FullModel load(const std::filesystem::path& path,
               const std::map<std::string, std::string>& variables) {
  ModelSource source{path, variables};
  py::gil_scoped_release release;
  return {std::make_shared<const Model>(load_model(source))};
}

// ---- matrices out -----------------------------------------------------------------------------

// The matrix `name` of a model of either kind, through square() (M, D, K, E, A) or rect() (B, C,
// Cv); KeyError for a name the kind does not have.
template <class SecondOrder, class Descriptor, class Square, class Rect>
py::object named_matrix(const std::variant<SecondOrder, Descriptor>& model, const std::string& name,
                        Square square, Rect rect) {
  if (const auto* so = std::get_if<SecondOrder>(&model)) {
    if (name == "M") return square(so->M);
    if (name == "D") return square(so->D);
    if (name == "K") return square(so->K);
    if (name == "B") return rect(so->B);
    if (name == "C") return rect(so->C);
    if (name == "Cv") return rect(so->Cv);
  } else {
    const auto& ds = std::get<Descriptor>(model);
    if (name == "E") return square(ds.E);
    if (name == "A") return square(ds.A);
    if (name == "B") return rect(ds.B);
    if (name == "C") return rect(ds.C);
  }
  throw py::key_error(name);
}

// ("sparse", (data, indices, indptr), (rows, cols)) or ("dense", array); None for an absent Cv.
py::object full_matrix(const py::object& self, const std::string& name) {
  auto sparse = [&](const SparseMatrix& m) -> py::object {
    return py::make_tuple("sparse", sparse_view(m, self), py::make_tuple(m.rows(), m.cols()));
  };
  auto dense = [&](const Matrix& m) -> py::object {
    if (m.size() == 0) return py::none();
    return py::make_tuple("dense", dense_view(m, self));
  };
  return named_matrix(*self.cast<const FullModel&>().model, name, sparse, dense);
}

// A read-only NumPy array; None for an absent Cv.
py::object reduced_matrix(const py::object& self, const std::string& name) {
  auto dense = [&](const Matrix& m) -> py::object {
    return m.size() == 0 ? py::object(py::none()) : py::object(dense_view(m, self));
  };
  return named_matrix(*self.cast<const Reduced&>().model, name, dense, dense);
}

// ---- plugins ----------------------------------------------------------------------------------

// The CLI's rule: the default directories load with warnings (one broken plugin must not stop the
// others), plugins named by the configuration with errors. Returns the warnings.
std::vector<std::string> load_plugins(Registry& registry,
                                      const std::vector<std::filesystem::path>& defaults,
                                      const std::vector<std::filesystem::path>& requested) {
  std::vector<std::string> warnings;
  for (const auto& dir : defaults)
    for (std::string& problem : registry.load_directory(dir)) warnings.push_back(problem);
  for (const auto& path : requested) {
    if (std::filesystem::is_directory(path)) {
      for (const std::string& problem : registry.load_directory(path)) throw PluginError(problem);
    } else {
      registry.load_plugin(path);
    }
  }
  return warnings;
}

py::list parameter_list(const std::vector<ParameterDoc>& docs) {
  py::list out;
  for (const ParameterDoc& p : docs)
    out.append(py::dict(py::arg("name") = p.name, py::arg("type") = p.type,
                        py::arg("default") = p.default_value,
                        py::arg("description") = p.description));
  return out;
}

py::tuple plugins(const std::vector<std::filesystem::path>& defaults) {
  Registry registry;
  const std::vector<std::string> warnings = load_plugins(registry, defaults, {});
  py::list reducers;
  for (const Registry::Entry& e : registry.entries()) {
    reducers.append(py::dict(
        py::arg("name") = e.info.name, py::arg("version") = e.info.version,
        py::arg("description") = e.info.description, py::arg("second_order") = e.info.second_order,
        py::arg("descriptor") = e.info.descriptor, py::arg("library") = e.library.string(),
        py::arg("parameters") = parameter_list(e.info.parameters)));
  }
  py::dict strategies;
  for (const std::string& name : run_strategy_names())
    strategies[py::str(name)] = parameter_list(run_strategy_options(name));
  py::dict sections;
  for (const std::string& name : option_section_names())
    sections[py::str(name)] = parameter_list(section_options(name));
  return py::make_tuple(reducers, strategies, sections, warnings);
}

// ---- runs -------------------------------------------------------------------------------------

std::atomic<int> g_sigint{0};
static_assert(std::atomic<int>::is_always_lock_free, "the handler needs a lock-free counter");
extern "C" void on_sigint(int) { g_sigint.fetch_add(1); }

/// SIGINT sets a flag for the length of a run (Python's own handler cannot run while the GIL is
/// released); the previous handler comes back afterwards.
class SigintScope {
 public:
  explicit SigintScope(bool install) : m_installed(install) {
    g_sigint = 0;
    if (!m_installed) return;
    struct sigaction action {};
    action.sa_handler = on_sigint;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &m_previous);
  }
  ~SigintScope() {
    if (m_installed) sigaction(SIGINT, &m_previous, nullptr);
  }
  SigintScope(const SigintScope&) = delete;
  SigintScope& operator=(const SigintScope&) = delete;

 private:
  bool m_installed;
  struct sigaction m_previous {};
};

/// Passes each history row to the Python callback (as its history.jsonl line) and stops the run
/// on SIGINT or when the callback raises (its exception is kept and raised after the run).
class Observer final : public RunObserver {
 public:
  explicit Observer(py::object progress) : m_progress(std::move(progress)) {}

  bool on_iteration(const IterationRecord& r) override {
    if (!m_progress.is_none() && m_error.is_none()) {
      py::gil_scoped_acquire gil;
      try {
        m_progress(history_json_line(r));
      } catch (py::error_already_set& e) {
        m_error = e.value();
        m_failed = true;
      }
    }
    return !stop_requested();
  }
  bool stop_requested() override { return g_sigint.load() > 0 || m_failed.load(); }
  void on_finished(const RunSummary&) override {}

  /// The callback's exception (None when it raised none). GIL required.
  py::object error() const { return m_error; }

 private:
  py::object m_progress;
  py::object m_error = py::none();
  std::atomic<bool> m_failed{false};  // m_error is set: read without the GIL
};

// (Run, signalled, callback exception or None, plugin warnings)
py::tuple reduce(const std::string& text, const std::string& name, bool from_file,
                 const py::object& model, const py::object& progress,
                 const std::vector<std::filesystem::path>& plugin_dirs, bool catch_sigint) {
  RunConfig config;
  if (from_file) {
    config = load_run_config(text);
  } else {
    ConfigRequirements requirements;
    requirements.model = model.is_none();
    requirements.output = false;
    requirements.lines = false;
    config = parse_run_config(text, name, requirements);
  }
  Registry registry;
  const std::vector<std::string> warnings = load_plugins(registry, plugin_dirs, config.plugins);
  std::shared_ptr<const Model> full;
  if (!model.is_none()) full = model.cast<const FullModel&>().model;

  Observer observer(progress);
  auto result = std::make_shared<RunResult>();
  bool signalled = false;
  {
    SigintScope sigint(catch_sigint);
    py::gil_scoped_release release;
    if (!full) full = std::make_shared<const Model>(load_model(config.model));
    *result = run_reduction(config, *full, registry, &observer);
    signalled = g_sigint.load() > 0;
  }
  return py::make_tuple(Run{result, full}, signalled, observer.error(), warnings);
}

py::object run_matrix(const py::object& self, const std::string& which) {
  const RunResult& r = *self.cast<const Run&>().result;
  if (!r.model) return py::none();
  return dense_view(which == "V" ? r.model->V : r.model->W, self);
}

Reduced run_reduced(const Run& run) {
  if (!run.result->model) throw py::value_error("the run has no reduced model");
  return {std::shared_ptr<const ReducedModel>(run.result, &run.result->model->model)};
}

void run_save(const Run& run, const std::filesystem::path& dir, const std::string& format) {
  const OutputFormat f = value_of(output_format_names(), format, "format");
  py::gil_scoped_release release;
  write_run_outputs(*run.result, dir, f);
}

py::list run_history(const Run& run) {
  py::list lines;
  for (const IterationRecord& r : run.result->history) lines.append(history_json_line(r));
  return lines;
}

// ---- the reduced elastic body -----------------------------------------------------------------

// Whole numbers only (node ids, directions): a fractional or huge value is an error, not a cast.
long long whole(double v, const std::string& origin, const char* what, Index row) {
  if (!(std::abs(v) < 9.0e15) || v != std::floor(v))
    throw InputError(
        fmt::format("{}: row {}: {} = {}: must be a whole number", origin, row + 1, what, v));
  return static_cast<long long>(v);
}

// nodes: k x 4 (id, x, y, z); dofs: N x 2 (node id, direction 1..6), row r of M in row r.
FeGeometry geometry_from(const py::tuple& nodes, const py::tuple& dofs, Index size,
                         const std::string& origin) {
  const Matrix n = dense_from(nodes, origin);
  const Matrix d = dense_from(dofs, origin);
  if (n.cols() != 4)
    throw InputError(
        fmt::format("{}: nodes has {} columns: must be 4 (id, x, y, z)", origin, n.cols()));
  if (d.cols() != 2)
    throw InputError(fmt::format(
        "{}: dofs has {} columns: must be 2 (node id, direction 1..6), one row per row of M",
        origin, d.cols()));
  FeGeometry g;
  for (Index i = 0; i < n.rows(); ++i)
    g.nodes.push_back({whole(n(i, 0), origin + ": nodes", "id", i), n(i, 1), n(i, 2), n(i, 3)});
  for (Index i = 0; i < d.rows(); ++i)
    g.dofs.push_back({i + 1, whole(d(i, 0), origin + ": dofs", "node", i),
                      static_cast<int>(whole(d(i, 1), origin + ": dofs", "direction", i))});
  validate(g, size, origin);
  return g;
}

py::dict export_body_py(const Run& run, const std::filesystem::path& sid_path,
                        const py::tuple& nodes, const py::tuple& dofs, bool all_nodes,
                        const py::object& mass_model, const std::string& name) {
  const std::string origin = "ecmor.export_body";
  const RunResult& r = *run.result;
  if (!r.model) throw InputError(origin + ": the run produced no reduced model");
  if (!run.model || !std::holds_alternative<SecondOrderModel>(*run.model))
    throw InputError(origin +
                     ": a descriptor model: a multibody body needs the second-order model M, D, K");
  if (!std::holds_alternative<ReducedSecondOrderModel>(r.model->model))
    throw InputError(origin +
                     ": the reduced model is first order: a multibody body needs a second-order "
                     "reduced model");
  BodyExportInput in;
  in.model = std::get<SecondOrderModel>(*run.model);
  in.geometry = geometry_from(nodes, dofs, in.model.size(), origin);
  in.V = r.model->V;
  in.W = r.model->W;
  in.reduced = std::get<ReducedSecondOrderModel>(r.model->model);
  in.all_nodes = all_nodes;
  in.name = name;
  in.header_comment = "SID generated by ecmor (Python)";
  in.origin = origin;
  if (!mass_model.is_none()) {
    const auto t = mass_model.cast<py::tuple>();
    if (t.size() != 3)
      throw InputError(origin +
                       ": mass_model must be (M, nodes, dofs) of the mesh without "
                       "boundary conditions");
    MassModel mm;
    mm.M = sparse_from(t[0].cast<py::tuple>(), origin + ": mass_model");
    mm.geometry = geometry_from(t[1].cast<py::tuple>(), t[2].cast<py::tuple>(), mm.M.rows(),
                                origin + ": mass_model");
    in.mass_model = std::move(mm);
  }
  BodyExport body;
  BodyFiles files;
  {
    py::gil_scoped_release release;
    body = export_body(in);
    files = write_body_files(sid_path, body);
  }
  const BodyInvariants& inv = body.invariants;
  py::dict d;
  d["sid"] = files.sid.string();
  d["json"] = files.json.string();
  d["mat"] = files.mat.string();
  d["mass"] = inv.mass;
  d["center"] =
      py::make_tuple(inv.mc.a0(0) / inv.mass, inv.mc.a0(1) / inv.mass, inv.mc.a0(2) / inv.mass);
  d["J"] = py::array(
      py::cast(std::vector<std::vector<double>>{{inv.J.a0(0, 0), inv.J.a0(0, 1), inv.J.a0(0, 2)},
                                                {inv.J.a0(1, 0), inv.J.a0(1, 1), inv.J.a0(1, 2)},
                                                {inv.J.a0(2, 0), inv.J.a0(2, 1), inv.J.a0(2, 2)}}));
  d["coordinates"] = inv.Me.rows();
  d["run_order"] = body.run_order;
  d["free_motions"] = body.elastic.free_motions;
  d["removed"] = body.elastic.removed;
  d["frame_nodes"] = body.sid.frame.size();
  d["check"] = py::make_tuple(body.check_M, body.check_D, body.check_K);
  d["warnings"] = body.warnings;
  return d;
}

// ---- responses and errors ---------------------------------------------------------------------

py::array_t<Complex> to_array(const std::vector<ComplexMatrix>& h, Index p, Index m) {
  py::array_t<Complex> out({static_cast<py::ssize_t>(h.size()), static_cast<py::ssize_t>(p),
                            static_cast<py::ssize_t>(m)});
  auto w = out.mutable_unchecked<3>();
  for (std::size_t k = 0; k < h.size(); ++k)
    for (Index i = 0; i < p; ++i)
      for (Index j = 0; j < m; ++j)
        w(static_cast<py::ssize_t>(k), static_cast<py::ssize_t>(i), static_cast<py::ssize_t>(j)) =
            h[k](i, j);
  return out;
}

py::array_t<Complex> response_full(const FullModel& model, const std::vector<double>& f_hz,
                                   int threads) {
  std::vector<ComplexMatrix> h;
  {
    py::gil_scoped_release release;
    auto solver = make_shifted_solver(*model.model);
    h = frequency_response(*model.model, *solver, f_hz, threads);
  }
  return to_array(h, outputs_of(*model.model), inputs_of(*model.model));
}

py::array_t<Complex> response_reduced(const Reduced& model, const std::vector<double>& f_hz) {
  std::vector<ComplexMatrix> h;
  {
    py::gil_scoped_release release;
    h = frequency_response(*model.model, f_hz);
  }
  return to_array(h, outputs_of(*model.model), inputs_of(*model.model));
}

py::dict band_error(const FullModel& full, const Reduced& reduced, double f_min_hz, double f_max_hz,
                    const std::string& norm, Index grid_points, int threads) {
  const Band band{f_min_hz, f_max_hz};
  band.validate();
  BandErrorOptions options;
  options.norm = parse_error_norm(norm);
  options.grid_points = grid_points;
  options.verify = ErrorVerify::Dense;
  options.validate();
  if (inputs_of(*full.model) != inputs_of(*reduced.model) ||
      outputs_of(*full.model) != outputs_of(*reduced.model))
    throw InputError(
        fmt::format("the reduced model has {} input(s) and {} output(s), the full model {} and {}",
                    inputs_of(*reduced.model), outputs_of(*reduced.model), inputs_of(*full.model),
                    outputs_of(*full.model)));
  BandError e;
  {
    py::gil_scoped_release release;
    auto solver = make_shifted_solver(*full.model);
    ResponseCache cache(*full.model, *solver, threads);
    BandErrorEstimator estimator(cache, band, options);
    e = estimator.evaluate(*reduced.model);
  }
  py::dict d;
  d["sup_relative"] = e.sup_relative;
  d["f_peak_hz"] = e.f_peak_hz;
  d["norm"] = to_string(e.norm);
  d["hinf_absolute"] = e.hinf_absolute;
  d["h2_absolute"] = e.h2_absolute;
  d["f_hz"] = py::array(py::cast(e.f_hz));
  d["relative"] = py::array(py::cast(e.relative));
  d["relative_spectral"] = py::array(py::cast(e.relative_spectral));
  d["relative_frobenius"] = py::array(py::cast(e.relative_frobenius));
  d["absolute"] = py::array(py::cast(e.absolute));
  d["reference"] = py::array(py::cast(e.reference));
  d["undefined_f_hz"] = e.undefined_f_hz;
  d["sampling"] = e.sampling();
  return d;
}

}  // namespace
}  // namespace ecmor::python

PYBIND11_MODULE(_ecmor, m) {
  namespace py = pybind11;
  using namespace ecmor;
  using namespace ecmor::python;
  m.doc() = "ecmor's C++ core; use the package ecmor, not this module";
  m.attr("version") = ECMOR_VERSION_STRING;
  py::register_exception<ecmor::Error>(m, "Error", PyExc_ValueError);

  py::class_<FullModel>(m, "FullModel")
      .def_property_readonly("kind",
                             [](const FullModel& f) { return to_string(kind_of(*f.model)); })
      .def_property_readonly("N", [](const FullModel& f) { return size_of(*f.model); })
      .def_property_readonly("inputs", [](const FullModel& f) { return inputs_of(*f.model); })
      .def_property_readonly("outputs", [](const FullModel& f) { return outputs_of(*f.model); })
      .def("matrix", &full_matrix);
  py::class_<Reduced>(m, "ReducedModel")
      .def_property_readonly("kind", [](const Reduced& r) { return to_string(kind_of(*r.model)); })
      .def_property_readonly("order", [](const Reduced& r) { return size_of(*r.model); })
      .def_property_readonly("inputs", [](const Reduced& r) { return inputs_of(*r.model); })
      .def_property_readonly("outputs", [](const Reduced& r) { return outputs_of(*r.model); })
      .def("matrix", &reduced_matrix);
  py::class_<Run>(m, "Run")
      .def_property_readonly("summary_json",
                             [](const Run& r) {
                               return r.result->has_outputs ? r.result->summary.to_json()
                                                            : std::string();
                             })
      .def_property_readonly("history", &run_history)
      .def_property_readonly("has_model", [](const Run& r) { return r.result->model.has_value(); })
      .def("reduced", &run_reduced)
      .def("basis", &run_matrix)
      .def("save", &run_save);

  m.def("second_order", &second_order);
  m.def("descriptor", &descriptor);
  m.def("reduced_second_order", &reduced_second_order);
  m.def("reduced_descriptor", &reduced_descriptor);
  m.def("load", &load);
  m.def("plugins", &plugins);
  // The configuration's top-level keys: its sections, then plugins and compress.
  m.def("config_keys", [] {
    std::vector<std::string> keys = option_section_names();
    for (const ParameterDoc& d : top_level_options()) keys.push_back(d.name);
    return keys;
  });
  m.def("reduce", &reduce);
  m.def("response_full", &response_full);
  m.def("response_reduced", &response_reduced);
  m.def("band_error", &band_error);
  m.def("export_body", &export_body_py);
}
