#pragma once
// Checks of command-line flag values shared by lensfarm, lensfarm-coordinator and lensfarm-worker.
// Each failure reads as one sentence with the limit and the value given, which CLI11 prefixes
// with the flag: "--time: must be more than 0 seconds, got 0". Numbers must be finite: "nan" and
// "inf" are refused (CLI::Range lets "nan" through, as it compares false). `unit` names what the
// number counts ("seconds"), or is empty.
#include <cstdint>
#include <string>

namespace CLI {
class Validator;
}

namespace lensfarm {

CLI::Validator positiveNumber(const std::string& unit);     // a finite number > 0
CLI::Validator nonNegativeNumber(const std::string& unit);  // a finite number >= 0
CLI::Validator numberIn(double lo, double hi, const std::string& unit = "");
CLI::Validator wholeNumberIn(uint64_t lo, uint64_t hi);  // digits only: no sign, no fraction
// A transform: "45", "90s", "1.5m", "2h" or "250ms" becomes seconds in [lo, hi].
CLI::Validator durationIn(double lo, double hi);

}  // namespace lensfarm
