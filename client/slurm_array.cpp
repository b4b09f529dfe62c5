#include "client/slurm_array.h"

#include <cctype>
#include <sstream>

#include "common/util/error.h"

namespace lensfarm::cli {

std::vector<std::string> sbatchArguments(const SlurmArray& a) {
  std::string range = "0-" + std::to_string(a.workers - 1);
  if (a.maxRunning > 0) range += "%" + std::to_string(a.maxRunning);
  std::vector<std::string> args = {"sbatch", "--parsable", "--array=" + range,
                                   "--cpus-per-task=" + std::to_string(a.cpusPerTask), "--job-name=" + a.jobName};
  if (!a.timeLimit.empty()) args.push_back("--time=" + a.timeLimit);
  if (!a.partition.empty()) args.push_back("--partition=" + a.partition);
  if (!a.account.empty()) args.push_back("--account=" + a.account);
  if (!a.qos.empty()) args.push_back("--qos=" + a.qos);
  if (!a.logDir.empty()) args.push_back("--output=" + (a.logDir / "lensfarm-worker-%A_%a.log").string());
  args.insert(args.end(), a.extraSbatchArgs.begin(), a.extraSbatchArgs.end());
  args.push_back(a.script.string());
  return args;
}

std::map<std::string, std::string> workerEnvironment(const SlurmArray& a) {
  std::ostringstream idle;
  idle << a.idleExitSeconds;
  std::map<std::string, std::string> env = {{"LENSFARM_COORDINATOR", a.coordinator},
                                            {"LENSFARM_IDLE_EXIT", idle.str()}};
  if (!a.workerTokenFile.empty()) env["LENSFARM_TOKEN_FILE"] = a.workerTokenFile.string();
  if (!a.workerBinary.empty()) env["LENSFARM_WORKER"] = a.workerBinary;
  return env;
}

std::string parseSbatchJobId(const std::string& output) {
  std::string id = output.substr(0, output.find_first_of(";\n"));
  while (!id.empty() && std::isspace(static_cast<unsigned char>(id.back()))) id.pop_back();
  const bool digits = !id.empty() && id.find_first_not_of("0123456789") == std::string::npos;
  if (!digits) throw InputError("sbatch", "expected a job id on its output, got '" + output + "'");
  return id;
}

std::vector<std::string> squeueArguments(const std::string& arrayJobId) {
  return {"squeue", "--noheader", "--array", "--jobs=" + arrayJobId, "--format=%i %T"};
}

std::vector<std::string> scancelArguments(const std::string& arrayJobId) { return {"scancel", arrayJobId}; }

bool isLocalOnlyAddress(const std::string& hostPort) {
  std::string host = hostPort.substr(0, hostPort.rfind(':'));
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  return host == "localhost" || host.rfind("127.", 0) == 0 || host == "::1" || host == "0.0.0.0" || host == "::" ||
         host.empty();
}

}  // namespace lensfarm::cli
