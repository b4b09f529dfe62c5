// `lensfarm blender install`: installs the Blender add-on "Render on lensfarm" (blender/, its zip
// built and installed with the project) into the user's Blender, enables it and saves Blender's
// preferences, by running Blender itself in the background (docs/blender.md).
//
//   lensfarm blender install [--blender PATH] [--zip render_lensfarm.zip] [--coordinator HOST:PORT]
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "client/commands.h"
#include "client/exit_codes.h"
#include "client/subprocess.h"

namespace lensfarm::cli {

namespace fs = std::filesystem;

namespace {

struct BlenderFlags {
  std::string action;  // "install", the only one so far
  std::string blender = "blender";
  std::string zip;
  std::string coordinator;
};

// The add-on's zip: installed beside the binaries (<prefix>/share/lensfarm/blender), or built beside
// them (build/blender/); empty if neither is there.
fs::path defaultZip() {
  for (const fs::path& candidate : {executableDir() / "../share/lensfarm/blender/render_lensfarm.zip",
                                    executableDir() / "../blender/render_lensfarm.zip"})
    if (fs::is_regular_file(candidate)) return fs::weakly_canonical(candidate);
  return {};
}

// Python for Blender's own interpreter: a string literal of `text` (repr-safe for paths).
std::string pythonString(const std::string& text) {
  std::string out = "'";
  for (const char c : text) {
    if (c == '\\' || c == '\'') out += '\\';
    out += c;
  }
  return out + "'";
}

// The script Blender runs: install (replacing an older copy), enable, set the coordinator if given,
// save the preferences; it prints where the add-on went, or exits 1 saying why.
std::string installScript(const fs::path& zip, const std::string& coordinator) {
  std::string s =
      "import addon_utils, bpy, sys\n"
      "r = bpy.ops.preferences.addon_install(filepath=" +
      pythonString(zip.string()) +
      ", overwrite=True)\n"
      "if r != {'FINISHED'}: print('LENSFARM-FAILED: Blender did not install the zip'); sys.exit(1)\n"
      "mod = addon_utils.enable('render_lensfarm', default_set=True, handle_error=lambda e: print('LENSFARM-FAILED:', "
      "e))\n"
      "if mod is None: sys.exit(1)\n";
  if (!coordinator.empty())
    s += "bpy.context.preferences.addons['render_lensfarm'].preferences.address = " + pythonString(coordinator) + "\n";
  s += "bpy.ops.wm.save_userpref()\n"
       "print('LENSFARM-INSTALLED:', mod.__file__.rsplit('/', 1)[0], 'in Blender', bpy.app.version_string)\n";
  return s;
}

// The line of Blender's output after `tag`, or "" if there is none.
std::string lineAfter(const std::string& out, const std::string& tag) {
  const size_t at = out.find(tag);
  if (at == std::string::npos) return "";
  const size_t from = at + tag.size();
  return out.substr(from, out.find('\n', from) - from);
}

int install(const BlenderFlags& f) {
  const fs::path zip = f.zip.empty() ? defaultZip() : fs::path(f.zip);
  if (zip.empty() || !fs::is_regular_file(zip)) {
    std::fprintf(stderr, "lensfarm: error: --zip %s: no render_lensfarm.zip there (build the project, or give --zip)\n",
                 f.zip.empty() ? "(default)" : f.zip.c_str());
    return kBadInput;
  }
  const CommandResult r =
      runCommand({f.blender, "-b", "--python-exit-code", "1", "--python-expr", installScript(zip, f.coordinator)});
  if (!r.started) {
    std::fprintf(stderr, "lensfarm: error: --blender %s: %s (install Blender, or give its path)\n", f.blender.c_str(),
                 r.error.c_str());
    return kBadInput;
  }
  const std::string installed = lineAfter(r.out, "LENSFARM-INSTALLED:");
  if (r.exitCode != 0 || installed.empty()) {
    const std::string why = lineAfter(r.out, "LENSFARM-FAILED:");
    std::fprintf(stderr, "lensfarm: failure: Blender could not install %s (exit %d)%s%s\n", zip.c_str(), r.exitCode,
                 why.empty() ? "" : ":", why.c_str());
    return kFailure;
  }
  std::printf("installed and enabled Render on lensfarm:%s\n", installed.c_str());
  return kOk;
}

}  // namespace

Runner addBlenderCommand(CLI::App& app) {
  auto* cmd =
      app.add_subcommand("blender", "The Blender add-on: lensfarm blender install (into your Blender, enabled)");
  auto f = std::make_shared<BlenderFlags>();
  cmd->add_option("action", f->action, "What to do: install")->required()->check(CLI::IsMember({"install"}));
  cmd->add_option("--blender", f->blender, "The Blender to install into")->capture_default_str();
  cmd->add_option("--zip", f->zip, "The add-on's zip (default: the one installed or built with this lensfarm)");
  cmd->add_option("--coordinator", f->coordinator, "Also set the add-on's coordinator address HOST:PORT");
  return [f] { return install(*f); };
}

}  // namespace lensfarm::cli
