// Authentication and TLS between real processes: per-service tokens, refusals that name the
// problem and never the secret, TLS with a throwaway CA made by openssl at test time.
#include <gtest/gtest.h>
#include <signal.h>
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <regex>

#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

class Security : public ::testing::Test {
 protected:
  std::string start(std::vector<std::string> extra, const std::string& listen = "127.0.0.1:0") {
    const fs::path portFile = dir_ / ("port" + std::to_string(++n_));
    std::vector<std::string> argv = {test::coordinatorPath(), "--listen", listen, "--port-file", portFile.string()};
    argv.insert(argv.end(), extra.begin(), extra.end());
    coordinator_ = std::make_unique<test::ChildProcess>(argv, dir_ / ("coordinator" + std::to_string(n_)));
    if (!test::waitFor([&] { return fs::exists(portFile) || !coordinator_->running(); }, 30)) return "";
    std::string a = test::readFile(portFile);
    return a.substr(0, a.find('\n'));
  }
  test::ProcessResult cli(std::vector<std::string> args) {
    args.insert(args.begin(), test::cliPath().string());
    return test::runProcess(args, 60);
  }
  std::unique_ptr<test::ChildProcess> worker(const std::string& address, std::vector<std::string> extra) {
    std::vector<std::string> argv = {test::workerPath(),
                                     "--coordinator",
                                     address,
                                     "--threads",
                                     "1",
                                     "--cache-dir",
                                     (dir_ / ("cache" + std::to_string(++n_))).string(),
                                     "--max-backoff",
                                     "0.3"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return std::make_unique<test::ChildProcess>(argv, dir_ / ("worker" + std::to_string(n_)));
  }
  fs::path scene() {
    nlohmann::json s = test::minimalSceneJson();
    s["render"]["samples_per_pixel"] = 4;
    return dir_.write("scene.json", s.dump());
  }
  // Runs openssl; fails the test if it fails.
  void openssl(const std::vector<std::string>& args) {
    std::vector<std::string> argv = {"/usr/bin/openssl"};
    argv.insert(argv.end(), args.begin(), args.end());
    const auto r = test::runProcess(argv, 60);
    ASSERT_EQ(r.exitCode, 0) << r.err;
  }
  // A CA, a server certificate for 127.0.0.1 and client certificates (CN = each name), all throwaway.
  void makeCertificates(const std::vector<std::string>& clients = {"client"}) {
    const auto p = [&](const char* name) { return (dir_ / name).string(); };
    openssl({"req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", p("ca.key"), "-out", p("ca.pem"), "-days", "1",
             "-subj", "/CN=lensfarm test CA"});
    std::vector<std::string> subjects = {"server"};
    subjects.insert(subjects.end(), clients.begin(), clients.end());
    for (const std::string& name : subjects) {
      const char* who = name.c_str();
      const std::string key = p(who) + std::string(".key"), csr = p(who) + std::string(".csr"),
                        pem = p(who) + std::string(".pem"), ext = p(who) + std::string(".ext");
      std::ofstream(ext) << "subjectAltName=IP:127.0.0.1,DNS:localhost\n";
      openssl(
          {"req", "-newkey", "rsa:2048", "-nodes", "-keyout", key, "-out", csr, "-subj", std::string("/CN=") + who});
      openssl({"x509", "-req", "-in", csr, "-CA", p("ca.pem"), "-CAkey", p("ca.key"), "-CAcreateserial", "-out", pem,
               "-days", "1", "-extfile", ext});
    }
  }

  test::TempDir dir_;
  std::unique_ptr<test::ChildProcess> coordinator_;
  int n_ = 0;
};

TEST_F(Security, EachServiceTakesOnlyItsOwnToken) {
  const fs::path clientToken = dir_.write("client.token", "client-secret-123\n");
  const fs::path workerToken = dir_.write("worker.token", "worker-secret-456\n");
  const std::string address = start({"--client-token-file", clientToken, "--worker-token-file", workerToken});
  ASSERT_FALSE(address.empty()) << coordinator_->log();

  const auto anonymous = cli({"status", "--coordinator", address});
  EXPECT_EQ(anonymous.exitCode, 6);
  EXPECT_NE(anonymous.err.find("missing client token"), std::string::npos) << anonymous.err;
  const auto workerAsClient = cli({"submit", scene().string(), "--coordinator", address, "--token-file", workerToken});
  EXPECT_EQ(workerAsClient.exitCode, 6) << "a worker token cannot submit";
  EXPECT_NE(workerAsClient.err.find("wrong client token"), std::string::npos) << workerAsClient.err;

  // A worker holding the client token cannot lease work: it gives up with a clear error.
  auto impostor = worker(address, {"--token-file", clientToken.string()});
  EXPECT_EQ(impostor->wait(30), 3);
  EXPECT_NE(impostor->log().find("wrong worker token"), std::string::npos) << impostor->log();

  auto honest = worker(address, {"--token-file", workerToken.string()});
  const auto submitted = cli({"submit", scene().string(), "--coordinator", address, "--token-file", clientToken});
  ASSERT_EQ(submitted.exitCode, 0) << submitted.err;
  const std::string job = submitted.out.substr(0, submitted.out.find('\n'));
  ::setenv("LENSFARM_TOKEN", "client-secret-123", 1);  // the environment works as well as a file
  const auto watched = cli({"watch", job, "--coordinator", address});
  ::unsetenv("LENSFARM_TOKEN");
  EXPECT_EQ(watched.exitCode, 0) << watched.err;

  const std::string log = coordinator_->log();
  EXPECT_NE(log.find("refused"), std::string::npos);
  EXPECT_EQ(log.find("secret-123"), std::string::npos) << "a token must never be logged";
  EXPECT_EQ(log.find("secret-456"), std::string::npos) << "a token must never be logged";
}

TEST_F(Security, NetworkListeningNeedsTokens) {
  EXPECT_TRUE(start({}, "0.0.0.0:0").empty());
  EXPECT_EQ(coordinator_->wait(30), 2);
  EXPECT_NE(coordinator_->log().find("refusing to listen on 0.0.0.0:0 without"), std::string::npos)
      << coordinator_->log();
  const fs::path same = dir_.write("same.token", "shared-token-of-both-services");
  EXPECT_TRUE(start({"--client-token-file", same, "--worker-token-file", same}).empty());
  EXPECT_EQ(coordinator_->wait(30), 2) << "clients and workers must not share a token";
  EXPECT_NE(coordinator_->log().find("different tokens"), std::string::npos) << coordinator_->log();
}

// Tokens a stranger could guess are refused, whoever supplies them: the placeholders the deploy
// files ship (read from the files themselves, so a new placeholder there is caught too), short
// tokens and tokens of few characters; each with the file named and how to make a good one.
TEST_F(Security, GuessableTokensAreRefused) {
  const YAML::Node secret = YAML::LoadFile((test::sourceDir() / "deploy/kubernetes/secret.yaml").string());
  std::vector<std::pair<std::string, std::string>> cases;  // client token, worker token
  cases.emplace_back(secret["stringData"]["client.token"].as<std::string>(),
                     secret["stringData"]["worker.token"].as<std::string>());
  const std::string good = "Zm9vYmFyLWEtcmVhbC1yYW5kb20tdG9rZW4tMTIz";
  for (const std::string bad : {"short-token", "aaaaaaaaaaaaaaaaaaaaaaaa", "ababababcdcdcdcdababab",
                                "CHANGEME-please-0123456789", "your_token_here_0123456789", "<placeholder>-0123456789"})
    cases.emplace_back(bad, good);
  for (const auto& [client, worker] : cases) {
    SCOPED_TRACE(client);
    const fs::path clientFile = dir_.write("client.token", client + "\n"),
                   workerFile = dir_.write("worker.token", worker + "\n");
    EXPECT_TRUE(start({"--client-token-file", clientFile, "--worker-token-file", workerFile}).empty());
    EXPECT_EQ(coordinator_->wait(30), 2);
    EXPECT_NE(coordinator_->log().find(clientFile.string()), std::string::npos) << coordinator_->log();
    EXPECT_NE(coordinator_->log().find("head -c 32 /dev/urandom | base64"), std::string::npos) << coordinator_->log();
    EXPECT_EQ(coordinator_->log().find(client), std::string::npos) << "the token itself is never logged";
  }
  // The same tokens from the environment are refused naming the variable.
  const fs::path workerFile = dir_.write("worker.token", good + "\n");
  const auto r =
      test::runProcess({"/usr/bin/env", "LENSFARM_CLIENT_TOKEN=REPLACE-ME-client-token", test::coordinatorPath(),
                        "--listen", "127.0.0.1:0", "--worker-token-file", workerFile.string()},
                       30);
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("LENSFARM_CLIENT_TOKEN"), std::string::npos) << r.err;
  // A good pair still starts.
  const fs::path clientFile = dir_.write("client.token", "Y2xpZW50LXNpZGUtcmFuZG9tLXRva2VuLTQ1Ng==\n");
  EXPECT_FALSE(start({"--client-token-file", clientFile, "--worker-token-file", workerFile}).empty())
      << coordinator_->log();
}

TEST_F(Security, TlsAndMutualTls) {
  makeCertificates();
  const auto p = [&](const char* name) { return (dir_ / name).string(); };
  {
    const std::string address = start({"--tls-cert", p("server.pem"), "--tls-key", p("server.key")});
    ASSERT_FALSE(address.empty()) << coordinator_->log();
    EXPECT_EQ(cli({"status", "--coordinator", address}).exitCode, 3) << "a plain client cannot talk to a TLS server";
    auto w = worker(address, {"--tls-ca", p("ca.pem")});
    const auto submitted = cli({"submit", scene().string(), "--coordinator", address, "--tls-ca", p("ca.pem")});
    ASSERT_EQ(submitted.exitCode, 0) << submitted.err;
    const std::string job = submitted.out.substr(0, submitted.out.find('\n'));
    EXPECT_EQ(cli({"watch", job, "--coordinator", address, "--tls-ca", p("ca.pem")}).exitCode, 0);
  }
  {
    const std::string address =
        start({"--tls-cert", p("server.pem"), "--tls-key", p("server.key"), "--tls-client-ca", p("ca.pem")});
    ASSERT_FALSE(address.empty()) << coordinator_->log();
    EXPECT_EQ(cli({"status", "--coordinator", address, "--tls-ca", p("ca.pem")}).exitCode, 3)
        << "mutual TLS: no client certificate, no connection";
    const auto withCert = cli({"status", "--coordinator", address, "--tls-ca", p("ca.pem"), "--tls-cert",
                               p("client.pem"), "--tls-key", p("client.key")});
    EXPECT_EQ(withCert.exitCode, 0) << withCert.err;
  }
}

// People known by their client certificates (docs/farm.md "People and permissions"): with mutual
// TLS, a users file line `NAME ROLE cert=CN` makes a call without a token that person's when its
// certificate has that name; a certificate nobody is named by still needs a token.
TEST_F(Security, PeopleKnownByTheirClientCertificatesActAsTheirRolesAllow) {
  makeCertificates({"ann", "vic", "stranger"});
  const auto p = [&](const std::string& name) { return (dir_ / name).string(); };
  const fs::path admin = dir_.write("admin.token", "the-administrators-token-7\n");
  const fs::path users = dir_.write("users", "ann submitter cert=ann\nvic viewer cert=vic\n");
  fs::permissions(users, fs::perms::owner_read | fs::perms::owner_write);
  const std::vector<std::string> tls = {"--tls-cert",    p("server.pem"),   "--tls-key",
                                        p("server.key"), "--tls-client-ca", p("ca.pem")};
  std::vector<std::string> flags = tls;
  flags.insert(flags.end(), {"--client-token-file", admin.string(), "--users", users.string()});
  const std::string address = start(flags);
  ASSERT_FALSE(address.empty()) << coordinator_->log();
  const auto as = [&](const std::string& who, std::vector<std::string> args) {
    args.insert(args.end(), {"--coordinator", address, "--tls-ca", p("ca.pem"), "--tls-cert", p(who + ".pem"),
                             "--tls-key", p(who + ".key")});
    return cli(args);
  };
  const auto submitted = as("ann", {"submit", scene().string(), "--owner", "mallory", "--paused"});
  ASSERT_EQ(submitted.exitCode, 0) << submitted.err;
  const std::string job = submitted.out.substr(0, submitted.out.find('\n'));
  EXPECT_NE(as("vic", {"status", job}).out.find("owner:      ann"), std::string::npos) << "ann's, by her certificate";
  const auto vicCancels = as("vic", {"cancel", job});
  EXPECT_EQ(vicCancels.exitCode, 6);
  EXPECT_NE(vicCancels.err.find("CancelJob: vic is a viewer: reading only"), std::string::npos) << vicCancels.err;
  const auto stranger = as("stranger", {"status"});
  EXPECT_EQ(stranger.exitCode, 6) << "a certificate nobody is named by is no identity";
  EXPECT_NE(stranger.err.find("missing client token"), std::string::npos) << stranger.err;
  EXPECT_EQ(as("ann", {"cancel", job}).exitCode, 0) << "ann acts on her own job";

  // cert= identities need mutual TLS: without --tls-client-ca the coordinator refuses to start.
  const auto refused =
      test::runProcess({test::coordinatorPath(), "--listen", "127.0.0.1:0", "--tls-cert", p("server.pem"), "--tls-key",
                        p("server.key"), "--client-token-file", admin.string(), "--users", users.string()},
                       30);
  EXPECT_EQ(refused.exitCode, 2);
  EXPECT_NE(refused.err.find("ann is known by a client certificate (cert=ann): that needs mutual TLS"),
            std::string::npos)
      << refused.err;
}

}  // namespace
}  // namespace lensfarm
