#include "coordinator/store/checked_file.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <fstream>

#include "common/util/hash.h"

namespace lensfarm {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kMagic = "LFCHECK1";
constexpr size_t kDigestBytes = 32, kTrailerBytes = kDigestBytes + 8;  // SHA-256

// Writes all of `bytes` to fd; false with errno set on failure.
bool writeAll(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    bytes.remove_prefix(size_t(n));
  }
  return true;
}

}  // namespace

StorageError::StorageError(const fs::path& file, int code)
    : std::runtime_error("cannot write " + file.string() + ": " + std::strerror(code)), file_(file), code_(code) {}

void writeCheckedFile(const fs::path& path, std::initializer_list<std::string_view> pieces) {
  const fs::path tmp = path.parent_path() / ("." + path.filename().string() + ".tmp-" + std::to_string(::getpid()));
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) throw StorageError(path, errno);
  EVP_MD_CTX* sha = EVP_MD_CTX_new();
  bool ok = sha && EVP_DigestInit_ex(sha, EVP_sha256(), nullptr) == 1;
  for (std::string_view piece : pieces) ok = ok && EVP_DigestUpdate(sha, piece.data(), piece.size()) == 1;
  std::array<unsigned char, kDigestBytes> digest{};
  ok = ok && EVP_DigestFinal_ex(sha, digest.data(), nullptr) == 1;
  EVP_MD_CTX_free(sha);
  if (!ok) errno = EIO;
  for (std::string_view piece : pieces) ok = ok && writeAll(fd, piece);
  ok = ok && writeAll(fd, std::string_view(reinterpret_cast<const char*>(digest.data()), digest.size())) &&
       writeAll(fd, kMagic) && ::fsync(fd) == 0;
  const int code = errno;
  ::close(fd);
  if (!ok || ::rename(tmp.c_str(), path.c_str()) != 0) {
    const int failure = ok ? errno : code;
    ::unlink(tmp.c_str());
    throw StorageError(path, failure);
  }
  // The rename itself made durable.
  if (const int dirFd = ::open(path.parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dirFd >= 0) {
    ::fsync(dirFd);
    ::close(dirFd);
  }
}

std::optional<std::string> readCheckedFile(const fs::path& path, std::string& damage) {
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  if (ec) {
    damage = "missing";
    return std::nullopt;
  }
  std::string bytes(size, '\0');
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  size_t got = 0;
  while (fd >= 0 && got < size) {
    const ssize_t n = ::read(fd, bytes.data() + got, size - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += size_t(n);
  }
  if (fd >= 0) ::close(fd);
  if (fd < 0 || got != size) {
    damage = std::string("unreadable (") + std::strerror(errno) + ")";
    return std::nullopt;
  }
  if (size < kTrailerBytes) {
    damage = "truncated (" + std::to_string(size) + " bytes)";
    return std::nullopt;
  }
  if (std::string_view(bytes).substr(size - kMagic.size()) != kMagic) {
    damage = "truncated or not a checked file (no trailer)";
    return std::nullopt;
  }
  const size_t payload = size - kTrailerBytes;
  std::array<unsigned char, kDigestBytes> digest{};
  if (EVP_Digest(bytes.data(), payload, digest.data(), nullptr, EVP_sha256(), nullptr) != 1 ||
      std::memcmp(digest.data(), bytes.data() + payload, kDigestBytes) != 0) {
    damage = "checksum mismatch";
    return std::nullopt;
  }
  bytes.resize(payload);
  return bytes;
}

fs::path sidecarOf(const fs::path& file) { return fs::path(file.string() + ".sha256"); }

namespace {
// The file's SHA-256 in hex, read in 1 MiB pieces; nullopt if it cannot be read.
std::optional<std::string> fileSha256(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  Sha256 sha;
  std::string buffer(size_t(1) << 20, '\0');
  while (in.read(buffer.data(), std::streamsize(buffer.size())) || in.gcount() > 0)
    sha.update(std::string_view(buffer.data(), size_t(in.gcount())));
  if (in.bad()) return std::nullopt;
  return sha.hexDigest();
}
}  // namespace

void writeChecksumSidecar(const fs::path& file) {
  const std::optional<std::string> digest = fileSha256(file);
  if (!digest) throw StorageError(file, EIO);
  writeCheckedFile(sidecarOf(file), {*digest});
}

std::optional<std::string> checkChecksumSidecar(const fs::path& file) {
  std::string damage;
  if (!fs::exists(sidecarOf(file))) return std::nullopt;
  const std::optional<std::string> expected = readCheckedFile(sidecarOf(file), damage);
  if (!expected) return "its checksum file " + sidecarOf(file).filename().string() + " is " + damage;
  const std::optional<std::string> actual = fileSha256(file);
  if (!actual) return std::string("missing or unreadable");
  if (*actual != *expected) return std::string("checksum mismatch (its bytes are not those written)");
  return std::nullopt;
}

}  // namespace lensfarm
