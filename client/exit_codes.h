#pragma once
// Exit codes of the `lensfarm` command, documented in docs/cli.md.
namespace lensfarm::cli {
inline constexpr int kOk = 0;
inline constexpr int kFailure = 1;       // an unexpected runtime failure
inline constexpr int kImagesDiffer = 1;  // `compare`: the relative RMSE is above the tolerance
inline constexpr int kBadInput =
    2;  // a bad flag, scene file, asset or output path (or a request the coordinator refused as such)
inline constexpr int kUnavailable = 3;    // the coordinator cannot be reached
inline constexpr int kNotFound = 4;       // no such job
inline constexpr int kJobNotDone = 5;     // `watch`: the job ended cancelled or failed
inline constexpr int kNotAllowed = 6;     // missing or wrong token
inline constexpr int kInterrupted = 130;  // Ctrl-C: the whole units so far were written (nothing, if none was done)
}  // namespace lensfarm::cli
