// The Kubernetes manifests against the Kubernetes API schema, offline (no cluster): every object
// that deploy/kubernetes/kustomization.yaml lists goes through tests/deploy/kubernetes_schema.js,
// run as a real node process. It checks each object with kubernetes-models' JSON-schema validator
// for its kind (Kubernetes 1.36 schema; npm, pinned in tests/deploy/package-lock.json, installed by
// scripts/setup.sh) and reports fields the schema does not have. A broken copy of a manifest shows
// that the check refuses what it should, naming the file, the object and the field.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>

#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

const fs::path kNode = "/usr/bin/node";
fs::path deployTests() { return test::sourceDir() / "tests/deploy"; }
fs::path base() { return test::sourceDir() / "deploy/kubernetes"; }

// Runs the validator on `inputs`. Node and the npm packages are installed by scripts/setup.sh test,
// so their absence is a failure, never a skip.
test::ProcessResult validate(const std::vector<std::string>& inputs) {
  EXPECT_TRUE(fs::exists(kNode)) << "node is missing: scripts/setup.sh test installs nodejs";
  EXPECT_TRUE(fs::exists(deployTests() / "node_modules/kubernetes-models/package.json"))
      << "the validator's npm packages are missing: scripts/setup.sh test installs them (npm ci in tests/deploy)";
  std::vector<std::string> argv{kNode.string(), (deployTests() / "kubernetes_schema.js").string()};
  argv.insert(argv.end(), inputs.begin(), inputs.end());
  return test::runProcess(argv, 120);
}

// The 1-based line of the first line of `text` that contains `needle` (0 if none).
int lineOf(const std::string& text, const std::string& needle) {
  std::istringstream in(text);
  int n = 0;
  for (std::string line; std::getline(in, line);)
    if (++n, line.find(needle) != std::string::npos) return n;
  return 0;
}

// `text` with `from` replaced by `to` once; fails the test if `from` is not there.
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

TEST(KubernetesSchema, EveryListedObjectIsValidAgainstASchemaNewEnoughForGrpcProbes) {
  const auto r = validate({base().string()});
  ASSERT_FALSE(r.timedOut);
  EXPECT_EQ(r.exitCode, 0) << r.out << r.err;
  EXPECT_EQ(r.err, "");

  // The pinned kubernetes-models is the one that ran, and its schema knows gRPC probes (Kubernetes
  // 1.24).
  const auto pinned = nlohmann::json::parse(test::readFile(deployTests() / "package.json"));
  const std::string version = pinned["dependencies"]["kubernetes-models"].get<std::string>();
  std::smatch header;
  ASSERT_TRUE(
      std::regex_search(r.out, header, std::regex(R"(^kubernetes-models (\S+), Kubernetes (\d+)\.(\d+) schema)")))
      << r.out;
  EXPECT_EQ(header[1].str(), version);
  EXPECT_GE(std::stoi(header[2].str()) * 100 + std::stoi(header[3].str()), 124) << "grpc: probes need Kubernetes 1.24";

  // Each object of each listed file (as yaml-cpp reads it) was validated, and nothing else.
  const YAML::Node kustomization = YAML::LoadFile((base() / "kustomization.yaml").string());
  size_t objects = 0;
  for (const auto& resource : kustomization["resources"]) {
    const fs::path file = base() / resource.as<std::string>();
    for (const YAML::Node& doc : YAML::LoadAllFromFile(file.string())) {
      ++objects;
      const std::string line = "ok " + file.string() + " " + doc["kind"].as<std::string>() + "/" +
                               doc["metadata"]["name"].as<std::string>() + "\n";
      EXPECT_NE(r.out.find(line), std::string::npos) << line << r.out;
    }
  }
  EXPECT_EQ(objects, 5u);
  EXPECT_NE(r.out.find("\n" + std::to_string(objects) + " objects, 0 invalid\n"), std::string::npos) << r.out;
}

// `node` as JSON, scalars typed as YAML 1.2's core schema reads them: quoted ones stay strings
// (yaml-cpp's emitter would drop the quotes of "true" or "9464" and change their type).
nlohmann::json toJson(const YAML::Node& node) {
  if (node.IsMap()) {
    nlohmann::json o = nlohmann::json::object();
    for (const auto& kv : node) o[kv.first.as<std::string>()] = toJson(kv.second);
    return o;
  }
  if (node.IsSequence()) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& item : node) a.push_back(toJson(item));
    return a;
  }
  if (node.IsNull()) return nullptr;
  const std::string text = node.Scalar();
  if (node.Tag() == "!") return text;  // quoted
  if (text == "true" || text == "false") return text == "true";
  if (std::regex_match(text, std::regex(R"(^-?[0-9]+$)"))) return std::stoll(text);
  if (std::regex_match(text, std::regex(R"(^-?[0-9]*\.[0-9]+([eE][-+]?[0-9]+)?$)"))) return std::stod(text);
  return text;
}

// What `kubectl apply -k` would send. kubectl is no Debian 12 package (kubernetes-client is 1.20,
// whose built-in kustomize predates the `labels:` field), so kustomize itself does not run here;
// instead: the kustomization lists every manifest of the base and only files that exist; its image
// transform names the image the containers use (else the tag is silently not applied); its labels
// are valid label keys and values; and the objects with both transforms applied as kustomize
// applies them (`labels` without includeSelectors: metadata.labels only; `images`: name:newTag)
// are valid against the schema.
TEST(KubernetesSchema, TheKustomizationCoversTheBaseAndItsTransformedObjectsAreValid) {
  const YAML::Node k = YAML::LoadFile((base() / "kustomization.yaml").string());
  std::set<std::string> listed, present;
  for (const auto& r : k["resources"]) listed.insert(r.as<std::string>());
  for (const auto& entry : fs::directory_iterator(base()))
    if (entry.path().extension() == ".yaml" && entry.path().filename() != "kustomization.yaml")
      present.insert(entry.path().filename().string());
  EXPECT_EQ(listed, present) << "every manifest of the base is listed, and only those that exist";

  std::map<std::string, std::string> labels, tags;
  const std::regex labelKey(
      R"(^([a-z0-9]([-a-z0-9]*[a-z0-9])?(\.[a-z0-9]([-a-z0-9]*[a-z0-9])?)*/)?[A-Za-z0-9]([-A-Za-z0-9_.]{0,61}[A-Za-z0-9])?$)");
  const std::regex labelValue(R"(^([A-Za-z0-9]([-A-Za-z0-9_.]{0,61}[A-Za-z0-9])?)?$)");
  for (const auto& group : k["labels"])
    for (const auto& pair : group["pairs"]) {
      const std::string key = pair.first.as<std::string>(), value = pair.second.as<std::string>();
      EXPECT_TRUE(std::regex_match(key, labelKey)) << key;
      EXPECT_TRUE(std::regex_match(value, labelValue)) << value;
      EXPECT_FALSE(group["includeSelectors"] && group["includeSelectors"].as<bool>())
          << "a selector label would change the Deployment's immutable selector";
      labels[key] = value;
    }
  ASSERT_FALSE(labels.empty());
  for (const auto& image : k["images"]) {
    ASSERT_TRUE(image["newTag"]) << "an image entry without newTag";
    tags[image["name"].as<std::string>()] = image["newTag"].as<std::string>();
  }
  ASSERT_FALSE(tags.empty());

  const test::TempDir dir;
  std::set<std::string> used;
  size_t objects = 0;
  std::string out;  // one JSON document a line: YAML documents
  for (const std::string& file : listed)
    for (YAML::Node doc : YAML::LoadAllFromFile((base() / file).string())) {
      ++objects;
      for (const auto& [key, value] : labels) doc["metadata"]["labels"][key] = value;
      if (const YAML::Node pod = doc["spec"]["template"]["spec"])
        for (YAML::Node container : pod["containers"]) {
          const std::string name = container["image"].as<std::string>();
          used.insert(name);
          if (tags.count(name)) container["image"] = name + ":" + tags[name];
        }
      out += "---\n" + toJson(doc).dump() + "\n";
    }
  for (const auto& [name, tag] : tags) EXPECT_TRUE(used.count(name)) << "images: no container uses \"" << name << "\"";
  const fs::path rendered = dir.write("kustomized.yaml", out);
  const auto r = validate({rendered.string()});
  EXPECT_EQ(r.exitCode, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("\n" + std::to_string(objects) + " objects, 0 invalid\n"), std::string::npos) << r.out;
  const std::string text = test::readFile(rendered);
  EXPECT_NE(text.find("\"image\":\"lensfarm:" + tags.begin()->second + "\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"" + labels.begin()->first + "\":\"" + labels.begin()->second + "\""), std::string::npos)
      << text;
}

TEST(KubernetesSchema, ABrokenManifestIsRefusedNamingTheFileTheObjectAndTheField) {
  const test::TempDir dir;
  // The worker Deployment with a wrong type, a container without its (required) name and a misspelt
  // optional field deep in the pod; the coordinator StatefulSet with a misspelt `containers`.
  std::string worker = test::readFile(base() / "worker-deployment.yaml");
  worker = replaced(worker, "replicas: 4", "replicas: \"two\"");
  worker = replaced(worker, "        - name: worker\n          image: lensfarm", "        - image: lensfarm");
  worker = replaced(worker, "readOnlyRootFilesystem: true", "readOnlyRootFilesytem: true");
  const std::string coordinator =
      replaced(test::readFile(base() / "coordinator-statefulset.yaml"), "      containers:", "      containerz:");
  const fs::path brokenWorker = dir.write("broken-worker.yaml", worker);
  const fs::path brokenCoordinator = dir.write("broken-coordinator.yaml", coordinator);
  // ... and an object of a kind the schema does not have.
  const std::string widget = "apiVersion: example.com/v1\nkind: Widget\nmetadata:\n  name: w\n";
  const fs::path unknownKind = dir.write("widget.yaml", widget);

  const auto r = validate({brokenWorker.string(), brokenCoordinator.string(), unknownKind.string()});
  ASSERT_FALSE(r.timedOut);
  EXPECT_EQ(r.exitCode, 1) << r.out << r.err;
  EXPECT_EQ(r.out.find("\nok "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\n3 objects, 3 invalid\n"), std::string::npos) << r.out;

  const auto expectError = [&](const fs::path& file, const std::string& text, const std::string& lineText,
                               const std::string& rest) {
    const std::string line = file.string() + ":" + std::to_string(lineOf(text, lineText)) + ": " + rest + "\n";
    EXPECT_NE(r.err.find(line), std::string::npos) << line << "not in:\n" << r.err;
  };
  const std::string w = "Deployment/lensfarm-worker: ", c = "StatefulSet/lensfarm-coordinator: ";
  std::smatch header;
  ASSERT_TRUE(std::regex_search(r.out, header, std::regex(R"(, (Kubernetes \S+ schema)\n)"))) << r.out;
  const std::string notInSchema = " (not in the " + header[1].str() + ")";
  expectError(brokenWorker, worker, "replicas:", w + "/spec/replicas: must be integer");
  expectError(brokenWorker, worker, "- image: lensfarm",
              w + "/spec/template/spec/containers/0/name: required field missing");
  expectError(brokenWorker, worker, "readOnlyRootFilesytem",
              w +
                  "/spec/template/spec/containers/0/securityContext/readOnlyRootFilesytem: unknown field "
                  "\"readOnlyRootFilesytem\"" +
                  notInSchema);
  expectError(brokenCoordinator, coordinator,
              "containerz:", c + "/spec/template/spec/containerz: unknown field \"containerz\"" + notInSchema);
  // Without `containers` the pod misses a required field too; what was under `containerz` is not
  // reported field by field.
  EXPECT_NE(r.err.find(c + "/spec/template/spec/containers: required field missing"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("/containerz/0"), std::string::npos) << r.err;
  expectError(unknownKind, widget, "apiVersion",
              "Widget/w: /: no schema for apiVersion \"example.com/v1\" kind \"Widget\"");
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 6) << "exactly the six errors:\n" << r.err;
}

}  // namespace
}  // namespace lensfarm
