// The Kubernetes kustomize base, parsed (no cluster needed): every manifest is listed and well
// formed, the containers run the binaries with flags they accept, the ports, probes, Prometheus
// annotations, volumes and secrets agree with those flags, and a worker's CPU request is its
// --threads.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <regex>

#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

fs::path base() { return test::sourceDir() / "deploy/kubernetes"; }

class Kubernetes : public ::testing::Test {
 protected:
  void SetUp() override {
    kustomization_ = YAML::LoadFile((base() / "kustomization.yaml").string());
    for (const auto& resource : kustomization_["resources"])
      for (const YAML::Node& doc : YAML::LoadAllFromFile((base() / resource.as<std::string>()).string())) {
        ASSERT_TRUE(doc["apiVersion"] && doc["kind"] && doc["metadata"]["name"]) << resource;
        objects_[doc["kind"].as<std::string>() + "/" + doc["metadata"]["name"].as<std::string>()] = doc;
      }
  }
  YAML::Node object(const std::string& kindAndName) {
    const auto it = objects_.find(kindAndName);
    if (it == objects_.end()) ADD_FAILURE() << "no " << kindAndName;
    return it == objects_.end() ? YAML::Node() : it->second;
  }
  // The one container of a workload's pod, and its args, which must run `binary` with its flags.
  std::pair<YAML::Node, std::vector<std::string>> containerOf(const YAML::Node& workload, const fs::path& binary) {
    const YAML::Node containers = workload["spec"]["template"]["spec"]["containers"];
    EXPECT_EQ(containers.size(), 1u);
    std::vector<std::string> args;
    for (const auto& a : containers[0]["args"]) args.push_back(a.as<std::string>());
    EXPECT_TRUE(test::runsWithItsFlags(args, binary));
    EXPECT_TRUE(
        labelsMatch(workload["spec"]["selector"]["matchLabels"], workload["spec"]["template"]["metadata"]["labels"]));
    return {containers[0], args};
  }
  static int containerPort(const YAML::Node& container, const std::string& name) {
    for (const auto& p : container["ports"])
      if (p["name"].as<std::string>() == name) return p["containerPort"].as<int>();
    return -1;
  }
  // The files the pod's secret volumes put in the container: MOUNT/KEY (or MOUNT/PATH of an item).
  std::map<std::string, std::string> secretFiles(const YAML::Node& pod, const YAML::Node& container) {
    std::map<std::string, std::string> files;  // path -> key
    for (const auto& volume : pod["volumes"]) {
      if (!volume["secret"]) continue;
      for (const auto& mount : container["volumeMounts"]) {
        if (mount["name"].as<std::string>() != volume["name"].as<std::string>()) continue;
        const std::string dir = mount["mountPath"].as<std::string>();
        if (volume["secret"]["items"]) {
          for (const auto& item : volume["secret"]["items"])
            files[dir + "/" + item["path"].as<std::string>()] = item["key"].as<std::string>();
        } else {
          for (const auto& entry : object("Secret/" + volume["secret"]["secretName"].as<std::string>())["stringData"])
            files[dir + "/" + entry.first.as<std::string>()] = entry.first.as<std::string>();
        }
      }
    }
    return files;
  }
  static bool labelsMatch(const YAML::Node& selector, const YAML::Node& labels) {
    for (const auto& kv : selector)
      if (!labels[kv.first.as<std::string>()] ||
          labels[kv.first.as<std::string>()].as<std::string>() != kv.second.as<std::string>())
        return false;
    return selector.size() > 0;
  }

  YAML::Node kustomization_;
  std::map<std::string, YAML::Node> objects_;
};

TEST_F(Kubernetes, EveryManifestIsListedAndTheTokensAreASecret) {
  std::set<std::string> listed, present;
  for (const auto& r : kustomization_["resources"]) listed.insert(r.as<std::string>());
  for (const auto& e : fs::directory_iterator(base()))
    if (e.path().extension() == ".yaml" && e.path().filename() != "kustomization.yaml")
      present.insert(e.path().filename().string());
  EXPECT_EQ(listed, present);
  EXPECT_EQ(objects_.size(), 5u) << "a Secret, two Services, a StatefulSet and a Deployment";

  const YAML::Node secret = object("Secret/lensfarm-tokens");
  ASSERT_TRUE(secret["stringData"]["client.token"] && secret["stringData"]["worker.token"]);
  EXPECT_NE(secret["stringData"]["client.token"].as<std::string>(),
            secret["stringData"]["worker.token"].as<std::string>())
      << "the coordinator refuses equal tokens";
  // The image every container runs is the one kustomize sets.
  const std::string image = kustomization_["images"][0]["name"].as<std::string>();
  for (const char* workload : {"StatefulSet/lensfarm-coordinator", "Deployment/lensfarm-worker"})
    for (const auto& c : object(workload)["spec"]["template"]["spec"]["containers"])
      EXPECT_EQ(c["image"].as<std::string>(), image);
}

TEST_F(Kubernetes, TheCoordinatorServesItsFlagsPortsWithProbesStateAndMetrics) {
  const YAML::Node set = object("StatefulSet/lensfarm-coordinator");
  const YAML::Node pod = set["spec"]["template"]["spec"];
  const auto [container, args] = containerOf(set, test::coordinatorPath());
  EXPECT_EQ(set["spec"]["replicas"].as<int>(), 1) << "one coordinator per farm";

  const int grpcPort = test::portOf(test::optionOf(args, "--listen"));
  const int metricsPort = test::portOf(test::optionOf(args, "--metrics-listen"));
  const int dashboardPort = test::portOf(test::optionOf(args, "--dashboard-listen"));
  EXPECT_GT(dashboardPort, 0) << "the coordinator serves its dashboard (--dashboard-listen)";
  EXPECT_EQ(containerPort(container, "grpc"), grpcPort);
  EXPECT_EQ(containerPort(container, "metrics"), metricsPort);
  EXPECT_EQ(containerPort(container, "dashboard"), dashboardPort);
  for (const char* probe : {"readinessProbe", "livenessProbe"}) {
    ASSERT_TRUE(container[probe]["grpc"]) << probe << " uses gRPC health checking";
    EXPECT_EQ(container[probe]["grpc"]["port"].as<int>(), grpcPort) << probe;
  }
  const YAML::Node annotations = set["spec"]["template"]["metadata"]["annotations"];
  EXPECT_EQ(annotations["prometheus.io/scrape"].as<std::string>(), "true");
  EXPECT_EQ(annotations["prometheus.io/port"].as<std::string>(), std::to_string(metricsPort));
  EXPECT_EQ(annotations["prometheus.io/path"].as<std::string>(), "/metrics");

  // --state-dir is the mount of a persistent volume claim template.
  std::string stateVolume;
  for (const auto& m : container["volumeMounts"])
    if (m["mountPath"].as<std::string>() == test::optionOf(args, "--state-dir"))
      stateVolume = m["name"].as<std::string>();
  ASSERT_FALSE(stateVolume.empty()) << "--state-dir is not a mount";
  bool claimed = false;
  for (const auto& t : set["spec"]["volumeClaimTemplates"])
    claimed |= t["metadata"]["name"].as<std::string>() == stateVolume;
  EXPECT_TRUE(claimed) << stateVolume << " is not a persistent volume claim";

  // Both tokens are files of the Secret.
  const auto files = secretFiles(pod, container);
  EXPECT_EQ(files.at(test::optionOf(args, "--client-token-file")), "client.token");
  EXPECT_EQ(files.at(test::optionOf(args, "--worker-token-file")), "worker.token");

  // Non-root, as the image's own user.
  EXPECT_TRUE(pod["securityContext"]["runAsNonRoot"].as<bool>());
  const std::string uid = std::to_string(pod["securityContext"]["runAsUser"].as<int>());
  EXPECT_NE(test::readFile(test::sourceDir() / "deploy/docker/Dockerfile").find("--uid " + uid + " "),
            std::string::npos)
      << uid;

  // The Service workers and clients dial, and the headless one that names the pod.
  const YAML::Node service = object("Service/lensfarm-coordinator");
  EXPECT_TRUE(labelsMatch(service["spec"]["selector"], set["spec"]["template"]["metadata"]["labels"]));
  std::map<std::string, int> servicePorts;
  for (const auto& p : service["spec"]["ports"]) {
    servicePorts[p["name"].as<std::string>()] = p["port"].as<int>();
    EXPECT_GE(containerPort(container, p["targetPort"].as<std::string>()), 0) << "targetPort names a container port";
  }
  EXPECT_EQ(servicePorts["grpc"], grpcPort);
  EXPECT_EQ(servicePorts["metrics"], metricsPort);
  EXPECT_EQ(servicePorts["dashboard"], dashboardPort);
  const YAML::Node headless = object("Service/" + set["spec"]["serviceName"].as<std::string>());
  EXPECT_EQ(headless["spec"]["clusterIP"].as<std::string>(), "None");
  EXPECT_TRUE(labelsMatch(headless["spec"]["selector"], set["spec"]["template"]["metadata"]["labels"]));

  // Every Service with the gRPC port has the dashboard port too, targeting the container's.
  for (const auto& [name, doc] : objects_) {
    if (doc["kind"].as<std::string>() != "Service") continue;
    std::map<std::string, std::pair<int, std::string>> ports;  // name -> port, targetPort
    for (const auto& p : doc["spec"]["ports"])
      ports[p["name"].as<std::string>()] = {p["port"].as<int>(), p["targetPort"].as<std::string>()};
    if (!ports.count("grpc")) continue;
    EXPECT_EQ(ports["dashboard"], std::make_pair(dashboardPort, std::string("dashboard"))) << name;
  }
}

// Kubernetes CPU quantities: "4" or "4000m".
double cores(const std::string& quantity) {
  return quantity.back() == 'm' ? std::stod(quantity.substr(0, quantity.size() - 1)) / 1000.0 : std::stod(quantity);
}

TEST_F(Kubernetes, WorkersRenderWithAsManyThreadsAsTheyRequestCoresAndDialTheService) {
  const YAML::Node deployment = object("Deployment/lensfarm-worker");
  const YAML::Node pod = deployment["spec"]["template"]["spec"];
  const auto [container, args] = containerOf(deployment, test::workerPath());
  const std::string help = test::helpOf(test::workerPath()).text;
  for (const auto& e : container["env"])
    EXPECT_NE(help.find(e["name"].as<std::string>()), std::string::npos) << e["name"];
  EXPECT_GE(deployment["spec"]["replicas"].as<int>(), 1);

  const std::string threads = test::optionOf(args, "--threads");
  ASSERT_FALSE(threads.empty()) << "--threads is set, not every core of the node";
  EXPECT_EQ(cores(container["resources"]["requests"]["cpu"].as<std::string>()), std::stod(threads));
  EXPECT_EQ(cores(container["resources"]["limits"]["cpu"].as<std::string>()), std::stod(threads));

  const YAML::Node service = object("Service/lensfarm-coordinator");
  int grpcPort = -1;
  for (const auto& p : service["spec"]["ports"])
    if (p["name"].as<std::string>() == "grpc") grpcPort = p["port"].as<int>();
  EXPECT_EQ(test::optionOf(args, "--coordinator"), "lensfarm-coordinator:" + std::to_string(grpcPort));
  const auto files = secretFiles(pod, container);
  EXPECT_EQ(files.at(test::optionOf(args, "--token-file")), "worker.token");
  EXPECT_EQ(files.size(), 1u) << "a worker sees only the worker token";
  EXPECT_GE(pod["terminationGracePeriodSeconds"].as<int>(), 60) << "time to drain the unit in progress";

  // docs/deploy.md scales the farm with one command naming this Deployment.
  const std::string docs = test::readFile(test::sourceDir() / "docs/deploy.md");
  EXPECT_TRUE(
      std::regex_search(docs, std::regex("kubectl scale deployment/" +
                                         deployment["metadata"]["name"].as<std::string>() + " --replicas=[0-9]+")));
}

}  // namespace
}  // namespace lensfarm
