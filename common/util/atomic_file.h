#pragma once
// Writing output files so that a reader never sees a partial one: write to a temporary file in
// the same directory, fsync, then rename over the target (atomic on POSIX file systems).
//
// The temporary of `dir/NAME` is `dir/.NAME.tmp-PID`, PID being the writer's process id. A writer
// killed mid-write (SIGKILL, a crash, a power cut) leaves its temporary behind; the next write of
// the same target removes it, and removeStaleTemporaries clears a whole directory. A temporary is
// stale when its PID is not a live process on this machine (kill(PID, 0) fails with ESRCH); one of
// a live process is never removed, since that writer may still be writing it. PIDs are per machine:
// on a file system shared by several machines (NFS), a temporary that a live process of another
// machine is writing is removed if its PID is dead here; that writer then fails rather than
// publishing a partial file (its reopen or rename finds no temporary).
#include <filesystem>
#include <functional>

namespace lensfarm {

// Calls write(tmpPath) and then publishes tmpPath as `path`. If write throws, the temporary file
// is removed and `path` is untouched. Throws InputError naming `path` if it cannot be written; when
// write fails with errno set (a full disk), the message ends with its text, e.g.
// "cannot write: write failed (No space left on device)". Before writing, removes the stale
// temporaries of `path` (`.NAME.tmp-PID` with a dead PID; see above), ignoring errors.
void writeFileAtomically(const std::filesystem::path& path,
                         const std::function<void(const std::filesystem::path& tmpPath)>& write);

// Removes every stale temporary (`.ANYTHING.tmp-PID` with a dead PID; see above) in `dir`, and in
// its subdirectories if `recursive` (symbolic links to directories are not followed). For a service
// at start, on a directory it owns. Best effort: errors are ignored, and it never throws.
void removeStaleTemporaries(const std::filesystem::path& dir, bool recursive);

}  // namespace lensfarm
