#pragma once
// The scene folder with a secret file beside it, shared by asset_confinement_test (loading) and
// asset_confinement_cli_test (the real `lensfarm` binary).
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/test_support.h"

namespace lensfarm::test {

namespace fs = std::filesystem;
using json = nlohmann::json;

inline const std::string kTriangleObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

// A scene folder `root` inside a temporary directory, with a secret file beside it (outside).
struct Layout {
  test::TempDir dir;
  fs::path root = dir / "project";
  fs::path secret = dir / "secret.obj";
  Layout() {
    fs::create_directories(root / "models");
    dir.write("secret.obj", kTriangleObj);
    dir.write("secret.bin", std::string(36, '\0'));
  }
  fs::path write(const std::string& name, const std::string& text) const {
    const fs::path p = root / name;
    fs::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
  // A scene whose one shape is an OBJ at `file`.
  fs::path sceneWithMesh(const std::string& file) const {
    json j = test::minimalSceneJson();
    j["shapes"] = {{{"type", "obj"}, {"file", file}, {"material", "white"}}};
    return write("scene.json", j.dump());
  }
};

}  // namespace lensfarm::test
