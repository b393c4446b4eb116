// registry.cpp: the reducer registry and the Boost.DLL plugin loader.
//
// Lifetime rule: code from a plugin (a factory's std::function, a reducer's vtable) must never run
// after its library is unmapped. Every registry entry and every reducer created from it therefore
// holds a shared_ptr to the library, declared before the things that use it so that it is
// destroyed last.
#include "ecmor/plugin/registry.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <boost/dll/runtime_symbol_info.hpp>
#include <boost/dll/shared_library.hpp>
#include <cctype>
#include <cstdlib>
#include <map>
#include <system_error>

#include "ecmor/base/error.hpp"
#include "ecmor/plugin/plugin.hpp"
#include "plugin/reducer_guard.hpp"

namespace ecmor {

// The Reducer interface has no source file of its own; its key function lives beside the registry
// so that the vtable and type_info are exported once, from libecmor_core.
Reducer::~Reducer() = default;

namespace {

using Library = std::shared_ptr<boost::dll::shared_library>;

bool is_snake_case(const std::string& name) {
  if (name.empty() || !std::islower(static_cast<unsigned char>(name.front()))) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return std::islower(static_cast<unsigned char>(c)) ||
           std::isdigit(static_cast<unsigned char>(c)) || c == '_';
  });
}

std::string describe_library(const std::filesystem::path& library) {
  return library.empty() ? std::string("the application (added directly)") : library.string();
}

// Boost.DLL reports "load() failed (dlerror system message: <what dlopen said>): <errno text>";
// the dlopen text is the useful part ("invalid ELF header", "undefined symbol: ...").
std::string loader_message(const std::exception& e) {
  const std::string what = e.what();
  const std::string marker = "(dlerror system message: ";
  const auto begin = what.find(marker);
  if (begin == std::string::npos) return what;
  const auto start = begin + marker.size();
  const auto end = what.rfind(')');
  return end == std::string::npos || end < start ? what.substr(start)
                                                 : what.substr(start, end - start);
}

}  // namespace

struct Registry::Impl {
  struct Item {
    Library library;  // first member: destroyed after the factory, whose code it maps
    std::filesystem::path path;
    ReducerFactory factory;
  };
  // Declared first so loaded libraries outlive the items below.
  std::map<std::filesystem::path, Library> libraries;
  std::map<std::string, Item> items;

  // Attribution during load_plugin(): which library add() calls come from, and what they added.
  Library loading;
  std::filesystem::path loading_path;
  std::vector<std::string> added;
};

Registry::Registry() : m_impl(std::make_unique<Impl>()) {}

Registry::~Registry() {
  // Factories before libraries (the member order of Impl guarantees it; made explicit here).
  if (m_impl) m_impl->items.clear();
}

void Registry::add(ReducerFactory factory) {
  const std::string name = factory.info.name;
  const std::string source = describe_library(m_impl->loading_path);
  if (name.empty()) throw PluginError(fmt::format("reducer from {} has an empty name", source));
  if (!is_snake_case(name))
    throw PluginError(fmt::format(
        "reducer '{}' from {}: name must be snake_case (lower-case letters, digits, '_', "
        "starting with a letter): it is the YAML reducer.name",
        name, source));
  if (!factory.create)
    throw PluginError(fmt::format("reducer '{}' from {} has no create function", name, source));
  if (auto it = m_impl->items.find(name); it != m_impl->items.end())
    throw PluginError(fmt::format("reducer '{}' is registered twice: by {} and by {}", name,
                                  describe_library(it->second.path), source));
  m_impl->items.emplace(name,
                        Impl::Item{m_impl->loading, m_impl->loading_path, std::move(factory)});
  m_impl->added.push_back(name);
}

void Registry::load_plugin(const std::filesystem::path& path) {
  std::error_code ec;
  const std::filesystem::path shown = std::filesystem::absolute(path, ec).lexically_normal();
  const std::string prefix = "plugin " + shown.string();
  if (!std::filesystem::exists(path, ec)) throw PluginError(prefix + ": file not found");
  if (std::filesystem::is_directory(path, ec))
    throw PluginError(prefix + ": is a directory, not a shared library");
  // Symlinks and relative spellings of one file are one plugin.
  const std::filesystem::path canonical = std::filesystem::canonical(path, ec);
  const std::filesystem::path key = ec ? shown : canonical;
  if (m_impl->libraries.count(key) != 0) return;

  Library library;
  try {
    // rtld_now: an unresolved symbol fails here, with the loader's message, not mid-run.
    library = std::make_shared<boost::dll::shared_library>(
        key, boost::dll::load_mode::rtld_now | boost::dll::load_mode::rtld_local);
  } catch (const std::exception& e) {
    throw PluginError(prefix + ": is not a loadable shared library: " + loader_message(e));
  }

  for (const char* symbol :
       {"ecmor_plugin_abi_version", "ecmor_plugin_build_info", "ecmor_plugin_register"})
    if (!library->has(symbol))
      throw PluginError(fmt::format("{}: is not an ecmor plugin (no {} symbol)", prefix, symbol));

  const int abi = library->get<int()>("ecmor_plugin_abi_version")();
  if (abi != ECMOR_PLUGIN_ABI_VERSION) {
    const char* info = library->get<const char*()>("ecmor_plugin_build_info")();
    throw PluginError(fmt::format(
        "{}: was built for ecmor plugin ABI {} ({}), this ecmor ({}) needs ABI {}: rebuild the "
        "plugin against this ecmor",
        prefix, abi, info != nullptr ? info : "unknown build", ECMOR_VERSION_STRING,
        ECMOR_PLUGIN_ABI_VERSION));
  }

  // Same entry-point ABI is not enough: Eigen objects cross the boundary by value, so a plugin
  // compiled with another Eigen, alignment (-mavx) or string ABI would corrupt memory silently.
  if (!library->has("ecmor_plugin_configuration")) {
    throw PluginError(prefix + ": is not an ecmor plugin (no ecmor_plugin_configuration symbol)");
  }
  const char* configuration = library->get<const char*()>("ecmor_plugin_configuration")();
  const std::string ours = ECMOR_PLUGIN_CONFIGURATION;
  if (configuration == nullptr || ours != configuration) {
    throw PluginError(fmt::format(
        "{}: was compiled with a different configuration ({}) than this ecmor ({}): rebuild it "
        "with the same Eigen and compiler flags (find_package(ecmor) and ecmor_add_plugin do that)",
        prefix, configuration != nullptr ? configuration : "none", ours));
  }

  auto register_function = library->get<void(Registry*)>("ecmor_plugin_register");
  m_impl->loading = library;
  m_impl->loading_path = key;
  m_impl->added.clear();
  std::string failure;
  try {
    register_function(this);
  } catch (const std::exception& e) {
    failure = e.what();
  } catch (...) {
    failure = "unknown exception (not derived from std::exception)";
  }
  // The failure text is copied before the exception object (whose code may live in the plugin)
  // is gone; the roll-back below runs the factories' destructors while the library is mapped.
  m_impl->loading.reset();
  m_impl->loading_path.clear();
  if (!failure.empty()) {
    for (const std::string& name : m_impl->added) m_impl->items.erase(name);
    m_impl->added.clear();
    throw PluginError(prefix + ": registration failed: " + failure);
  }
  m_impl->added.clear();
  m_impl->libraries.emplace(key, std::move(library));
}

std::vector<std::string> Registry::load_directory(const std::filesystem::path& dir) {
  std::vector<std::string> errors;
  std::error_code ec;
  if (!std::filesystem::exists(dir, ec)) return errors;
  if (!std::filesystem::is_directory(dir, ec)) {
    errors.push_back("plugin directory " + dir.string() + ": is not a directory");
    return errors;
  }
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec))
    if (entry.path().extension() == ".so" && !entry.is_directory()) files.push_back(entry.path());
  if (ec) errors.push_back("plugin directory " + dir.string() + ": " + ec.message());
  // Name order makes which plugin wins a name clash (the first) reproducible.
  std::sort(files.begin(), files.end());
  for (const auto& file : files) {
    try {
      load_plugin(file);
    } catch (const std::exception& e) {
      errors.push_back(e.what());
    }
  }
  return errors;
}

std::vector<Registry::Entry> Registry::entries() const {
  std::vector<Entry> out;
  for (const auto& [name, item] : m_impl->items) out.push_back({item.factory.info, item.path});
  return out;
}

std::vector<std::string> Registry::names() const {
  std::vector<std::string> out;
  for (const auto& [name, item] : m_impl->items) out.push_back(name);
  return out;
}

bool Registry::contains(const std::string& name) const { return m_impl->items.count(name) != 0; }

std::shared_ptr<Reducer> Registry::create(const std::string& name,
                                          const ParameterMap& params) const {
  auto it = m_impl->items.find(name);
  if (it == m_impl->items.end()) {
    const std::vector<std::string> known = names();
    if (known.empty())
      throw ConfigError(
          fmt::format("unknown reducer '{}': no reducers are registered (no plugins loaded; check "
                      "$ECMOR_PLUGIN_PATH or the 'plugins' list)",
                      name));
    const std::string near = nearest(name, known);
    throw ConfigError(fmt::format("unknown reducer '{}'{}; registered reducers: {}", name,
                                  near.empty() ? "" : " (did you mean '" + near + "'?)",
                                  fmt::join(known, ", ")));
  }
  const Impl::Item& item = it->second;
  std::unique_ptr<Reducer> reducer = item.factory.create(params);
  if (!reducer)
    throw PluginError(fmt::format("reducer '{}' from {}: create() returned no reducer", name,
                                  describe_library(item.path)));
  params.check_unused();
  // Every call into the plugin goes through the boundary checks (reducer_guard.hpp).
  reducer = detail::guard_reducer(std::move(reducer), item.factory.info, item.path);
  // The deleter runs the plugin's destructor, then releases its copy of the library handle: the
  // code stays mapped for as long as the reducer lives, even after the Registry is gone.
  Library library = item.library;
  return std::shared_ptr<Reducer>(reducer.release(), [library](Reducer* r) { delete r; });
}

std::vector<std::filesystem::path> default_plugin_directories() {
  std::vector<std::filesystem::path> dirs;
  if (const char* env = std::getenv("ECMOR_PLUGIN_PATH")) {
    const std::string list = env;
    std::size_t start = 0;
    while (start <= list.size()) {
      std::size_t end = list.find(':', start);
      if (end == std::string::npos) end = list.size();
      if (end > start) dirs.emplace_back(list.substr(start, end - start));
      start = end + 1;
    }
  }
  std::error_code ec;
  std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) {
    try {
      exe = boost::dll::program_location();
    } catch (const std::exception&) {
      exe.clear();  // no way to find the executable: only $ECMOR_PLUGIN_PATH applies
    }
  }
  if (!exe.empty())
    dirs.push_back((exe.parent_path() / ".." / "lib" / "ecmor" / "plugins").lexically_normal());
  return dirs;
}

}  // namespace ecmor
