#include "common/util/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstring>

#include "common/util/error.h"

namespace lensfarm {

namespace fs = std::filesystem;

void writeFileAtomically(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(path.string(), "directory does not exist");
  std::string tmpName = ".";  // hidden, beside the target so that rename() stays atomic
  tmpName += path.filename().string();
  tmpName += ".tmp-";
  tmpName += std::to_string(::getpid());
  const fs::path tmp = dir / tmpName;
  try {
    write(tmp);
    // Flush file contents to disk before the rename makes them visible under the final name.
    const int fd = ::open(tmp.c_str(), O_RDONLY);
    if (fd < 0) throw InputError(path.string(), std::string("cannot reopen: ") + std::strerror(errno));
    ::fsync(fd);
    ::close(fd);
    fs::rename(tmp, path);
    // Make the rename itself durable.
    const int dirFd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
    if (dirFd >= 0) {
      ::fsync(dirFd);
      ::close(dirFd);
    }
  } catch (const InputError&) {
    fs::remove(tmp, ec);
    throw;
  } catch (const std::exception& e) {
    fs::remove(tmp, ec);
    throw InputError(path.string(), std::string("cannot write: ") + e.what());
  }
}

}  // namespace lensfarm
