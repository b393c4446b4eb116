// ecmor: adaptive, error-controlled model order reduction. Parses arguments and dispatches; no
// numerics here.
#include <CLI/CLI.hpp>
#include <iostream>

#include "commands.hpp"
#include "ecmor/version.hpp"

int main(int argc, char** argv) {
  CLI::App cli{"ecmor " ECMOR_VERSION_STRING
               ": error-controlled model order reduction of large sparse second-order and "
               "descriptor models"};
  cli.require_subcommand(1);
  cli.set_version_flag("--version", std::string("ecmor ") + ECMOR_VERSION_STRING);

  ecmor::app::CommonOptions common;
  auto add_common = [&](CLI::App* sub) {
    sub->add_option("--plugin", common.plugin_paths,
                    "extra plugin library or directory (repeatable)");
    sub->add_flag("--no-default-plugins", common.no_default_plugins,
                  "do not load plugins from $ECMOR_PLUGIN_PATH and <prefix>/lib/ecmor/plugins");
    sub->add_flag("-q,--quiet", common.quiet, "print only the final summary line");
  };

  std::filesystem::path config;
  auto* reduce = cli.add_subcommand(
      "reduce", "reduce a model as configured in a YAML file (exit 0: target met, 2: target "
                "missed but a model was written, 1: error, 130: interrupted)");
  reduce->add_option("config", config, "YAML run configuration")->required();
  reduce->add_option("-o,--output", common.output_dir, "output directory (overrides output.dir)");
  add_common(reduce);

  auto* plugins = cli.add_subcommand("plugins", "list the loaded reducers and their parameters");
  add_common(plugins);

  std::filesystem::path model_dir;
  int eigenfrequencies = 10;
  auto* info = cli.add_subcommand(
      "info", "describe a model directory: sizes, nnz, symmetry, definiteness, lowest "
              "eigenfrequencies");
  info->add_option("model_dir", model_dir, "directory with M,D,K,B,C[,Cv].mtx or E,A,B,C.mtx")
      ->required();
  info->add_option("--eigenfrequencies", eigenfrequencies,
                   "how many of the lowest eigenfrequencies to compute (0: none)")
      ->check(CLI::Range(0, 1000));
  add_common(info);

  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 1;
  }
  if (*reduce) return ecmor::app::reduce(config, common);
  if (*plugins) return ecmor::app::plugins(common);
  if (*info) return ecmor::app::info(model_dir, eigenfrequencies, common);
  return 1;
}
