// Checks of command-line flag values (flag_checks.h).
#include "common/util/flag_checks.h"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <optional>

namespace lensfarm {

namespace {

// The whole of `text` as a finite number, or nothing.
std::optional<double> finiteNumber(const std::string& text) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return std::nullopt;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::string withUnit(const std::string& number, const std::string& unit) {
  return unit.empty() ? number : number + " " + unit;
}

}  // namespace

CLI::Validator positiveNumber(const std::string& unit) {
  return CLI::Validator(
      [unit](std::string& text) -> std::string {
        const auto v = finiteNumber(text);
        if (!v) return fmt::format("expected a number{}, got \"{}\"", unit.empty() ? "" : " of " + unit, text);
        if (*v <= 0.0) return fmt::format("must be more than {}, got {}", withUnit("0", unit), text);
        return "";
      },
      "> 0");
}

CLI::Validator nonNegativeNumber(const std::string& unit) {
  return CLI::Validator(
      [unit](std::string& text) -> std::string {
        const auto v = finiteNumber(text);
        if (!v) return fmt::format("expected a number{}, got \"{}\"", unit.empty() ? "" : " of " + unit, text);
        if (*v < 0.0) return fmt::format("must be {} or more, got {}", withUnit("0", unit), text);
        return "";
      },
      ">= 0");
}

CLI::Validator numberIn(double lo, double hi, const std::string& unit) {
  const std::string range = fmt::format("from {} to {}", lo, withUnit(fmt::format("{}", hi), unit));
  return CLI::Validator(
      [range, lo, hi](std::string& text) -> std::string {
        const auto v = finiteNumber(text);
        if (!v) return fmt::format("expected a number {}, got \"{}\"", range, text);
        if (*v < lo || *v > hi) return fmt::format("must be {}, got {}", range, text);
        return "";
      },
      fmt::format("in [{}, {}]", lo, hi));
}

CLI::Validator wholeNumberIn(uint64_t lo, uint64_t hi) {
  const std::string range = fmt::format("a whole number from {} to {}", lo, hi);
  return CLI::Validator(
      [range, lo, hi](std::string& text) -> std::string {
        uint64_t v = 0;
        const char* end = text.data() + text.size();
        const auto [ptr, ec] = std::from_chars(text.data(), end, v);
        // Digits only (from_chars takes no sign, space or fraction); too many is out of range.
        if (!text.empty() && ptr == end && ec == std::errc() && v >= lo && v <= hi) return "";
        if (finiteNumber(text)) return fmt::format("must be {}, got {}", range, text);
        return fmt::format("expected {}, got \"{}\"", range, text);
      },
      fmt::format("in [{}, {}]", lo, hi));
}

CLI::Validator durationIn(double lo, double hi) {
  // Units are CLI11's own transform; the check around it says what a duration looks like.
  const auto toSeconds = std::make_shared<CLI::AsNumberWithUnit>(
      std::map<std::string, double>{{"ms", 1e-3}, {"s", 1.0}, {"m", 60.0}, {"h", 3600.0}});
  return CLI::Validator(
      [toSeconds, lo, hi](std::string& text) -> std::string {
        std::string seconds = text;
        std::string error;
        try {
          error = (*toSeconds)(seconds);
        } catch (const CLI::Error& e) {
          error = e.what();
        }
        const auto v = error.empty() ? finiteNumber(seconds) : std::nullopt;
        if (!v) return fmt::format("expected a duration such as 45, 90s, 10m or 2h, got \"{}\"", text);
        if (*v <= 0.0) return fmt::format("must be more than 0 seconds, got {}", text);
        if (*v < lo || *v > hi) return fmt::format("must be from {} to {} seconds, got {}", lo, hi, text);
        text = seconds;
        return "";
      },
      "DURATION");
}

}  // namespace lensfarm
