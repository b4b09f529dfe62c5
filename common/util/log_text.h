#pragma once
// Text from outside (a worker's name, a job's label, a request path, an error message quoting
// either) made safe to print in a log line or on a terminal: control characters are shown, never
// interpreted. A newline cannot forge a second log line and an escape sequence cannot recolour,
// retitle or clear the terminal of someone reading `lensfarm workers`.
#include <string>
#include <string_view>

namespace lensfarm {

// `text` with C0 controls (U+0000-U+001F), DEL, C1 controls (U+0080-U+009F, which some
// terminals obey in 8-bit mode) and the bidirectional overrides and isolates (U+202A-U+202E,
// U+2066-U+2069, which reorder what is shown) written as \xNN, \u{NNNN}, \n, \r or \t; a backslash
// is doubled so that an escape cannot be forged; a byte that is not UTF-8 is shown as \xNN.
// Plain printable text, UTF-8 included, comes back unchanged.
std::string logText(std::string_view text);

}  // namespace lensfarm
