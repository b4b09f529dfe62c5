#include "common/farm/job_policy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <set>

#include "common/farm/farm_types.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

[[noreturn]] void invalid(const std::string& field, const std::string& what) {
  throw FarmError(FarmError::Kind::kInvalidArgument, field + ": " + what);
}

// The text as a person sees it in a message: printable ASCII, at most 80 characters.
std::string quoted(const std::string& text) {
  std::string out;
  for (unsigned char c : text.substr(0, 80)) out += c >= 0x20 && c < 0x7f ? char(c) : '?';
  return "\"" + out + (text.size() > 80 ? "...\"" : "\"");
}

struct ConditionName {
  Dependency::Condition condition;
  const char* name;
};
constexpr ConditionName kConditions[] = {{Dependency::Condition::kDone, "done"},
                                         {Dependency::Condition::kFailed, "failed"},
                                         {Dependency::Condition::kEnded, "ended"},
                                         {Dependency::Condition::kApproved, "approved"}};

double parseError(const std::string& text, const std::string& field, const std::string& whole) {
  // "2%", "2 %", "0.02": a percent sign means percent, a bare number a fraction.
  std::string number = text;
  while (!number.empty() && number.back() == ' ') number.pop_back();
  const bool percent = !number.empty() && number.back() == '%';
  if (percent) number.pop_back();
  size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(number, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  while (used < number.size() && number[used] == ' ') ++used;
  if (number.empty() || used != number.size() || !std::isfinite(value))
    invalid(field, quoted(whole) + ": the error must be a number, e.g. error<=2% or error<=0.02");
  if (percent) value /= 100.0;
  if (!(value > 0.0 && value <= 1.0)) invalid(field, quoted(whole) + ": the error must be above 0 and at most 100 %");
  return value;
}

}  // namespace

Dependency parseDependency(const std::string& text, const std::string& field) {
  Dependency d;
  const size_t colon = text.find(':');
  d.jobId = text.substr(0, colon);
  if (d.jobId.empty())
    invalid(field, quoted(text) + ": no job id (JOB, JOB:done, JOB:failed, JOB:ended, JOB:approved, JOB:error<=2%)");
  if (d.jobId.size() > 128 || d.jobId.find_first_of(" \t\r\n") != std::string::npos)
    invalid(field, quoted(text) + ": not a job id");
  if (colon == std::string::npos) return d;
  const std::string condition = text.substr(colon + 1);
  for (const ConditionName& c : kConditions)
    if (condition == c.name) {
      d.condition = c.condition;
      return d;
    }
  if (condition.rfind("error<=", 0) == 0) {
    d.condition = Dependency::Condition::kErrorAtMost;
    d.maxError = parseError(condition.substr(7), field, text);
    return d;
  }
  invalid(field, quoted(text) + ": unknown condition " + quoted(condition) +
                     " (done, failed, ended, approved, error<=PERCENT%)");
}

std::string dependencyText(const Dependency& d) {
  if (d.condition == Dependency::Condition::kErrorAtMost) {
    char percent[32];
    std::snprintf(percent, sizeof percent, "%.6g", d.maxError * 100.0);
    return d.jobId + ":error<=" + percent + "%";
  }
  for (const ConditionName& c : kConditions)
    if (c.condition == d.condition) return d.jobId + ":" + c.name;
  return d.jobId;
}

void checkTag(const std::string& tag, const std::string& field) {
  const auto ok = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
  };
  if (tag.empty()) invalid(field, "an empty tag");
  if (tag.size() > 64) invalid(field, quoted(tag) + ": a tag has at most 64 characters");
  if (!std::all_of(tag.begin(), tag.end(), ok) || tag.front() == '.' || tag.front() == '_' || tag.front() == '-')
    invalid(field,
            quoted(tag) + ": a tag is lower-case letters, digits, '.', '_' and '-', starting with a letter or digit");
}

namespace {
void checkTags(const std::vector<std::string>& tags, const std::string& field) {
  if (tags.size() > kMaxTags)
    invalid(field, std::to_string(tags.size()) + " tags, the most is " + std::to_string(kMaxTags));
  for (size_t i = 0; i < tags.size(); ++i) checkTag(tags[i], field + "[" + std::to_string(i) + "]");
}
}  // namespace

void checkPolicy(const JobPolicy& policy) {
  if (policy.after.size() > kMaxDependencies)
    invalid("after",
            std::to_string(policy.after.size()) + " dependencies, the most is " + std::to_string(kMaxDependencies));
  std::set<std::string> seen;
  for (size_t i = 0; i < policy.after.size(); ++i) {
    const Dependency& d = policy.after[i];
    const std::string field = "after[" + std::to_string(i) + "]";
    if (d.jobId.empty()) invalid(field, "no job id");
    if (d.condition == Dependency::Condition::kErrorAtMost && !(d.maxError > 0.0 && d.maxError <= 1.0))
      invalid(field, d.jobId + ": the error must be above 0 and at most 1 (100 %)");
    if (!seen.insert(d.jobId).second) invalid(field, d.jobId + " is waited for twice");
  }
  checkTags(policy.requireTags, "require_tags");
  checkTags(policy.preferTags, "prefer_tags");
  checkTags(policy.auditRequireTags, "audit_require_tags");
  if (policy.maxWorkers && *policy.maxWorkers == 0)
    invalid("max_workers", "0 workers would never render it; leave it unset for no cap");
  if (!(std::isfinite(policy.shareWeight) && policy.shareWeight > 0.0 && policy.shareWeight <= 1e6))
    invalid("share_weight", "must be a number above 0 and at most 1e6");
  if (policy.maxUnitFailures && (*policy.maxUnitFailures < 1 || *policy.maxUnitFailures > 1000))
    invalid("max_unit_failures", "must be 1 to 1000");
  if (policy.maxWorkerFailures && (*policy.maxWorkerFailures < 1 || *policy.maxWorkerFailures > 1000))
    invalid("max_worker_failures", "must be 1 to 1000");
  if (policy.unitTimeLimitSeconds &&
      !(std::isfinite(*policy.unitTimeLimitSeconds) && *policy.unitTimeLimitSeconds >= 0.1 &&
        *policy.unitTimeLimitSeconds <= 7 * 24 * 3600.0))
    invalid("unit_time_limit_seconds", "must be 0.1 s to 7 days");
}

bool hasAllTags(const std::vector<std::string>& have, const std::vector<std::string>& need) {
  return std::all_of(need.begin(), need.end(),
                     [&](const std::string& t) { return std::find(have.begin(), have.end(), t) != have.end(); });
}

std::string tagsText(const std::vector<std::string>& tags) {
  std::string out;
  for (const std::string& t : tags) out += (out.empty() ? "" : ", ") + t;
  return out.empty() ? "none" : out;
}

std::string policyToJson(const JobPolicy& p) {
  json after = json::array();
  for (const Dependency& d : p.after) after.push_back(dependencyText(d));
  json j = {{"after", after},
            {"on_dependency_failure", p.onDependencyFailure == OnDependencyFailure::kWait ? "wait" : "fail"},
            {"require_tags", p.requireTags},
            {"prefer_tags", p.preferTags},
            {"audit_require_tags", p.auditRequireTags},
            {"share_weight", p.shareWeight}};
  if (p.maxWorkers) j["max_workers"] = *p.maxWorkers;
  if (p.maxUnitFailures) j["max_unit_failures"] = *p.maxUnitFailures;
  if (p.maxWorkerFailures) j["max_worker_failures"] = *p.maxWorkerFailures;
  if (p.unitTimeLimitSeconds) j["unit_time_limit_seconds"] = *p.unitTimeLimitSeconds;
  j["on_failure"] = p.onFailure == OnFailure::kPause ? "pause" : "fail";
  return j.dump();
}

JobPolicy policyFromJson(const std::string& text, std::string* damage) {
  JobPolicy p;
  if (text.empty()) return p;  // a row written before policies existed
  try {
    const json j = json::parse(text);
    for (const auto& d : j.at("after")) p.after.push_back(parseDependency(d.get<std::string>(), "after"));
    p.onDependencyFailure = j.at("on_dependency_failure").get<std::string>() == "wait" ? OnDependencyFailure::kWait
                                                                                       : OnDependencyFailure::kFail;
    p.requireTags = j.at("require_tags").get<std::vector<std::string>>();
    p.preferTags = j.at("prefer_tags").get<std::vector<std::string>>();
    p.auditRequireTags = j.at("audit_require_tags").get<std::vector<std::string>>();
    p.shareWeight = j.at("share_weight").get<double>();
    if (j.contains("max_workers")) p.maxWorkers = j.at("max_workers").get<uint32_t>();
    if (j.contains("max_unit_failures")) p.maxUnitFailures = j.at("max_unit_failures").get<uint32_t>();
    if (j.contains("max_worker_failures")) p.maxWorkerFailures = j.at("max_worker_failures").get<uint32_t>();
    if (j.contains("unit_time_limit_seconds")) p.unitTimeLimitSeconds = j.at("unit_time_limit_seconds").get<double>();
    p.onFailure = j.value("on_failure", "fail") == "pause" ? OnFailure::kPause : OnFailure::kFail;
    checkPolicy(p);
  } catch (const std::exception& e) {
    if (damage)
      *damage = std::string("its scheduling policy could not be read (") + e.what() + "): the default applies";
    return JobPolicy{};
  }
  return p;
}

}  // namespace lensfarm
