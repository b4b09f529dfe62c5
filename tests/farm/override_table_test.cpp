// The render overrides are one table (scene/render_overrides.h overrideTable()): every row is a
// field of lensfarm.v1.RenderOverrides and a flag of `render` and `submit`, and a value survives
// every form it takes (proto, the coordinator's stored JSON) unchanged.
#include "common/scene/render_overrides.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "common/film/image_io.h"
#include "common/util/error.h"
#include "proto/convert.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

// Every override set, each to a value other than its default.
RenderOverrides everyOverride() {
  RenderOverrides o;
  o.samplesPerPixel = (uint64_t(1) << 40) - 3;
  o.width = 320, o.height = 200;
  o.maxBounces = 7;
  o.seed = UINT64_MAX;  // the top bit survives every form
  o.integrator = IntegratorKind::kNee;
  o.sampler = SamplerKind::kStratified;
  o.russianRoulette = false;
  o.targetError = 0.0125;
  o.timeLimitSeconds = 5400.5;
  o.ev = -1.5;
  o.tileSize = RenderSettings::kTilesOff;
  AovSet aovs;
  std::string bad;
  EXPECT_TRUE(parseAovList("albedo,depth", aovs, &bad));
  o.aovs = aovs;
  o.adaptive = true;
  o.kernel = TraceKernel::kAvx2;
  return o;
}

TEST(OverrideTable, EveryRowIsAProtoFieldAndEveryFieldARow) {
  std::set<std::string> rows, fields;
  for (const OverrideRow& r : overrideTable()) EXPECT_TRUE(rows.insert(r.name).second) << "two rows named " << r.name;
  const auto* d = v1::RenderOverrides::descriptor();
  for (int i = 0; i < d->field_count(); ++i) fields.insert(d->field(i)->name());
  EXPECT_EQ(rows, fields);
}

TEST(OverrideTable, EveryOverrideSurvivesTheProtoAndTheStoredJob) {
  const RenderOverrides o = everyOverride();
  const json all = overridesToJson(o);
  EXPECT_EQ(all.size(), overrideTable().size()) << all.dump() << ": a row the test does not set";
  EXPECT_EQ(overridesToJson(proto::fromProto(proto::toProto(o))), all);
  EXPECT_EQ(overridesToJson(overridesFromJson(json::parse(all.dump()))), all);
  EXPECT_EQ(*proto::fromProto(proto::toProto(o)).seed, UINT64_MAX);
  EXPECT_TRUE(overridesToJson(proto::fromProto(proto::toProto(RenderOverrides{}))).empty());
}

TEST(OverrideTable, AValueOfTheWrongKindIsRefusedNamingItsField) {
  for (const OverrideRow& r : overrideTable()) {
    SCOPED_TRACE(r.name);
    RenderOverrides o;
    const json wrong = r.get(everyOverride())->is_string() ? json(17) : json("seventeen");
    try {
      r.set(o, wrong);
      ADD_FAILURE() << "accepted " << wrong.dump();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("overrides." + r.name + ": "), std::string::npos) << e.what();
    }
  }
}

TEST(OverrideTable, AnUnknownNameInARequestIsInvalidArgument) {
  v1::RenderOverrides p;
  p.set_integrator("bidirectional");
  try {
    proto::fromProto(p);
    ADD_FAILURE() << "accepted";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("overrides.integrator: unknown integrator \"bidirectional\""),
              std::string::npos)
        << e.what();
  }
}

TEST(OverrideTable, EveryFlagIsOfferedByRenderAndSubmit) {
  for (const char* command : {"render", "submit"}) {
    const auto r = test::runProcess({test::cliPath().string(), command, "--help"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const OverrideRow& row : overrideTable()) {
      if (row.flag.empty()) continue;
      EXPECT_NE(r.out.find(row.flag), std::string::npos) << command << " lacks " << row.flag;
    }
  }
}

TEST(OverrideTable, TheCliTakesEveryFlagAndSetsWhatItSays) {
  // Every flag at once through the real binary; the EXR shows the size and samples asked for, and
  // the seed (a flag the EXR does not record) changes the pixels.
  test::TempDir dir;
  const auto scene = dir / "s.json";
  std::ofstream(scene) << test::minimalSceneJson().dump();
  const auto render = [&](const std::string& seed, const std::string& name) {
    const auto exr = dir / name;
    const auto r = test::runProcess({test::cliPath().string(),
                                     "render",
                                     scene.string(),
                                     "--spp",
                                     "3",
                                     "--resolution",
                                     "20x10",
                                     "--max-bounces",
                                     "2",
                                     "--seed",
                                     seed,
                                     "--integrator",
                                     "nee",
                                     "--sampler",
                                     "independent",
                                     "--russian-roulette",
                                     "off",
                                     "--tile-size",
                                     "off",
                                     "--aov",
                                     "albedo",
                                     "--aov",
                                     "depth",
                                     "--adaptive",
                                     "off",
                                     "--ev",
                                     "1",
                                     "--target-error",
                                     "0.5",
                                     "--deadline",
                                     "10m",
                                     "-q",
                                     "-o",
                                     exr.string()});
    EXPECT_EQ(r.exitCode, 0) << r.out << r.err;
    ImageMetadata metadata;
    const Image image = readExr(exr, &metadata);
    EXPECT_EQ(image.width, 20);
    EXPECT_EQ(image.height, 10);
    EXPECT_LE(metadata.samplesPerPixel, 3u);
    return image.rgb;
  };
  EXPECT_NE(render("9", "a.exr"), render("10", "b.exr"));
  // Without a stopping rule the job renders exactly the samples --spp asks for (the scene says 2).
  const auto exact = dir / "exact.exr";
  const auto plain = test::runProcess({test::cliPath().string(), "render", scene.string(), "--spp", "3", "--resolution",
                                       "20x10", "-q", "-o", exact.string()});
  ASSERT_EQ(plain.exitCode, 0) << plain.err;
  ImageMetadata metadata;
  const Image image = readExr(exact, &metadata);
  EXPECT_EQ(metadata.samplesPerPixel, 3u);
  EXPECT_EQ(image.width, 20);
  const auto twice = test::runProcess({test::cliPath().string(), "render", scene.string(), "--spp", "3", "--spp", "4"});
  EXPECT_EQ(twice.exitCode, 2) << "a single-valued flag given twice: " << twice.err;
}

}  // namespace
}  // namespace lensfarm
