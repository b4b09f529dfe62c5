// `lensfarm`: the command-line client. Subcommands: render (one machine), dof (depth-of-field
// table), and the farm commands submit, status, watch, download, cancel, workers.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>
#include <map>

#include "commands.h"
#include "exit_codes.h"
#include "util/error.h"
#include "util/version.h"

int main(int argc, char** argv) {
  using namespace lensfarm;
  CLI::App app{"lensfarm: a physically based renderer and render farm"};
  app.set_version_flag("--version", kRendererVersion);
  app.require_subcommand(1);
  spdlog::set_pattern("[%H:%M:%S] %^%l%$ %v");
  spdlog::set_default_logger(spdlog::stderr_color_mt("lensfarm"));

  std::map<CLI::App*, cli::Runner> runners;
  for (auto add : {cli::addRenderCommand, cli::addDofCommand, cli::addSubmitCommand, cli::addStatusCommand,
                   cli::addWatchCommand, cli::addDownloadCommand, cli::addSnapshotCommand, cli::addCancelCommand, cli::addWorkersCommand,
                   cli::addStudyCommand, cli::addCompareCommand}) {
    cli::Runner run = add(app);
    runners[app.get_subcommands({}).back()] = std::move(run);
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "lensfarm: error: " << e.what() << "\n";
    return cli::kBadInput;
  }

  try {
    for (auto* sub : app.get_subcommands()) return runners.at(sub)();
  } catch (const InputError& e) {
    std::cerr << "lensfarm: error: " << e.what() << "\n";
    return cli::kBadInput;
  } catch (const std::exception& e) {
    std::cerr << "lensfarm: failure: " << e.what() << "\n";
    return cli::kFailure;
  }
  return cli::kFailure;
}
