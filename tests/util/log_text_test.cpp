// Text from outside printed safely (common/util/log_text.h) and warnings anyone can cause written
// at a bounded rate (common/util/throttled_log.h).
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <sstream>

#include "common/util/log_text.h"
#include "common/util/throttled_log.h"

namespace lensfarm {
namespace {

TEST(LogText, PrintableTextAndUtf8ComeBackUnchanged) {
  for (const std::string text : {"worker-7", "studio a / node 3",
                                 "Kamera \xC3\xBC"
                                 "ber Glas",
                                 "\xE6\x97\xA5\xE6\x9C\xAC", "\xF0\x9F\x93\xB7 lens", ""})
    EXPECT_EQ(logText(text), text);
}

TEST(LogText, ControlCharactersAreShownNeverInterpreted) {
  // A forged second log line, a terminal escape (clear screen, set title), a C1 CSI, DEL, NUL.
  EXPECT_EQ(logText("w1\n[12:00:00.000] [coordinator] info job-1 done"),
            "w1\\n[12:00:00.000] [coordinator] info job-1 done");
  EXPECT_EQ(logText("\x1b[2J\x1b]0;owned\x07"), "\\x1B[2J\\x1B]0;owned\\x07");
  EXPECT_EQ(logText("a\xC2\x9B"
                    "31mb"),
            "a\\u{009B}31mb");
  EXPECT_EQ(logText(std::string("x\x7f\0y\r\t", 6)), "x\\x7F\\x00y\\r\\t");
  // Bidirectional overrides reorder what a reader sees ("Trojan Source", Boucher & Anderson 2021).
  EXPECT_EQ(logText("job\xE2\x80\xAEtxt.exe"), "job\\u{202E}txt.exe");
  EXPECT_EQ(logText("\xE2\x81\xA6x\xE2\x81\xA9"), "\\u{2066}x\\u{2069}");
  // Not UTF-8: a lone continuation byte, a truncated sequence, an overlong '/', a surrogate.
  EXPECT_EQ(logText("\x80"), "\\x80");
  EXPECT_EQ(logText("\xE6\x97"), "\\xE6\\x97");
  EXPECT_EQ(logText("\xC0\xAF"), "\\xC0\\xAF");
  EXPECT_EQ(logText("\xED\xA0\x80"), "\\xED\\xA0\\x80");
}

TEST(LogText, AnEscapeCannotBeForged) {
  // The name "\x1B" typed as four characters differs from the byte 0x1B once printed.
  EXPECT_EQ(logText("\\x1B"), "\\\\x1B");
  EXPECT_NE(logText("\\x1B"), logText("\x1b"));
  for (int byte = 0; byte < 256; ++byte) {
    const std::string out = logText(std::string(1, char(byte)) + "z");
    for (const char c : out) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << "byte " << byte << " printed as " << out;
  }
}

// Captures spdlog's lines for the life of the object.
class CapturedLog {
 public:
  CapturedLog() : previous_(spdlog::default_logger()) {
    auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(out_);
    spdlog::set_default_logger(std::make_shared<spdlog::logger>("captured", sink));
  }
  ~CapturedLog() { spdlog::set_default_logger(previous_); }
  std::vector<std::string> lines() const {
    std::vector<std::string> out;
    std::istringstream in(out_.str());
    for (std::string line; std::getline(in, line);) out.push_back(line);
    return out;
  }

 private:
  std::ostringstream out_;
  std::shared_ptr<spdlog::logger> previous_;
};

TEST(ThrottledLog, TenThousandRefusalsMakeAFewLinesThatCountTheRest) {
  CapturedLog log;
  ThrottledLog throttled(10, std::chrono::seconds(1));
  for (int i = 0; i < 10000; ++i) throttled.warn("token", "refused call " + std::to_string(i));
  throttled.warn("other", "another kind has its own budget");
  EXPECT_EQ(log.lines().size(), 11u);
  EXPECT_EQ(throttled.suppressed("token"), 9990u);
  EXPECT_EQ(throttled.suppressed("other"), 0u);
  // The next window's first line says how many were held back.
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // the window itself is what is tested
  throttled.warn("token", "refused call again");
  const auto lines = log.lines();
  ASSERT_EQ(lines.size(), 12u);
  EXPECT_NE(lines.back().find("refused call again (and 9990 more like it not logged in the 1 s before)"),
            std::string::npos)
      << lines.back();
}

}  // namespace
}  // namespace lensfarm
