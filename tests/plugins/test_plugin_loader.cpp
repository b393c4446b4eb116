// The Boost.DLL plugin loader: every way a plugin can be broken gets a PluginError naming the path
// and the cause, nothing half-registered survives a failure, and reducers keep their code mapped.
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/plugin/plugin.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/version.hpp"

namespace fs = std::filesystem;
using namespace ecmor;

namespace {

fs::path fixture(const std::string& name) {
  return fs::path(ECMOR_TEST_FIXTURE_DIR) / ("libecmor_test_plugin_" + name + ".so");
}

// Whether the dynamic loader currently has `path` mapped (RTLD_NOLOAD never loads it).
bool is_loaded(const fs::path& path) {
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_NOLOAD);
  if (handle == nullptr) return false;
  dlclose(handle);
  return true;
}

// Catches E and returns its message; fails the test if nothing (or something else) is thrown.
using test::message_of;

// A 4 x 4 second-order model with distinct entries so that a wrong projection shows.
SecondOrderModel small_model() {
  Matrix M = Matrix::Identity(4, 4) * 2.0;
  Matrix K(4, 4);
  K << 4, -1, 0, 0, -1, 5, -2, 0, 0, -2, 6, -3, 0, 0, -3, 7;
  Matrix D = 0.1 * M + 0.01 * K;
  SecondOrderModel model;
  model.M = M.sparseView();
  model.D = D.sparseView();
  model.K = K.sparseView();
  model.B = Matrix::Ones(4, 1);
  model.C = Matrix::Ones(1, 4);
  return model;
}

class PluginLoader : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    m_tmp = fs::temp_directory_path() /
            ("ecmor_loader_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(m_tmp);
    fs::create_directories(m_tmp);
  }
  void TearDown() override { fs::remove_all(m_tmp); }
  fs::path m_tmp;
};

TEST_F(PluginLoader, GoodPluginRegistersAndItsReducerProjects) {
  Registry registry;
  registry.load_plugin(fixture("good"));
  ASSERT_TRUE(registry.contains("test_identity"));
  ASSERT_EQ(registry.entries().size(), 1u);
  EXPECT_EQ(registry.entries()[0].library, fs::canonical(fixture("good")));
  EXPECT_EQ(registry.entries()[0].info.parameters.at(0).name, "offset");

  ParameterMap params("reducer 'test_identity'");
  params.set("offset", 1);
  auto reducer = registry.create("test_identity", params);
  const Model model = small_model();
  reducer->setup({&model, nullptr, Band{1.0, 10.0}});
  const ReducerResult result = reducer->reduce({2, {}});
  // V = [e_1 e_2] selects rows/columns 1..2: the reduced matrices are those blocks exactly.
  const auto& full = std::get<SecondOrderModel>(model);
  const auto& red = std::get<ReducedSecondOrderModel>(result.model);
  EXPECT_EQ(Matrix(red.K), Matrix(full.K).block(1, 1, 2, 2));
  EXPECT_EQ(Matrix(red.M), Matrix(full.M).block(1, 1, 2, 2));
  EXPECT_EQ(red.B, full.B.middleRows(1, 2));
  EXPECT_EQ(reducer->max_order(), 3);
}

TEST_F(PluginLoader, LoadingTheSameFileTwiceIsANoOp) {
  Registry registry;
  registry.load_plugin(fixture("good"));
  EXPECT_NO_THROW(registry.load_plugin(fixture("good")));
  // Another spelling of the same file (through a symlink) is still the same plugin.
  fs::create_symlink(fixture("good"), m_tmp / "liblink.so");
  EXPECT_NO_THROW(registry.load_plugin(m_tmp / "liblink.so"));
  EXPECT_EQ(registry.names(), std::vector<std::string>{"test_identity"});
}

TEST_F(PluginLoader, MissingFileIsNamed) {
  Registry registry;
  const fs::path missing = m_tmp / "libnothing.so";
  EXPECT_EQ(message_of<PluginError>([&] { registry.load_plugin(missing); }),
            "plugin " + missing.string() + ": file not found");
}

TEST_F(PluginLoader, TextFileIsNotALoadableLibrary) {
  Registry registry;
  const fs::path text = m_tmp / "libtext.so";
  std::ofstream(text) << std::string(200, 'x') << "\nthis is a text file, not an ELF object\n";
  const std::string msg = message_of<PluginError>([&] { registry.load_plugin(text); });
  EXPECT_NE(msg.find("plugin " + text.string() + ": is not a loadable shared library: "),
            std::string::npos)
      << msg;
  // The dynamic loader's own diagnosis is passed on.
  EXPECT_NE(msg.find("invalid ELF header"), std::string::npos) << msg;
  EXPECT_TRUE(registry.names().empty());
}

TEST_F(PluginLoader, DirectoryIsNotALibrary) {
  Registry registry;
  const std::string msg = message_of<PluginError>([&] { registry.load_plugin(m_tmp); });
  EXPECT_NE(msg.find(m_tmp.string() + ": is a directory"), std::string::npos) << msg;
}

TEST_F(PluginLoader, SharedLibraryWithoutEntryPointsIsNotAnEcmorPlugin) {
  Registry registry;
  const fs::path path = fixture("not_ecmor");
  EXPECT_EQ(
      message_of<PluginError>([&] { registry.load_plugin(path); }),
      "plugin " + path.string() + ": is not an ecmor plugin (no ecmor_plugin_abi_version symbol)");
}

TEST_F(PluginLoader, AbiMismatchNamesBothVersions) {
  Registry registry;
  const fs::path path = fixture("wrong_abi");
  // The fixture's registration function throws if called: the check must come first.
  EXPECT_EQ(message_of<PluginError>([&] { registry.load_plugin(path); }),
            "plugin " + path.string() +
                ": was built for ecmor plugin ABI 0 (ecmor 0.0.1, g++ 10.2.1, cxx11-abi 1), this "
                "ecmor (" ECMOR_VERSION_STRING ") needs ABI " +
                std::to_string(ECMOR_PLUGIN_ABI_VERSION) +
                ": rebuild the plugin against this ecmor");
  EXPECT_TRUE(registry.names().empty());
}

// Same entry-point ABI, other Eigen configuration: refused before registration, naming both.
TEST_F(PluginLoader, ConfigurationMismatchNamesBothConfigurations) {
  Registry registry;
  const fs::path path = fixture("wrong_config");
  const std::string msg = message_of<PluginError>([&] { registry.load_plugin(path); });
  EXPECT_NE(msg.find(path.string() + ": was compiled with a different configuration (eigen 3.3.7, "
                                     "max-align 32"),
            std::string::npos)
      << msg;
  EXPECT_NE(msg.find(std::string("than this ecmor (") + ECMOR_PLUGIN_CONFIGURATION + ")"),
            std::string::npos)
      << msg;
  EXPECT_TRUE(registry.names().empty());
}

TEST_F(PluginLoader, ThrowingRegistrationIsRolledBack) {
  Registry registry;
  const fs::path path = fixture("throws");
  EXPECT_EQ(message_of<PluginError>([&] { registry.load_plugin(path); }),
            "plugin " + path.string() + ": registration failed: boom");
  // The reducer it registered before throwing must not survive.
  EXPECT_FALSE(registry.contains("test_half_registered"));
  EXPECT_TRUE(registry.names().empty());
  // A failed plugin does not count as loaded: trying again reports the same failure.
  EXPECT_THROW(registry.load_plugin(path), PluginError);
}

TEST_F(PluginLoader, DuplicateNamesAcrossLibrariesNameBoth) {
  Registry registry;
  const fs::path copy = m_tmp / "libcopy.so";
  fs::copy_file(fixture("good"), copy);
  registry.load_plugin(fixture("good"));
  const std::string msg = message_of<PluginError>([&] { registry.load_plugin(copy); });
  EXPECT_NE(msg.find("plugin " + copy.string() +
                     ": registration failed: reducer "
                     "'test_identity' is registered twice: by " +
                     fs::canonical(fixture("good")).string() + " and by " + copy.string()),
            std::string::npos)
      << msg;
  // The first registration stays and still works.
  ASSERT_EQ(registry.entries().size(), 1u);
  EXPECT_EQ(registry.entries()[0].library, fs::canonical(fixture("good")));
}

TEST_F(PluginLoader, DuplicateOfDirectlyAddedReducer) {
  Registry registry;
  ReducerFactory factory;
  factory.info.name = "test_identity";
  factory.create = [](const ParameterMap&) -> std::unique_ptr<Reducer> { return nullptr; };
  registry.add(factory);
  const std::string msg = message_of<PluginError>([&] { registry.load_plugin(fixture("good")); });
  EXPECT_NE(msg.find("'test_identity' is registered twice: by the application (added directly) "
                     "and by " +
                     fs::canonical(fixture("good")).string()),
            std::string::npos)
      << msg;
  // Adding it directly a second time names the application twice.
  EXPECT_THROW(registry.add(factory), PluginError);
}

TEST_F(PluginLoader, AddRejectsInvalidNames) {
  Registry registry;
  ReducerFactory factory;
  factory.create = [](const ParameterMap&) -> std::unique_ptr<Reducer> { return nullptr; };
  factory.info.name = "";
  EXPECT_NE(message_of<PluginError>([&] { registry.add(factory); }).find("empty name"),
            std::string::npos);
  for (const char* bad : {"Modal", "my-reducer", "2sided", "a b"}) {
    factory.info.name = bad;
    const std::string msg = message_of<PluginError>([&] { registry.add(factory); });
    EXPECT_NE(msg.find(std::string("reducer '") + bad + "'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("snake_case"), std::string::npos) << msg;
  }
  factory.info.name = "fine_name_2";
  factory.create = nullptr;
  EXPECT_NE(message_of<PluginError>([&] { registry.add(factory); }).find("no create function"),
            std::string::npos);
  EXPECT_TRUE(registry.names().empty());
}

TEST_F(PluginLoader, LoadDirectoryCollectsErrorsInNameOrder) {
  // a_ .. e_ prefixes fix the name order independently of the fixture names.
  fs::copy_file(fixture("wrong_abi"), m_tmp / "liba_wrong_abi.so");
  fs::copy_file(fixture("good"), m_tmp / "libb_good.so");
  fs::copy_file(fixture("throws"), m_tmp / "libc_throws.so");
  fs::copy_file(fixture("not_ecmor"), m_tmp / "libd_not_ecmor.so");
  std::ofstream(m_tmp / "libe_text.so") << std::string(100, '#') << " not a library\n";
  std::ofstream(m_tmp / "README.txt") << "ignored: not a .so\n";
  fs::create_directory(m_tmp / "subdir.so");  // directories are skipped, not descended into

  Registry registry;
  const std::vector<std::string> errors = registry.load_directory(m_tmp);
  ASSERT_EQ(errors.size(), 4u);
  EXPECT_NE(errors[0].find("liba_wrong_abi.so: was built for ecmor plugin ABI 0"),
            std::string::npos);
  EXPECT_NE(errors[1].find("libc_throws.so: registration failed: boom"), std::string::npos);
  EXPECT_NE(errors[2].find("libd_not_ecmor.so: is not an ecmor plugin"), std::string::npos);
  EXPECT_NE(errors[3].find("libe_text.so: is not a loadable shared library"), std::string::npos);
  EXPECT_EQ(registry.names(), std::vector<std::string>{"test_identity"});
  EXPECT_EQ(registry.entries()[0].library, fs::canonical(m_tmp / "libb_good.so"));

  // A missing directory is not an error (default directories need not exist).
  EXPECT_TRUE(registry.load_directory(m_tmp / "does_not_exist").empty());
  // A file where a directory is expected is.
  const std::vector<std::string> file_errors = registry.load_directory(m_tmp / "README.txt");
  ASSERT_EQ(file_errors.size(), 1u);
  EXPECT_NE(file_errors[0].find("README.txt: is not a directory"), std::string::npos);
}

TEST_F(PluginLoader, CreateWithUnknownNameListsRegisteredOnes) {
  Registry empty;
  const std::string none =
      message_of<ConfigError>([&] { (void)empty.create("modal", ParameterMap()); });
  EXPECT_NE(none.find("unknown reducer 'modal': no reducers are registered"), std::string::npos)
      << none;

  Registry registry;
  registry.load_plugin(fixture("good"));
  EXPECT_EQ(message_of<ConfigError>([&] { (void)registry.create("test_identiy", ParameterMap()); }),
            "unknown reducer 'test_identiy' (did you mean 'test_identity'?); registered reducers: "
            "test_identity");
  EXPECT_EQ(message_of<ConfigError>([&] { (void)registry.create("krylov", ParameterMap()); }),
            "unknown reducer 'krylov'; registered reducers: test_identity");
}

TEST_F(PluginLoader, CreateChecksParameters) {
  Registry registry;
  registry.load_plugin(fixture("good"));

  ParameterMap typo("reducer 'test_identity'");
  typo.set("ofset", ParameterValue{2LL, "run.yaml:7"});
  EXPECT_EQ(message_of<ConfigError>([&] { (void)registry.create("test_identity", typo); }),
            "run.yaml:7: unknown key 'ofset' in reducer 'test_identity' (did you mean "
            "'offset'?)");

  ParameterMap negative("reducer 'test_identity'");
  negative.set("offset", ParameterValue{-3LL, "run.yaml:8"});
  EXPECT_EQ(message_of<ConfigError>([&] { (void)registry.create("test_identity", negative); }),
            "run.yaml:8: reducer 'test_identity': offset = -3: must be >= 0");
}

TEST_F(PluginLoader, ReducerKeepsItsLibraryLoadedAfterTheRegistryIsGone) {
  const fs::path path = fs::canonical(fixture("good"));
  ASSERT_FALSE(is_loaded(path)) << "an earlier test leaked a handle to the fixture";
  std::shared_ptr<Reducer> reducer;
  {
    Registry registry;
    registry.load_plugin(path);
    EXPECT_TRUE(is_loaded(path));
    reducer = registry.create("test_identity", ParameterMap());
  }
  // The registry is destroyed; the reducer's code (vtable, reduce()) must still be mapped.
  EXPECT_TRUE(is_loaded(path));
  const Model model = small_model();
  reducer->setup({&model, nullptr, Band{1.0, 10.0}});
  const ReducerResult result = reducer->reduce({3, {}});
  EXPECT_EQ(result.V, Matrix::Identity(4, 3));
  EXPECT_EQ(result.note, "identity");
  // Destroying the last reducer releases the last handle: the library is unmapped.
  reducer.reset();
  EXPECT_FALSE(is_loaded(path));
}

TEST(PluginDirectories, EnvironmentFirstThenNextToTheExecutable) {
  ASSERT_EQ(::setenv("ECMOR_PLUGIN_PATH", "/opt/a::/opt/b:", 1), 0);
  const std::vector<fs::path> dirs = default_plugin_directories();
  ::unsetenv("ECMOR_PLUGIN_PATH");
  ASSERT_EQ(dirs.size(), 3u);  // empty entries are skipped
  EXPECT_EQ(dirs[0], "/opt/a");
  EXPECT_EQ(dirs[1], "/opt/b");
  // Tests live in build/bin, plugins in build/lib/ecmor/plugins: the install layout.
  EXPECT_EQ(dirs[2], fs::path(ECMOR_TEST_PLUGIN_DIR).lexically_normal());

  const std::vector<fs::path> plain = default_plugin_directories();
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_EQ(plain[0], dirs[2]);
}

}  // namespace
