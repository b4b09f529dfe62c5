#include "common/util/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "common/util/error.h"

namespace lensfarm {

namespace fs = std::filesystem;

namespace {

constexpr const char* kTmpMark = ".tmp-";  // a temporary is "." + target name + kTmpMark + PID

// The PID spelled by `digits` as std::to_string spells one (decimal digits only, no leading zero,
// at most 9 of them), or 0: a name this code did not make is never taken for a temporary.
pid_t pidOf(const std::string& digits) {
  if (digits.empty() || digits.size() > 9 || digits[0] == '0') return 0;
  pid_t pid = 0;
  for (const char c : digits) {
    if (c < '0' || c > '9') return 0;
    pid = pid * 10 + (c - '0');
  }
  return pid;
}

// The PID of a temporary named `.ANYTHING.tmp-PID` (ANYTHING not empty), or 0 if `name` is not one.
pid_t temporaryPid(const std::string& name) {
  const size_t mark = name.rfind(kTmpMark);
  if (name.empty() || name[0] != '.' || mark == std::string::npos || mark < 2) return 0;
  return pidOf(name.substr(mark + std::strlen(kTmpMark)));
}

// No process has this PID on this machine (EPERM would mean one exists, of another user).
bool processIsGone(pid_t pid) { return ::kill(pid, 0) == -1 && errno == ESRCH; }

// Removes `entry` if it is a regular file (not a link, not a directory) and `pid`, its writer, is
// gone. `pid` 0 means "not a temporary": kept. Never throws.
void removeIfStale(const fs::directory_entry& entry, pid_t pid) {
  std::error_code ec;
  if (pid > 0 && fs::is_regular_file(entry.symlink_status(ec)) && processIsGone(pid)) fs::remove(entry.path(), ec);
}

// Removes the stale temporaries of one target: `prefix` + PID in `dir`, PID gone. Best effort.
void removeStaleTemporariesOf(const fs::path& dir, const std::string& prefix) noexcept {
  try {
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (name.size() > prefix.size() && name.compare(0, prefix.size(), prefix) == 0)
        removeIfStale(*it, pidOf(name.substr(prefix.size())));
    }
  } catch (...) {  // an allocation failing: the temporaries stay, the write goes on
  }
}

// `what`, followed by the text of errno `err` when there is one and `what` does not give it yet.
std::string withErrnoText(std::string what, int err) {
  if (err == 0) return what;
  const std::string text = std::strerror(err);
  if (what.find(text) == std::string::npos) what += " (" + text + ")";
  return what;
}

// Flushes `tmp` to disk, renames it to `path` and makes the rename durable: once the name is
// visible, so are all its bytes.
void publish(const fs::path& tmp, const fs::path& path, const fs::path& dir) {
  const int fd = ::open(tmp.c_str(), O_RDONLY);
  if (fd < 0) throw InputError(path.string(), std::string("cannot reopen: ") + std::strerror(errno));
  ::fsync(fd);
  ::close(fd);
  fs::rename(tmp, path);
  const int dirFd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dirFd >= 0) {
    ::fsync(dirFd);
    ::close(dirFd);
  }
}

}  // namespace

void writeFileAtomically(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(path.string(), "directory does not exist");
  // Hidden, beside the target so that rename() stays atomic; the PID tells whether it is stale.
  const std::string prefix = "." + path.filename().string() + kTmpMark;
  removeStaleTemporariesOf(dir, prefix);
  const fs::path tmp = dir / (prefix + std::to_string(::getpid()));
  try {
    errno = 0;  // any errno after a failure is then write's own, not the cleanup's ESRCH
    write(tmp);
    publish(tmp, path, dir);
  } catch (const InputError&) {
    fs::remove(tmp, ec);
    throw;
  } catch (const std::exception& e) {
    const int err = errno;  // before anything else can change it
    fs::remove(tmp, ec);
    throw InputError(path.string(), withErrnoText(std::string("cannot write: ") + e.what(), err));
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
}

void removeStaleTemporaries(const fs::path& dir, bool recursive) {
  const auto visit = [](const fs::directory_entry& entry) {
    removeIfStale(entry, temporaryPid(entry.path().filename().string()));
  };
  try {
    std::error_code ec;
    if (!recursive) {
      for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) visit(*it);
      return;
    }
    const auto options = fs::directory_options::skip_permission_denied;  // links are not followed
    for (fs::recursive_directory_iterator it(dir, options, ec), end; !ec && it != end; it.increment(ec)) visit(*it);
  } catch (...) {  // best effort: never throws
  }
}

}  // namespace lensfarm
