// AOV layers in EXR files (docs/aovs.md): channel c of layer L is "L.c" ("c" for the unnamed
// layer, the standard depth channel Z), the beauty stays R, G, B, and what is written reads back
// bit for bit, whatever wrote the file.
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <gtest/gtest.h>

#include <set>

#include "common/film/image_io.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

Image layeredImage() {
  Image image(3, 2, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18});
  image.layers.push_back({"albedo", {"R", "G", "B"}, std::vector<float>(18, 0.25f)});
  image.layers.push_back({"", {"Z"}, {1.5f, 2.5f, 3.5f, 4.5f, 5.5f, std::numeric_limits<float>::infinity()}});
  image.layers.push_back({"object_id", {"id"}, {0, 1, 2, 3, 16777216, 7}});
  return image;
}

TEST(ExrLayers, TheFileNamesEachChannelLayerDotChannelAndReadsBackBitForBit) {
  test::TempDir dir;
  const Image image = layeredImage();
  writeExr(dir.path() / "aov.exr", image, ImageMetadata{});

  Imf::InputFile file((dir.path() / "aov.exr").c_str());
  std::set<std::string> names;
  for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) names.insert(it.name());
  EXPECT_EQ(names, (std::set<std::string>{"R", "G", "B", "Z", "albedo.R", "albedo.G", "albedo.B", "object_id.id"}));

  const Image back = readExr(dir.path() / "aov.exr");
  EXPECT_EQ(back.rgb, image.rgb);
  ASSERT_EQ(back.layers.size(), 3u);
  for (const ImageLayer& written : image.layers) {
    const ImageLayer* read = back.layer(written.name);
    ASSERT_NE(read, nullptr) << written.name;
    EXPECT_EQ(read->channels, written.channels) << written.name;
    EXPECT_EQ(read->values, written.values) << written.name;
  }
}

TEST(ExrLayers, AFileFromAnotherToolGroupsItsChannelsByTheirLastDot) {
  // Blender writes "ViewLayer.Combined.R" and "ViewLayer.Depth.Z"; half-float channels read as float.
  test::TempDir dir;
  const int w = 2, h = 1;
  Imf::Header header(w, h);
  for (const char* name : {"ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Depth.Z"})
    header.channels().insert(name, Imf::Channel(Imf::FLOAT));
  header.channels().insert("ViewLayer.Denoising Albedo.R", Imf::Channel(Imf::HALF));
  std::vector<float> r{1, 2}, g{3, 4}, z{5, 6};
  std::vector<half> a{half(0.5f), half(0.75f)};
  {
    Imf::OutputFile out((dir.path() / "blender.exr").c_str(), header);
    Imf::FrameBuffer fb;
    fb.insert("ViewLayer.Combined.R", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(r.data()), 4, 8));
    fb.insert("ViewLayer.Combined.G", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(g.data()), 4, 8));
    fb.insert("ViewLayer.Depth.Z", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(z.data()), 4, 8));
    fb.insert("ViewLayer.Denoising Albedo.R", Imf::Slice(Imf::HALF, reinterpret_cast<char*>(a.data()), 2, 4));
    out.setFrameBuffer(fb);
    out.writePixels(h);
  }
  const Image back = readExr(dir.path() / "blender.exr");
  ASSERT_NE(back.layer("ViewLayer.Combined"), nullptr);
  EXPECT_EQ(back.layer("ViewLayer.Combined")->channels, (std::vector<std::string>{"R", "G"}));
  EXPECT_EQ(back.layer("ViewLayer.Combined")->values, (std::vector<float>{1, 3, 2, 4}));
  ASSERT_NE(back.layer("ViewLayer.Depth"), nullptr);
  EXPECT_EQ(back.layer("ViewLayer.Depth")->values, (std::vector<float>{5, 6}));
  ASSERT_NE(back.layer("ViewLayer.Denoising Albedo"), nullptr);
  EXPECT_EQ(back.layer("ViewLayer.Denoising Albedo")->values, (std::vector<float>{0.5f, 0.75f}));
}

TEST(ExrLayers, ALayerOfTheWrongSizeIsRefusedAndNoFileIsLeft) {
  test::TempDir dir;
  Image image = layeredImage();
  image.layers[0].values.pop_back();
  EXPECT_ANY_THROW(writeExr(dir.path() / "bad.exr", image, ImageMetadata{}));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "bad.exr"));
}

}  // namespace
}  // namespace lensfarm
