// `lensfarm study --quick` end to end: every output exists, the plots are PNG files gnuplot drew,
// and the numbers say what physics says they must (errors fall with time, blur follows thin-lens
// optics, light-hit fractions and energy grow with the bounce limit).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

using Csv = std::vector<std::map<std::string, std::string>>;

Csv readCsv(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> header;
  Csv rows;
  for (std::string line; std::getline(in, line);) {
    // RFC 4180 cells: a quoted cell may hold commas ("" is a quote inside one).
    std::vector<std::string> cells(1);
    bool quoted = false;
    for (size_t k = 0; k < line.size(); ++k) {
      const char c = line[k];
      if (quoted && c == '"' && k + 1 < line.size() && line[k + 1] == '"') {
        cells.back() += '"';
        ++k;
      } else if (c == '"') {
        quoted = !quoted;
      } else if (c == ',' && !quoted) {
        cells.emplace_back();
      } else {
        cells.back() += c;
      }
    }
    if (header.empty()) {
      header = cells;
      continue;
    }
    std::map<std::string, std::string> row;
    for (size_t k = 0; k < header.size() && k < cells.size(); ++k) row[header[k]] = cells[k];
    rows.push_back(row);
  }
  return rows;
}

double num(const std::map<std::string, std::string>& row, const std::string& column) {
  return std::stod(row.at(column));
}

// One quick study (a few seconds) checked from every side; ctest runs each TEST in its own
// process, so one TEST keeps it to one run.
struct StudyRun {
  test::TempDir dir;
  test::ProcessResult result;
  fs::path out(const std::string& name) const { return dir.path() / "out" / name; }
};

// A variant table's rows by their variant's name.
std::map<std::string, std::map<std::string, std::string>> rowsByVariant(const StudyRun& run, const char* csv) {
  std::map<std::string, std::map<std::string, std::string>> rows;
  for (const auto& row : readCsv(run.out(csv))) rows[row.at("variant")] = row;
  return rows;
}

void checkReportTablesAndPlots(const StudyRun& run) {
  const std::string report = test::readFile(run.dir.path() / "docs" / "accuracy.md");
  for (const char* section :
       {"## Convergence", "## The live error estimate", "## Resolution", "## Depth of field", "## Bounces",
        "## Glass and metal", "## Models", "## Camera optics", "## Uniform sampling against",
        "## Adaptive sampling against uniform sampling", "## Participating media", "## Many lights",
        "## Light points by solid angle", "## Path guiding", "lensfarm study"})
    EXPECT_NE(report.find(section), std::string::npos) << section;
  for (const char* plot : {"convergence", "estimate", "resolution", "dof", "bounces", "materials", "models", "optics",
                           "denoise", "adaptive", "media", "lights", "near-lights", "guiding"}) {
    EXPECT_NE(report.find("(../out/" + std::string(plot) + ".png)"), std::string::npos) << "relative link to " << plot;
    const std::string png = test::readFile(run.out(std::string(plot) + ".png"));
    ASSERT_GT(png.size(), 2000u) << plot;
    EXPECT_EQ(png.substr(1, 3), "PNG") << plot;
  }
  for (const char* csv :
       {"convergence.csv", "time-to-error.csv", "estimate.csv", "resolution.csv", "dof.csv", "bounces.csv",
        "materials.csv", "models.csv", "optics.csv", "denoise.csv", "adaptive.csv", "media.csv"})
    EXPECT_GT(readCsv(run.out(csv)).size(), 2u) << csv;
  EXPECT_EQ(readCsv(run.out("lights.csv")).size(), 2u) << "the light tree and choosing by power";
  EXPECT_EQ(readCsv(run.out("near-lights.csv")).size(), 3u) << "auto, by area, by solid angle";
  EXPECT_EQ(readCsv(run.out("guiding.csv")).size(), 2u) << "off and guided";
}

void checkConvergence(const StudyRun& run) {
  std::map<std::string, std::vector<std::pair<double, double>>> series;  // config -> (spp, error)
  for (const auto& row : readCsv(run.out("convergence.csv")))
    series[row.at("config")].push_back({num(row, "spp"), num(row, "relative_rmse")});
  EXPECT_EQ(series.size(), 18u) << "3 estimators x 3 samplers x roulette on/off";
  for (const auto& [config, points] : series) {
    ASSERT_GE(points.size(), 3u) << config;
    EXPECT_LT(points.back().second, 0.7 * points.front().second) << config << ": more samples, less error";
  }
  // At equal samples, NEE + MIS is far less noisy than the 2013 report's estimator. (Each runs for the
  // same time, so on a loaded machine they end at different counts: compare at the largest count
  // both reached.)
  std::map<double, double> mis, naive;
  for (const auto& [spp, error] : series["nee_mis/sobol"]) mis[spp] = error;
  for (const auto& [spp, error] : series["naive/independent"]) naive[spp] = error;
  double common = 0.0;
  for (const auto& [spp, error] : mis)
    if (naive.count(spp)) common = spp;
  ASSERT_GT(common, 0.0) << "no sample count both reached";
  EXPECT_LT(mis[common], naive[common]) << "at " << common << " spp";
}

void checkDepthOfField(const StudyRun& run) {
  const Csv rows = readCsv(run.out("dof.csv"));
  ASSERT_EQ(rows.size(), 16u) << "4 f-numbers x (focus, near limit, far limit, off focus)";
  for (const auto& row : rows) {
    const double predicted = num(row, "predicted 10-90 width (px)"), measured = num(row, "measured 10-90 width (px)");
    EXPECT_NEAR(measured / predicted, 1.0, 0.2) << "N = " << row.at("N") << " at " << row.at("distance");
    if (row.at("plane") == "focus") {
      EXPECT_LE(measured, 0.85) << "in focus only the pixel blurs";
    }
  }
}

void checkBounces(const StudyRun& run) {
  double lastHits = 0.0, lastEnergy = 0.0;
  for (const auto& row : readCsv(run.out("bounces.csv"))) {
    if (row.at("estimator") != "naive") continue;
    const double hits = std::stod(row.at("light-hit fraction")), energy = num(row, "energy vs B = 8");
    EXPECT_GT(hits, lastHits) << "B = " << row.at("B");
    EXPECT_GT(energy, lastEnergy) << "B = " << row.at("B");
    EXPECT_LT(energy, 1.02);
    lastHits = hits;
    lastEnergy = energy;
  }
  EXPECT_GT(lastHits, 0.0);
}

// Energy compensation keeps a rough metal's light: the variant without it is darker, and the
// diffuse stand-ins simulate no glass or metal.
void checkMaterials(const StudyRun& run) {
  const auto rows = rowsByVariant(run, "materials.csv");
  ASSERT_EQ(rows.size(), 9u);
  const auto& outdoors = rows.at("outdoors, lit by an environment map (sky and sun)");
  EXPECT_NE(outdoors.at("effects").find("environment"), std::string::npos);
  // Light paths from the sky through the glass ball, and the row without them.
  EXPECT_NE(outdoors.at("effects").find("light path(s) per camera path from environment"), std::string::npos)
      << outdoors.at("effects");
  const auto& alone = rows.at("outdoors, camera paths alone (no light paths)");
  EXPECT_EQ(alone.at("effects").find("light path"), std::string::npos) << alone.at("effects");
  EXPECT_EQ(alone.at("image mean"), outdoors.at("image mean")) << "one reference: the one with light paths";
  // The thin-walled ball is a thin wall, and only that variant pays for one.
  EXPECT_NE(rows.at("thin-walled glass (a thin wall), rough gold 0.3").at("effects").find("let light straight through"),
            std::string::npos);
  EXPECT_EQ(rows.at("smooth glass, rough gold 0.3").at("effects").find("let light straight through"),
            std::string::npos);
  EXPECT_LT(num(rows.at("smooth glass, rough gold 1.0, no energy compensation"), "image mean"),
            num(rows.at("smooth glass, rough gold 1.0"), "image mean"));
  EXPECT_EQ(rows.at("diffuse stand-ins").at("effects"), "diffuse only");
  EXPECT_NE(rows.at("rough glass 0.3, rough gold 0.3").at("effects").find("rough glass"), std::string::npos);
}

// The textured model shades per point and says so; its stand-ins with one material do not
// texture anything.
void checkModels(const StudyRun& run) {
  const auto rows = rowsByVariant(run, "models.csv");
  ASSERT_EQ(rows.size(), 3u);
  const auto& textured = rows.at("as modelled: textures, normal maps, cut-outs, smooth normals");
  EXPECT_NE(textured.at("effects").find("textured material"), std::string::npos) << textured.at("effects");
  EXPECT_NE(rows.at("one Lambertian material, smooth normals").at("effects").find("0 textured material(s)"),
            std::string::npos);
  EXPECT_GT(num(textured, "image mean"), 0.0);
}

// Participating media: the baseline runs without them and says so, each medium is named where it
// is used, the volume tracer's walks cost rays, equiangular sampling is on in the fog and off in
// its free-flight rows (one more shadow ray per segment), and cutting walks short loses light.
void checkMedia(const StudyRun& run) {
  const auto rows = rowsByVariant(run, "media.csv");
  ASSERT_EQ(rows.size(), 8u);
  const auto& none = rows.at("no media (marble block Lambertian, empty glass)");
  const auto& all = rows.at("all three (the scene)");
  EXPECT_EQ(none.at("effects"), "none");
  EXPECT_NE(rows.at("fog bank only").at("effects").find("\"haze\" inside \"fog-bank\""), std::string::npos)
      << rows.at("fog bank only").at("effects");
  EXPECT_NE(rows.at("marble block only (random walk)").at("effects").find("inside \"marble\""), std::string::npos);
  EXPECT_NE(rows.at("glass of milk only").at("effects").find("\"milk\" inside \"milk-glass\""), std::string::npos);
  EXPECT_GT(num(all, "rays per path"), 2.0 * num(none, "rays per path")) << "walks cost rays";
  const auto& fog = rows.at("fog bank only");
  const auto& fogAlone = rows.at("fog bank only, free-flight sampling alone");
  EXPECT_NE(fog.at("effects").find("towards a point on a light"), std::string::npos) << fog.at("effects");
  EXPECT_EQ(fogAlone.at("effects").find("towards a point on a light"), std::string::npos) << fogAlone.at("effects");
  EXPECT_GT(num(fog, "rays per path"), num(fogAlone, "rays per path")) << "a shadow ray per segment in fog";
  EXPECT_EQ(rows.count("all three, free-flight sampling alone"), 1u);
  EXPECT_LT(num(rows.at("all three, max_medium_bounces 16"), "image mean"), num(all, "image mean"))
      << "a walk cut at 16 events loses light";
}

// Many lights: the tree row says it is on and over how many triangles, the by-power row says it is
// off; both are one image (their references are one), and the tree's error at the budget is lower.
void checkLights(const StudyRun& run) {
  const auto rows = rowsByVariant(run, "lights.csv");
  ASSERT_EQ(rows.size(), 2u);
  const auto& tree = rows.at("light tree (auto: on)");
  const auto& power = rows.at("by power (the light tree off)");
  EXPECT_NE(tree.at("effects").find("over 23034 emitting triangle(s)"), std::string::npos) << tree.at("effects");
  EXPECT_EQ(power.at("effects"), "none");
  EXPECT_EQ(num(tree, "image mean"), num(power, "image mean")) << "one reference";
  // At equal time the tree's error is lower where the choice of light matters: in the relMSE
  // (each pixel's error over its own value: the walls and the street). The relative RMSE is ruled
  // by the directly seen windows' edges, the same noise in both rows (docs/accuracy.md).
  EXPECT_LT(num(tree, "relMSE at budget"), num(power, "relMSE at budget"));
  EXPECT_LE(num(tree, "rel. RMSE at budget"), 1.1 * num(power, "rel. RMSE at budget"));
}

// Near lights: one image three ways (one reference); by area, the ceiling over the two-sided lamp
// gets fireflies, so its error at the budget is the highest; by solid angle everywhere pays libm
// calls at every point for nothing, so auto's time per path is not above it.
void checkNearLights(const StudyRun& run) {
  const auto rows = rowsByVariant(run, "near-lights.csv");
  ASSERT_EQ(rows.size(), 3u);
  const auto& automatic = rows.at("auto: by solid angle within two radii of a triangle");
  const auto& area = rows.at("by area everywhere");
  const auto& everywhere = rows.at("by solid angle everywhere");
  EXPECT_EQ(num(automatic, "image mean"), num(area, "image mean")) << "one reference";
  EXPECT_EQ(num(automatic, "image mean"), num(everywhere, "image mean")) << "one reference";
  EXPECT_GT(num(area, "worst 1 % at budget"), num(automatic, "worst 1 % at budget")) << "the fireflies";
}

// Path guiding: one image two ways (one reference, the unguided one); the guided row says so.
void checkGuiding(const StudyRun& run) {
  const auto rows = rowsByVariant(run, "guiding.csv");
  ASSERT_EQ(rows.size(), 2u);
  const auto& off = rows.at("path tracer (guiding off)");
  const auto& guided = rows.at("guided (on)");
  EXPECT_EQ(num(off, "image mean"), num(guided, "image mean")) << "one reference";
  EXPECT_NE(guided.at("effects").find("training passes"), std::string::npos) << guided.at("effects");
  EXPECT_EQ(off.at("effects").find("training passes"), std::string::npos) << off.at("effects");
}

// Every camera model renders; the real lenses say they trace every camera ray; the thin lens
// keeps the 2013 report's convention that the aperture does not change the brightness.
void checkOptics(const StudyRun& run) {
  const auto rows = rowsByVariant(run, "optics.csv");
  ASSERT_EQ(rows.size(), 6u);
  const double pinhole = num(rows.at("pinhole"), "image mean");
  EXPECT_GT(pinhole, 0.0);
  for (const char* thin : {"thin lens f/2.8, round aperture", "thin lens f/2.8, 6 straight blades",
                           "thin lens f/2.8, 7 curved blades (curvature 0.15)"})
    EXPECT_NEAR(num(rows.at(thin), "image mean") / pinhole, 1.0, 0.05) << thin;
  int real = 0;
  for (const auto& [name, row] : rows) {
    if (name.rfind("real lens", 0) != 0) continue;
    ++real;
    EXPECT_NE(row.at("effects").find("every camera ray traced"), std::string::npos) << row.at("effects");
    EXPECT_NE(row.at("effects").find("each camera sample traced at its own wavelength"), std::string::npos)
        << "both lenses carry Abbe numbers: " << row.at("effects");
    EXPECT_GT(num(row, "image mean"), 0.0) << name;
  }
  EXPECT_EQ(real, 2);
}

// Uniform sampling against uniform + denoise: both series at the same checkpoints; at 2 spp the
// denoiser wins on cornell-seed (its noise dwarfs the bias); the raw error falls with samples; the
// denoiser's bias at convergence is reported, finite, and below the raw error at 2 spp.
void checkDenoise(const StudyRun& run) {
  std::map<std::string, std::vector<std::map<std::string, std::string>>> series;
  for (const auto& row : readCsv(run.out("denoise.csv"))) series[row.at("series")].push_back(row);
  ASSERT_EQ(series.size(), 2u);
  const auto& raw = series["uniform"];
  const auto& denoised = series["uniform+denoise"];
  ASSERT_GE(raw.size(), 3u);
  ASSERT_EQ(denoised.size(), raw.size());
  EXPECT_EQ(num(raw.front(), "spp"), 2.0);
  EXPECT_LT(num(denoised.front(), "relative_rmse"), 0.7 * num(raw.front(), "relative_rmse"))
      << "at 2 spp the denoiser removes most of the error";
  EXPECT_LT(num(raw.back(), "relative_rmse"), 0.7 * num(raw.front(), "relative_rmse")) << "more samples, less error";
  for (size_t k = 0; k < raw.size(); ++k) {
    EXPECT_EQ(raw[k].at("spp"), denoised[k].at("spp"));
    EXPECT_GT(num(denoised[k], "seconds"), num(raw[k], "seconds")) << "the denoiser's time is charged";
    EXPECT_GT(num(denoised[k], "worst_1pct_relative_error"), 0.0);
  }
  const Csv summary = readCsv(run.out("denoise-summary.csv"));
  ASSERT_EQ(summary.size(), 1u);
  const double bias = num(summary[0], "bias_at_convergence");
  EXPECT_TRUE(std::isfinite(bias));
  EXPECT_GT(bias, 0.0);
  EXPECT_LT(bias, num(raw.front(), "relative_rmse"));
  EXPECT_GE(num(summary[0], "crossover_seconds"), 0.0) << "a time, or inf where the curves do not converge";
  const std::string report = test::readFile(run.dir.path() / "docs" / "accuracy.md");
  EXPECT_NE(report.find("denoiser's bias at convergence"), std::string::npos);
  EXPECT_NE(report.find("Crossover"), std::string::npos);
}

TEST(Study, QuickRunWritesEverythingAndItsNumbersFollowThePhysics) {
  StudyRun run;
  run.result =
      test::runProcess({test::cliPath().string(), "study", "--quick", "--out", (run.dir.path() / "out").string(),
                        "--report", (run.dir.path() / "docs" / "accuracy.md").string()},
                       600);
  ASSERT_EQ(run.result.exitCode, 0) << run.result.err;
  {
    SCOPED_TRACE("report, tables and plots");
    checkReportTablesAndPlots(run);
  }
  {
    SCOPED_TRACE("convergence");
    checkConvergence(run);
  }
  {
    SCOPED_TRACE("depth of field");
    checkDepthOfField(run);
  }
  {
    SCOPED_TRACE("bounces");
    checkBounces(run);
  }
  {
    SCOPED_TRACE("materials");
    checkMaterials(run);
  }
  {
    SCOPED_TRACE("models");
    checkModels(run);
  }
  {
    SCOPED_TRACE("optics");
    checkOptics(run);
  }
  {
    SCOPED_TRACE("denoise");
    checkDenoise(run);
  }
  {
    SCOPED_TRACE("media");
    checkMedia(run);
  }
  {
    SCOPED_TRACE("lights");
    checkLights(run);
  }
  {
    SCOPED_TRACE("near lights");
    checkNearLights(run);
  }
  {
    SCOPED_TRACE("guiding");
    checkGuiding(run);
  }
}

// Uniform against adaptive against uniform + denoise, each rendered on its own at every count: the
// three series at the same counts; more samples, less error; adaptive sampling really changed where
// the samples went (its image differs from uniform's once passes hold more than the floor's one
// sample); it stays unbiased (mean ratio) and its live estimate follows the true error; the time to
// each target is reported for all three.
TEST(Study, AdaptiveExperimentComparesTheThreeWaysOfSpendingSamples) {
  StudyRun run;
  run.result = test::runProcess(
      {test::cliPath().string(), "study", "--quick", "--experiments", "adaptive", "--out",
       (run.dir.path() / "out").string(), "--report", (run.dir.path() / "docs" / "accuracy.md").string()},
      300);
  ASSERT_EQ(run.result.exitCode, 0) << run.result.err;
  std::map<std::string, std::vector<std::map<std::string, std::string>>> series;
  for (const auto& row : readCsv(run.out("adaptive.csv"))) series[row.at("series")].push_back(row);
  ASSERT_EQ(series.size(), 3u);
  const auto& uniform = series["uniform"];
  const auto& adaptive = series["adaptive"];
  const auto& denoised = series["uniform + denoise"];
  ASSERT_GE(uniform.size(), 3u);
  ASSERT_EQ(adaptive.size(), uniform.size());
  ASSERT_EQ(denoised.size(), uniform.size());
  for (size_t k = 0; k < uniform.size(); ++k) {
    EXPECT_EQ(adaptive[k].at("spp"), uniform[k].at("spp")) << "the same mean samples per pixel";
    EXPECT_EQ(denoised[k].at("spp"), uniform[k].at("spp"));
    if (k > 0) {
      EXPECT_GT(num(uniform[k], "spp"), num(uniform[k - 1], "spp"));
    }
  }
  const double adaptiveLast = num(adaptive.back(), "relative_rmse");
  EXPECT_TRUE(std::isfinite(adaptiveLast));
  EXPECT_LT(adaptiveLast, num(uniform.front(), "relative_rmse")) << "more samples, less error";
  EXPECT_LT(num(uniform.back(), "relative_rmse"), 0.7 * num(uniform.front(), "relative_rmse"));
  EXPECT_NE(adaptive.back().at("relative_rmse"), uniform.back().at("relative_rmse"))
      << "the adaptive render spent its samples differently";
  EXPECT_NEAR(num(adaptive.back(), "mean_ratio"), 1.0, 0.05) << "no bias beyond the reference's noise";
  const double estimate = num(adaptive.back(), "estimated_relative_rmse");
  const double trueError = num(adaptive.back(), "relative_rmse_net_of_reference_noise");
  EXPECT_GT(estimate, 0.5 * trueError) << "the live estimate of an adaptive image follows its error";
  EXPECT_LT(estimate, 2.0 * trueError);
  EXPECT_EQ(num(denoised.back(), "estimated_relative_rmse"), -1.0) << "no live estimate of a denoised image";
  EXPECT_LT(num(denoised.front(), "relative_rmse"), num(uniform.front(), "relative_rmse"))
      << "at 16 spp the denoiser removes noise";

  const Csv targets = readCsv(run.out("adaptive-targets.csv"));
  ASSERT_EQ(targets.size(), 3u);
  for (const auto& row : targets) {
    for (const char* column : {"uniform_seconds", "adaptive_seconds", "denoise_seconds", "adaptive_speedup_in_samples"})
      EXPECT_GT(num(row, column), 0.0) << column;
    EXPECT_NEAR(num(row, "adaptive_speedup"), num(row, "uniform_seconds") / num(row, "adaptive_seconds"), 1e-2);
  }
  const std::string report = test::readFile(run.dir.path() / "docs" / "accuracy.md");
  EXPECT_NE(report.find("## Adaptive sampling against uniform sampling"), std::string::npos);
  EXPECT_NE(report.find("(../out/adaptive.png)"), std::string::npos);
  EXPECT_NE(report.find("**How it works**"), std::string::npos);
  EXPECT_EQ(report.find("## Uniform sampling against"), std::string::npos) << "only the experiment asked for";
  const std::string png = test::readFile(run.out("adaptive.png"));
  ASSERT_GT(png.size(), 2000u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
}

TEST(StudyInput, AnUnknownExperimentIsRefusedByName) {
  test::TempDir dir;
  const auto r = test::runProcess({test::cliPath().string(), "study", "--quick", "--out", dir.path().string(),
                                   "--experiments", "convergence,glitter"});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--experiments"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("glitter"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() / "accuracy.md")) << "nothing written";
}

}  // namespace
}  // namespace lensfarm
