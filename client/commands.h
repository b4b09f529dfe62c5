#pragma once
// The `lensfarm` subcommands. Each registers its flags on the CLI11 app and returns a runner.
#include <CLI/CLI.hpp>
#include <functional>

namespace lensfarm::cli {

using Runner = std::function<int()>;

Runner addRenderCommand(CLI::App& app);
Runner addDofCommand(CLI::App& app);
Runner addSubmitCommand(CLI::App& app);
Runner addStatusCommand(CLI::App& app);
Runner addWatchCommand(CLI::App& app);
Runner addDownloadCommand(CLI::App& app);
Runner addSnapshotCommand(CLI::App& app);
Runner addCancelCommand(CLI::App& app);
Runner addDeleteCommand(CLI::App& app);
Runner addArchiveCommand(CLI::App& app);
Runner addPauseCommand(CLI::App& app);
Runner addResumeCommand(CLI::App& app);
Runner addApproveCommand(CLI::App& app);
Runner addUpdateCommand(CLI::App& app);
Runner addPrefetchCommand(CLI::App& app);
Runner addEventsCommand(CLI::App& app);
Runner addWorkersCommand(CLI::App& app);
Runner addSlurmCommand(CLI::App& app);
Runner addStudyCommand(CLI::App& app);
Runner addCompareCommand(CLI::App& app);
Runner addLensCommand(CLI::App& app);
Runner addDenoiseCommand(CLI::App& app);
Runner addBlenderCommand(CLI::App& app);

}  // namespace lensfarm::cli
