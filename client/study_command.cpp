// `lensfarm study [--out DIR] [--report FILE] [--quick] [--experiments a,b]`: measures what
// accuracy costs in time (client/study/study.h) and writes docs/accuracy.md's tables and plots.
#include <spdlog/spdlog.h>

#include <filesystem>

#include "client/commands.h"
#include "client/exit_codes.h"
#include "client/study/study.h"

namespace lensfarm::cli {

namespace {
namespace fs = std::filesystem;

// The source tree's scenes/ when this binary runs from its build, else the installed copy
// (<prefix>/share/lensfarm/scenes beside <prefix>/bin/lensfarm), else ./scenes.
std::string defaultScenesDir() {
#ifdef LENSFARM_SOURCE_DIR
  if (fs::is_directory(std::string(LENSFARM_SOURCE_DIR) + "/scenes"))
    return std::string(LENSFARM_SOURCE_DIR) + "/scenes";
#endif
  std::error_code ec;
  const fs::path installed =
      fs::read_symlink("/proc/self/exe", ec).parent_path().parent_path() / "share/lensfarm/scenes";
  if (!ec && fs::is_directory(installed)) return installed.string();
  return "scenes";
}
}  // namespace

Runner addStudyCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("study",
                                 "Measure error against time for estimators, samplers, resolution, "
                                 "depth of field and bounces (writes docs/accuracy.md's content)");
  auto o = std::make_shared<study::StudyOptions>();
  auto experiments = std::make_shared<std::vector<std::string>>();
  o->scenes = defaultScenesDir();
  cmd->add_option("--out", o->out, "Folder for the CSV files, plots and the reference cache")->capture_default_str();
  cmd->add_option("--report", o->report, "The Markdown report (default: OUT/accuracy.md)");
  cmd->add_option("--scenes", o->scenes, "Folder holding cornell-seed.json")->capture_default_str();
  cmd->add_option("--experiments", *experiments,
                  "Some of: convergence, estimate, resolution, dof, bounces, materials, models, optics, denoise, "
                  "adaptive, media")
      ->delimiter(',');
  cmd->add_flag("--quick", o->quick, "Tiny images and budgets: the whole study in seconds (for tests)");
  cmd->add_option("--threads", o->threads, "Threads (default: all cores)")->check(CLI::Range(1u, 4096u));
  return [o, experiments, cmd] {
    o->experiments = std::set<std::string>(experiments->begin(), experiments->end());
    o->command = "lensfarm study";
    for (const auto* opt : cmd->get_options())
      if (opt->count() > 0 && opt->get_name() != "--help") {
        o->command += " " + opt->get_name(false, true).substr(0, opt->get_name(false, true).find(','));
        if (opt->get_expected_min() > 0)
          for (const auto& r : opt->results()) o->command += " " + r;
      }
    // The full study is long: say so, and where it writes, before the first render.
    spdlog::info("study: {} into {} (report {}); {}",
                 o->experiments.empty() ? "every experiment" : "the chosen experiments", o->out.string(),
                 (o->report.empty() ? o->out / "accuracy.md" : o->report).string(),
                 o->quick ? "--quick: about a minute"
                          : "about 10 minutes on 2 cores for all experiments (--quick: about a minute)");
    study::runStudy(*o);
    return kOk;
  };
}

}  // namespace lensfarm::cli
