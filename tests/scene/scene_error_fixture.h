#pragma once
// The fixture of the scene-input tests (bad_input_test, camera_input_test, bad_mesh_test): a
// scene written into a fresh directory under one file name, loaded, and the message of the
// InputError it raised, checked to start with "<file>: <field>: " as every scene error does.
#include <gtest/gtest.h>

#include <filesystem>
#include <initializer_list>
#include <string>

#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm::test {

inline constexpr const char* kNoError = "<no InputError was thrown>";

class SceneErrorTest : public ::testing::Test {
 protected:
  explicit SceneErrorTest(std::string sceneName) : sceneName_(std::move(sceneName)) {}

  std::filesystem::path sceneFile() const { return dir_ / sceneName_; }

  // The message of the InputError thrown while loading the scene file as it is, or kNoError.
  std::string loadError() const {
    try {
      (void)loadScene(sceneFile());
    } catch (const InputError& e) {
      return e.what();
    } catch (const std::exception& e) {
      return std::string("<not an InputError: ") + e.what() + ">";
    }
    return kNoError;
  }
  // The same for a scene of this text, or of this JSON.
  std::string errorOfText(const std::string& text) const {
    dir_.write(sceneName_, text);
    return loadError();
  }
  std::string errorOf(const nlohmann::json& scene) const { return errorOfText(scene.dump(2)); }

  // The message starts with "<file>: <field>: " and contains every one of `more`.
  ::testing::AssertionResult namesField(const std::string& message, const std::string& field,
                                        std::initializer_list<std::string> more = {}) const {
    const std::string prefix = sceneFile().string() + ": " + field + ": ";
    if (message.rfind(prefix, 0) != 0)
      return ::testing::AssertionFailure() << "message \"" << message << "\" does not start with \"" << prefix << "\"";
    for (const auto& m : more)
      if (message.find(m) == std::string::npos)
        return ::testing::AssertionFailure() << "message \"" << message << "\" does not contain \"" << m << "\"";
    return ::testing::AssertionSuccess();
  }

  TempDir dir_;

 private:
  std::string sceneName_;
};

}  // namespace lensfarm::test
