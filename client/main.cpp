// `lensfarm`: the command-line client. Subcommands: render (one machine), dof (depth-of-field
// table), study and compare, the farm commands submit, status, watch, download, snapshot, cancel,
// delete, archive, pause, resume, approve, update, prefetch, events,
// workers, and help. Without a subcommand it prints the usage; a mistyped one gets a suggestion.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>
#include <map>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "client/commands.h"
#include "client/exit_codes.h"
#include "common/util/error.h"
#include "common/util/spelling.h"
#include "common/util/version.h"

namespace {

using namespace lensfarm;

// "unknown command 'rendr'; did you mean 'render'?" when a command is at most two edits away.
int unknownCommand(const CLI::App& app, const std::string& word) {
  std::vector<std::string> names;
  for (const auto* sub : app.get_subcommands([](const CLI::App*) { return true; })) names.push_back(sub->get_name());
  const std::optional<std::string> nearest = nearestName(word, names);
  std::cerr << "lensfarm: error: unknown command '" << word << "'; "
            << (nearest ? "did you mean '" + *nearest + "'?" : std::string("run 'lensfarm help' for the list")) << "\n";
  return cli::kBadInput;
}

// The top level's help: the commands. (app.help() would describe the subcommand that ran.)
std::string usage(const CLI::App& app) {
  return app.get_formatter()->make_help(&app, app.get_name(), CLI::AppFormatMode::Normal);
}

// `lensfarm help [COMMAND]`: the usage, or the command's own help, on stdout.
int help(const CLI::App& app, const std::string& topic) {
  if (topic.empty()) {
    std::cout << usage(app);
    return cli::kOk;
  }
  for (const auto* sub : app.get_subcommands([](const CLI::App*) { return true; }))
    if (sub->get_name() == topic) {
      std::cout << sub->help(app.get_name());
      return cli::kOk;
    }
  return unknownCommand(app, topic);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"lensfarm: a physically based renderer and render farm", "lensfarm"};
  app.set_version_flag("-v,--version", kRendererVersion);
  app.require_subcommand(0, 1);  // none: the usage, on stderr (see below)
  spdlog::set_pattern("[%H:%M:%S] %^%l%$ %v");
  spdlog::set_default_logger(spdlog::stderr_color_mt("lensfarm"));

  std::map<CLI::App*, cli::Runner> runners;
  for (auto add : {cli::addRenderCommand,  cli::addDofCommand,      cli::addSubmitCommand,   cli::addStatusCommand,
                   cli::addWatchCommand,   cli::addDownloadCommand, cli::addSnapshotCommand, cli::addCancelCommand,
                   cli::addDeleteCommand,  cli::addArchiveCommand,  cli::addPauseCommand,    cli::addResumeCommand,
                   cli::addApproveCommand, cli::addUpdateCommand,   cli::addPrefetchCommand, cli::addEventsCommand,
                   cli::addWorkersCommand, cli::addSlurmCommand,    cli::addStudyCommand,    cli::addCompareCommand,
                   cli::addLensCommand,    cli::addDenoiseCommand,  cli::addBlenderCommand}) {
    cli::Runner run = add(app);
    runners[app.get_subcommands({}).back()] = std::move(run);
  }
  std::string helpTopic;
  auto* helpCommand = app.add_subcommand("help", "Print this list, or a command's flags: lensfarm help COMMAND");
  helpCommand->add_option("command", helpTopic, "The command to explain");
  runners[helpCommand] = [&] { return help(app, helpTopic); };
  // Set after the subcommands, which would otherwise inherit it.
  app.footer(
      "Run 'lensfarm help COMMAND' or 'lensfarm COMMAND --help' for a command's flags; "
      "docs/cli.md has them all.");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ExtrasError& e) {
    // A first word that is no command ("lensfarm rendr ...") is left over by the top level.
    const std::vector<std::string> left = app.remaining(false);
    if (app.get_subcommands().empty() && !left.empty() && left.front() == argv[1] && left.front()[0] != '-')
      return unknownCommand(app, left.front());
    std::cerr << "lensfarm: error: " << e.what() << "\n";
    return cli::kBadInput;
  } catch (const CLI::ParseError& e) {
    std::cerr << "lensfarm: error: " << e.what() << "\n";
    return cli::kBadInput;
  }
  if (app.get_subcommands().empty()) {  // bare `lensfarm`: a mistake in a script, a question at a prompt
    std::cerr << usage(app);
    return cli::kBadInput;
  }

  try {
    return runners.at(app.get_subcommands().front())();
  } catch (const InputError& e) {
    std::cerr << "lensfarm: error: " << e.what() << "\n";
    return cli::kBadInput;
  } catch (const std::exception& e) {
    std::cerr << "lensfarm: failure: " << e.what() << "\n";
    return cli::kFailure;
  }
}
