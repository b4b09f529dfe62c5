#pragma once
// State files that say when they are damaged. Every file of the state dir that SQLite does not
// hold (a unit's sums, a checkpoint, a job's manifest) ends with a trailer: the SHA-256 of the
// bytes before it and a magic word,
//
//   [payload][SHA-256 of the payload, 32 bytes]["LFCHECK1", 8 bytes]
//
// so a torn write, a truncation or a flipped bit is found when the file is read, not when an
// image comes out different. Files are written atomically (a temporary beside the target,
// fsync, rename, fsync of the directory), and a failed write names the file and errno's text
// (StorageError), so a full disk is told apart from anything else.
#include <cerrno>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace lensfarm {

// A state file could not be written: `code()` is the errno (ENOSPC for a full disk).
class StorageError : public std::runtime_error {
 public:
  StorageError(const std::filesystem::path& file, int code);
  int code() const { return code_; }
  const std::filesystem::path& file() const { return file_; }

 private:
  std::filesystem::path file_;
  int code_;
};

// Writes the pieces one after another and the trailer, without joining them in memory first (a
// checkpoint's pieces are frame-sized). Throws StorageError.
void writeCheckedFile(const std::filesystem::path& path, std::initializer_list<std::string_view> pieces);

// The payload, or nullopt with `damage` saying what is wrong: "missing", "truncated (N bytes)",
// "not a checked file", "checksum mismatch". Never throws for a damaged file.
std::optional<std::string> readCheckedFile(const std::filesystem::path& path, std::string& damage);

// Files the coordinator streams as they are (an archived image, a stored frame: EXR files that
// other tools read) carry their checksum beside them instead, in "<file>.sha256" (the SHA-256 in
// hex), written atomically once the file is: writeChecksumSidecar. Throws StorageError.
void writeChecksumSidecar(const std::filesystem::path& file);
// nullopt if `file` matches its sidecar, or has none (written before sidecars, or a crash came
// between the file and its sidecar); else what is wrong ("checksum mismatch", "missing").
std::optional<std::string> checkChecksumSidecar(const std::filesystem::path& file);
std::filesystem::path sidecarOf(const std::filesystem::path& file);

}  // namespace lensfarm
