#include "client/study/study.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <sstream>
#include <thread>

#include "client/study/progressive.h"
#include "client/study/report.h"
#include "common/camera/depth_of_field.h"
#include "common/farm/job_layout.h"
#include "common/film/adaptive_allocation.h"
#include "common/film/denoiser.h"
#include "common/film/error_metrics.h"
#include "common/film/image_io.h"
#include "common/render/render_scene.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/file_contents.h"
#include "common/util/version.h"

namespace lensfarm::study {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Image sizes and budgets: the full study for the docs, and a quick one for tests.
struct Scale {
  int referenceSide;
  uint64_t referenceSpp;
  int convergenceSide;
  double convergenceBudget;  // seconds per configuration
  std::vector<int> resolutionSides;
  double resolutionBudget;
  double resolutionTarget;  // the "acceptable noise" of the resolution experiment
  int dofWidth;
  uint64_t dofSpp;
  int bounceSide;
  uint64_t bounceSpp;
  int materialsSide;
  uint64_t materialsReferenceSpp;
  double materialsBudget;  // seconds per variant
  int denoiseSide;
  uint64_t denoiseReferenceSpp;
  double denoiseBudget;                  // seconds of rendering
  std::vector<uint64_t> adaptiveCounts;  // mean samples per pixel of each render (adaptive experiment)
  double cheapSeconds;                   // renders faster than this are timed three times (median)
};
constexpr int kStudyBounces = 3;  // B for the convergence and resolution experiments
// The edge images of the depth-of-field experiment are wide strips (4 rows) so that a pixel is
// much smaller than the circle of confusion (0.094 mm on the 100 mm sensor).
const Scale kFull{256,
                  8192,
                  128,
                  6.0,
                  {64, 128, 256},
                  12.0,
                  0.04,
                  4096,
                  256,
                  128,
                  64,
                  128,
                  4096,
                  8.0,
                  128,
                  8192,
                  40.0,
                  {16, 32, 64, 128, 256, 512, 1024, 2048, 4096},
                  2.0};
const Scale kQuick{32, 256, 16,  0.15, {8, 16, 32}, 0.5, 0.10, 1024,         32, 16,
                   32, 16,  128, 0.3,  24,          256, 0.3,  {16, 32, 64}, 1.0};

struct Series {
  std::string name, integrator, sampler;
  bool roulette = false;
  std::vector<double> seconds, spp, error, estimate;  // error: relative RMSE vs the reference
  std::vector<ImageError> details;
};

// Time for `s` to reach `target`, interpolated on log-log axes between checkpoints, or
// extrapolated from the nearest end as error ~ 1/sqrt(time). `extrapolated` says which.
double timeToError(const Series& s, double target, bool* extrapolated) {
  *extrapolated = false;
  for (size_t k = 0; k < s.error.size(); ++k) {
    if (s.error[k] > target) continue;
    if (k == 0) {
      *extrapolated = true;
      return s.seconds[0] * std::pow(s.error[0] / target, 2.0);
    }
    const double a = std::log(s.error[k - 1]), b = std::log(s.error[k]);
    const double t = (std::log(target) - a) / (b - a);
    return std::exp(std::log(s.seconds[k - 1]) + t * (std::log(s.seconds[k]) - std::log(s.seconds[k - 1])));
  }
  *extrapolated = true;
  return s.seconds.back() * std::pow(s.error.back() / target, 2.0);
}

// Error of `s` at `seconds`, interpolated the same way.
double errorAtTime(const Series& s, double seconds) {
  for (size_t k = 1; k < s.seconds.size(); ++k)
    if (s.seconds[k] >= seconds) {
      const double t =
          (std::log(seconds) - std::log(s.seconds[k - 1])) / (std::log(s.seconds[k]) - std::log(s.seconds[k - 1]));
      return std::exp(std::log(s.error[k - 1]) + t * (std::log(s.error[k]) - std::log(s.error[k - 1])));
    }
  return s.error.back() * std::sqrt(s.seconds.back() / seconds);
}

// An error measured against a reference with the reference's own error `floor` removed in
// quadrature (the two are independent); 0 where the floor is the larger.
double netError(double error, double floor) { return std::sqrt(std::max(0.0, error * error - floor * floor)); }

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

std::string machineDescription() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string model = "unknown CPU";
  for (std::string line; std::getline(cpuinfo, line);)
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  return std::to_string(std::thread::hardware_concurrency()) + " hardware threads, " + model;
}

class Study {
 public:
  explicit Study(const StudyOptions& o) : options_(o), scale_(o.quick ? kQuick : kFull) {
    fs::create_directories(options_.out);
    report_ = options_.report.empty() ? options_.out / "accuracy.md" : options_.report;
    if (report_.has_parent_path()) fs::create_directories(report_.parent_path());
    cache_ = options_.out / "cache";
    seed_ = loadScene(options_.scenes / "cornell-seed.json");
  }

  void run() {
    const auto start = std::chrono::steady_clock::now();
    const auto wants = [&](const char* name) {
      return options_.experiments.empty() || options_.experiments.count(name);
    };
    std::string body;
    if (wants("convergence") || wants("estimate") || wants("resolution")) makeReference();
    if (wants("convergence") || wants("estimate")) body += convergence(wants("convergence"), wants("estimate"));
    if (wants("resolution")) body += resolution();
    if (wants("dof")) body += depthOfField();
    if (wants("bounces")) body += bounces();
    if (wants("materials")) body += materials();
    if (wants("models")) body += models();
    if (wants("optics")) body += optics();
    if (wants("denoise")) body += denoising();
    if (wants("adaptive")) body += adaptiveSampling();
    if (wants("media")) body += media();
    if (wants("lights")) body += manyLights();
    if (wants("near-lights")) body += nearLights();
    if (wants("guiding")) body += pathGuiding();
    const double minutes = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / 60.0;
    writeBytesAtomically(report_, header(minutes) + body);
    spdlog::info("wrote {} ({:.1f} min)", report_.string(), minutes);
  }

 private:
  // ---- shared -------------------------------------------------------------------------------
  fs::path plotFile(const std::string& name) const { return options_.out / (name + ".png"); }
  std::string link(const std::string& name) const {
    const fs::path rel = fs::relative(plotFile(name), report_.parent_path().empty() ? "." : report_.parent_path());
    return "![" + name + "](" + rel.generic_string() + ")\n\n";
  }

  Scene seedAt(int side, int bounces) const {
    Scene s = seed_;
    s.render.width = s.render.height = side;
    s.render.maxBounces = bounces;
    s.render.samplesPerUnit = 0;
    // The estimators, samplers and settings themselves: path guiding has its own experiment.
    s.render.pathGuiding = PathGuidingMode::kOff;
    return s;
  }

  void makeReference() {
    reference_ = referenceImage(seedAt(scale_.referenceSide, kStudyBounces), scale_.referenceSpp, cache_,
                                &referenceError_, options_.threads);
  }
  Image referenceAt(int side) const { return side == reference_.width ? reference_ : downscaleToFit(reference_, side); }

  Series measure(Scene scene, const Image& reference, const ProgressiveRun& run, const std::string& name,
                 PathStats* stats = nullptr) const {
    Series s;
    s.name = name;
    s.integrator = integratorName(scene.render.integrator);
    s.sampler = samplerName(scene.render.sampler);
    s.roulette = scene.render.roulette != RouletteRule::kOff;
    renderProgressive(scene, run, [&](const Checkpoint& c) {
      const ImageError e = compareImages(c.image, reference, scene.render.exposure);
      s.seconds.push_back(c.seconds);
      s.spp.push_back(double(c.samplesPerPixel));
      s.error.push_back(e.relativeRmse);
      s.estimate.push_back(c.estimate.valid ? c.estimate.relativeRmse : -1.0);
      s.details.push_back(e);
      if (stats) *stats = c.stats;
      return true;
    });
    spdlog::info("{}: {} spp in {:.2f} s, relative RMSE {:.4f}", name, s.spp.back(), s.seconds.back(), s.error.back());
    return s;
  }

  // One line per series of relative RMSE against render time, on log-log axes, into plot `name`.
  void plotErrorAgainstTime(const std::string& name, const std::vector<Series>& all) const {
    std::string script = "set terminal pngcairo size 800,600 noenhanced\nset output " + gnuplotPath(plotFile(name)) +
                         "\nset logscale xy\nset xlabel 'render time (s)'\nset ylabel 'relative RMSE'\nset grid\nplot ";
    for (size_t k = 0; k < all.size(); ++k)
      script += (k ? ", " : "") + std::string("'-' with linespoints title '") + all[k].name + "'";
    script += "\n";
    for (const Series& s : all) {
      for (size_t k = 0; k < s.seconds.size(); ++k)
        script += number(s.seconds[k], 6) + " " + number(s.error[k], 6) + "\n";
      script += "e\n";
    }
    runGnuplot(script);
  }

  // ---- convergence: estimators x samplers x roulette ------------------------------------------
  std::string convergence(bool showConvergence, bool showEstimate) {
    const int side = scale_.convergenceSide;
    const Image reference = referenceAt(side);
    std::vector<Series> all;
    for (IntegratorKind integrator : {IntegratorKind::kNaive, IntegratorKind::kNee, IntegratorKind::kNeeMis})
      for (SamplerKind sampler : {SamplerKind::kIndependent, SamplerKind::kStratified, SamplerKind::kSobol})
        for (bool roulette : {false, true}) {
          Scene scene = seedAt(side, kStudyBounces);
          scene.render.integrator = integrator;
          scene.render.sampler = sampler;
          scene.render.roulette = roulette ? kRouletteOn : RouletteRule::kOff;
          ProgressiveRun run;
          run.firstCheckpoint = 16;
          run.budgetSeconds = scale_.convergenceBudget;
          run.threads = options_.threads;
          all.push_back(
              measure(scene, reference, run,
                      std::string(integratorName(integrator)) + "/" + samplerName(sampler) + (roulette ? "+rr" : "")));
        }

    Table csv({"config", "integrator", "sampler", "russian_roulette", "spp", "seconds", "rmse", "relative_rmse",
               "relative_mse", "display_rmse", "mean_ratio", "estimated_relative_rmse"});
    for (const Series& s : all)
      for (size_t k = 0; k < s.spp.size(); ++k)
        csv.add({s.name, s.integrator, s.sampler, s.roulette ? "on" : "off", number(s.spp[k], 10),
                 number(s.seconds[k], 4), number(s.details[k].rmse, 4), number(s.error[k], 4),
                 number(s.details[k].relativeMse, 4), number(s.details[k].displayRmse, 4),
                 number(s.details[k].meanRatio, 5), number(s.estimate[k], 4)});
    csv.writeCsv(options_.out / "convergence.csv");

    std::string md;
    if (showConvergence) md += convergenceSection(all, side);
    if (showEstimate) md += estimateSection(all);
    return md;
  }

  std::string convergenceSection(const std::vector<Series>& all, int side) {
    // The common error: the largest final error, so every configuration reaches it.
    double common = 0.0;
    for (const Series& s : all) common = std::max(common, s.error.back());
    const Series& seedConfig = all.front();  // naive / independent / no roulette: the report's
    bool ext = false;
    const double seedTime = timeToError(seedConfig, common, &ext);
    Table table({"integrator", "sampler", "roulette", "M paths/s", "time to " + number(100 * common, 2) + " % (s)",
                 "speed-up vs the 2013 report's", "rel. RMSE at " + number(scale_.convergenceBudget, 2) + " s",
                 "display RMSE at the end"});
    for (const Series& s : all) {
      bool extrapolated = false;
      const double t = timeToError(s, common, &extrapolated);
      const double pathsPerSecond = s.spp.back() * side * side / s.seconds.back();
      table.add({s.integrator, s.sampler, s.roulette ? "on" : "off", number(pathsPerSecond / 1e6, 3),
                 number(t, 3) + (extrapolated ? " (extrapolated)" : ""), number(seedTime / t, 3) + "x",
                 number(errorAtTime(s, scale_.convergenceBudget), 3), number(s.details.back().displayRmse, 3)});
    }
    table.writeCsv(options_.out / "time-to-error.csv");

    // Fig. 5 as numbers: the 2013 report's configuration, checkpoint by checkpoint.
    Table progressive({"spp", "seconds", "relative RMSE", "relMSE", "display RMSE (8-bit sRGB, 0..1)"});
    for (size_t k = 0; k < seedConfig.spp.size(); ++k)
      progressive.add({number(seedConfig.spp[k], 10), number(seedConfig.seconds[k], 3), number(seedConfig.error[k], 3),
                       number(seedConfig.details[k].relativeMse, 3), number(seedConfig.details[k].displayRmse, 3)});

    std::string script = "set terminal pngcairo size 1000,700 noenhanced\nset output " +
                         gnuplotPath(plotFile("convergence")) + "\nset logscale xy\nset xlabel 'render time (s, " +
                         std::to_string(std::thread::hardware_concurrency()) +
                         " threads)'\nset ylabel 'relative RMSE vs reference'\nset key outside right\nset grid\n"
                         "set datafile separator ','\nplot ";
    for (size_t k = 0; k < all.size(); ++k)
      script += (k ? ", " : "") + gnuplotPath(options_.out / "convergence.csv") + " using 6:(strcol(1) eq '" +
                all[k].name + "' ? $8 : 1/0) with linespoints title '" + all[k].name + "'";
    runGnuplot(script + "\n");

    return "## Convergence: estimators, samplers and Russian roulette\n\n"
           "cornell-seed, " +
           std::to_string(side) + "x" + std::to_string(side) + ", B = " + std::to_string(kStudyBounces) +
           ", every configuration rendered progressively for about " + number(scale_.convergenceBudget, 2) +
           " s and compared with the reference at every power-of-two sample count. The table gives the time each "
           "needs to reach the same relative RMSE (the largest final error among them, so every configuration "
           "reaches it), interpolated on log-log axes between checkpoints.\n\n" +
           table.markdown() + "\n" + link("convergence") +
           "### Progressive rendering (2013 report Fig. 5) as numbers\n\nThe report's configuration (naive estimator, "
           "independent random numbers): the error falls as 1/sqrt(samples), so each halving of the noise costs four "
           "times the time.\n\n" +
           progressive.markdown() + "\n" + "Data: `convergence.csv`, `time-to-error.csv`.\n\n";
  }

  std::string estimateSection(const std::vector<Series>& all) {
    Table table({"sampler", "checkpoints", "median estimated / true", "min", "max"});
    // Only checkpoints whose error is well above the reference's own (else the true error is
    // not known well enough to judge the estimate).
    std::map<std::string, std::vector<double>> ratios;
    for (const Series& s : all)
      for (size_t k = 0; k < s.error.size(); ++k)
        if (s.estimate[k] > 0.0 && s.error[k] > 2.0 * referenceError_) {
          // The true error includes the reference's own noise; remove it in quadrature.
          const double trueError = netError(s.error[k], referenceError_);
          ratios[s.sampler].push_back(s.estimate[k] / trueError);
        }
    for (const auto& [sampler, r] : ratios)
      table.add({sampler, std::to_string(r.size()), number(median(r), 3),
                 number(*std::min_element(r.begin(), r.end()), 3), number(*std::max_element(r.begin(), r.end()), 3)});
    table.writeCsv(options_.out / "estimate.csv");

    std::string script = "set terminal pngcairo size 800,700 noenhanced\nset output " +
                         gnuplotPath(plotFile("estimate")) +
                         "\nset logscale xy\nset xlabel 'true relative RMSE (vs reference)'\n"
                         "set ylabel 'live estimate (two half-images)'\nset key top left\nset grid\n"
                         "set datafile separator ','\nplot ";
    bool first = true;
    for (const char* sampler : {"independent", "stratified", "sobol"}) {
      script += std::string(first ? "" : ", ") + gnuplotPath(options_.out / "convergence.csv") +
                " using 8:((strcol(3) eq '" + sampler + "' && $12 > 0) ? $12 : 1/0) with points title '" + sampler +
                "'";
      first = false;
    }
    runGnuplot(script + ", x with lines title 'estimate = true'\n");
    return "## The live error estimate against the true error\n\n"
           "Every checkpoint of the convergence experiment with at least two units: the coordinator's estimate "
           "(film/convergence.h: two half-images of alternating units) against the error measured with the "
           "reference (the reference's own estimated error, " +
           number(100 * referenceError_, 2) +
           " %, removed in quadrature). The two halves are independent for every sampler (Sobol draws even and odd "
           "units from two independently scrambled replicates; stratified patterns are per unit), so the estimate "
           "of the mean squared error is unbiased; a ratio far from 1 would show correlation between the halves. "
           "Its spread comes from the few pixels that dominate the error of a small image.\n\n" +
           table.markdown() + "\n" + link("estimate");
  }

  // ---- resolution (2013 report Fig. 6) ---------------------------------------------------------------
  std::string resolution() {
    Table table({"resolution", "pixels", "rel. RMSE at " + number(scale_.resolutionBudget / 4, 2) + " s",
                 "time to " + number(100 * scale_.resolutionTarget, 2) + " % (s)", "time per pixel (us)"});
    std::vector<Series> all;
    std::vector<double> logPixels, logTimes;
    for (int side : scale_.resolutionSides) {
      Scene scene = seedAt(side, kStudyBounces);
      ProgressiveRun run;
      run.firstCheckpoint = 16;
      run.budgetSeconds = scale_.resolutionBudget;
      run.threads = options_.threads;
      all.push_back(measure(scene, referenceAt(side), run, std::to_string(side) + "x" + std::to_string(side)));
      // The reference's own noise, scaled to this resolution (a pixel here averages
      // (referenceSide / side)^2 of its cells), removed in quadrature: the target is near it.
      const double floor = referenceError_ * double(side) / double(scale_.referenceSide);
      for (double& e : all.back().error) e = std::sqrt(std::max(1e-12, e * e - floor * floor));
      bool extrapolated = false;
      const double t = timeToError(all.back(), scale_.resolutionTarget, &extrapolated);
      const double pixels = double(side) * side;
      logPixels.push_back(std::log(pixels));
      logTimes.push_back(std::log(t));
      table.add({all.back().name, number(pixels, 10), number(errorAtTime(all.back(), scale_.resolutionBudget / 4), 3),
                 number(t, 3) + (extrapolated ? " (extrapolated)" : ""), number(t / pixels * 1e6, 3)});
    }
    // Least-squares slope of log(time to target) against log(pixels): 1 means linear.
    double mx = 0, my = 0;
    for (size_t k = 0; k < logPixels.size(); ++k) mx += logPixels[k], my += logTimes[k];
    mx /= double(logPixels.size());
    my /= double(logTimes.size());
    double sxy = 0, sxx = 0;
    for (size_t k = 0; k < logPixels.size(); ++k) {
      sxy += (logPixels[k] - mx) * (logTimes[k] - my);
      sxx += (logPixels[k] - mx) * (logPixels[k] - mx);
    }
    slope_ = sxy / sxx;
    table.writeCsv(options_.out / "resolution.csv");

    plotErrorAgainstTime("resolution", all);
    return "## Resolution and noise (2013 report Fig. 6)\n\n"
           "cornell-seed, NEE + MIS, Sobol, B = " +
           std::to_string(kStudyBounces) +
           ". The references for the smaller images are the large reference box-filtered down (a pixel of the "
           "smaller image covers exactly the cells it replaces); the reference's own noise at each resolution is "
           "removed from the errors in quadrature. At a fixed time a larger image is noisier; the "
           "time to reach a fixed error grows with the pixel count as pixels^" +
           number(slope_, 3) + " (least-squares slope on log-log axes; the report claims linear, slope 1).\n\n" +
           table.markdown() + "\n" + link("resolution");
  }

  // ---- depth of field (2013 report Fig. 7, Table 1) --------------------------------------------------
  // A knife edge: an emitting half-plane (x < 0) at distance d in front of the report's camera,
  // nothing else. Camera rays that hit it see radiance 1, the others 0, so the image is the edge
  // convolved with the lens blur and the pixel footprint, with no other noise.
  Image renderEdge(double distance, double fNumber) const {
    const int width = scale_.dofWidth, height = 4;
    const double z = distance - 2.9;
    json scene = {
        {"format", "lensfarm-scene/1"},
        {"camera",
         {{"type", "thin_lens"},
          {"position", {0, 0, -2.9}},
          {"look_at", {0, 0, 0}},
          {"up", {0, 1, 0}},
          {"sensor_width", 0.1},
          {"focal_length", 0.095},
          {"focus_distance", 2.9}}},
        {"materials", {{"edge", {{"type", "emissive"}, {"radiance", 1.0}, {"two_sided", true}}}}},
        {"shapes", json::array({{{"type", "quad"},
                                 {"name", "edge"},
                                 {"material", "edge"},
                                 {"corner", {-20.0, -20.0, z}},
                                 {"edge1", {20.0, 0.0, 0.0}},
                                 {"edge2", {0.0, 40.0, 0.0}}}})},
        {"render", {{"resolution", {width, height}}, {"samples_per_pixel", scale_.dofSpp}, {"max_bounces", 0}}}};
    if (std::isfinite(fNumber)) scene["camera"]["f_number"] = fNumber;
    Scene s = parseScene(scene.dump(), "dof-edge.json");
    ProgressiveRun run;
    run.firstCheckpoint = scale_.dofSpp;
    run.maxSamples = scale_.dofSpp;
    run.threads = options_.threads;
    return renderProgressive(s, run).image;
  }

  // 10 %-90 % width in pixels of an edge profile sampled at pixel centres, by linear
  // interpolation between them (the same for the render and the prediction).
  static double profileWidth(std::vector<double> profile) {
    if (profile.front() < profile.back()) std::reverse(profile.begin(), profile.end());  // bright on the left
    auto crossing = [&](double level) {
      for (size_t x = 1; x < profile.size(); ++x)
        if (profile[x] <= level && profile[x - 1] > level)
          return double(x - 1) + (profile[x - 1] - level) / (profile[x - 1] - profile[x]);
      return 0.0;
    };
    return std::abs(crossing(0.1) - crossing(0.9));
  }

  static double edgeWidth(const Image& image) {  // rows averaged
    std::vector<double> profile(size_t(image.width), 0.0);
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) profile[size_t(x)] += image.at(x, y).g / float(image.height);
    return profileWidth(profile);
  }

  // The same width predicted by optics alone: a uniform disk of diameter `blur` pixels (the lens
  // aperture's image) convolved with a one-pixel box (the cell), edge response by quadrature,
  // sampled at the pixel centres (the edge lies on the boundary between the two middle pixels).
  static double predictedEdgeWidth(double blur) {
    const double r = blur / 2;
    auto disk = [&](double u) {  // fraction of the disk left of x = u
      if (r < 1e-9) return u < 0 ? 0.0 : 1.0;
      if (u <= -r) return 0.0;
      if (u >= r) return 1.0;
      const double segment = r * r * std::acos(u / r) - u * std::sqrt(r * r - u * u);  // area right of u
      return 1.0 - segment / (std::numbers::pi * r * r);
    };
    auto cell = [&](double x) {
      const int n = 400;
      double s = 0;
      for (int k = 0; k < n; ++k) s += disk(x - 0.5 + (k + 0.5) / n);
      return s / n;
    };
    std::vector<double> profile;
    const int half = int(r) + 3;
    for (int k = -half; k < half; ++k) profile.push_back(1.0 - cell(k + 0.5));  // bright on the left
    return profileWidth(profile);
  }

  std::string depthOfField() {
    const double f = 0.095, s1 = 2.9, sensor = 0.1;
    const double coc = circleOfConfusion(sensor, sensor);  // Table 1's square 0.1 x 0.1 sensor
    const double pitch = sensor / scale_.dofWidth;         // metres per pixel on the sensor
    const double s2 = f * s1 / (s1 - f);
    Table table({"N", "plane", "distance", "blur circle (mm)", "blur (px)", "predicted 10-90 width (px)",
                 "measured 10-90 width (px)", "DoF report eq. 9-10", "DoF textbook"});
    std::vector<std::vector<double>> points;
    for (double n : {16.0, 8.0, 4.0, 2.0}) {
      const DepthOfField seedDof = seedDepthOfField(f, s1, n, coc), book = textbookDepthOfField(f, s1, n, coc);
      std::vector<std::pair<std::string, double>> planes = {
          {"focus", s1}, {"near limit DN (textbook)", book.nearLimit}, {"off focus", 2.0}};
      if (std::isfinite(book.farLimit)) planes.insert(planes.begin() + 2, {"far limit DF (textbook)", book.farLimit});
      for (const auto& [plane, d] : planes) {
        // Thin lens: the plane at d focuses at v = f d / (d - f); the sensor sits at S2, so a
        // point spreads over a disk of diameter A |S2 - v| / v, A = f / N (2013 report eq. 6-7).
        const double v = f * d / (d - f);
        const double blur = (f / n) * std::abs(s2 - v) / v;
        const double predicted = predictedEdgeWidth(blur / pitch);
        const double measured = edgeWidth(renderEdge(d, n));
        points.push_back({predicted, measured});
        table.add({number(n, 3), plane, number(d, 4), number(blur * 1e3, 3), number(blur / pitch, 3),
                   number(predicted, 3), number(measured, 3), number(seedDof.depth(), 3), number(book.depth(), 3)});
      }
    }
    table.writeCsv(options_.out / "dof.csv");
    std::string script =
        "set terminal pngcairo size 700,600 noenhanced\nset output " + gnuplotPath(plotFile("dof")) +
        "\nset xlabel 'predicted edge width (px, thin lens + pixel)'\nset ylabel 'measured edge width (px)'"
        "\nset grid\nset key top left\nplot '-' with points pt 7 title 'renders', x with lines title "
        "'measured = predicted'\n";
    for (const auto& p : points) script += number(p[0], 6) + " " + number(p[1], 6) + "\n";
    runGnuplot(script + "e\n");
    return "## Depth of field vs f-number (2013 report Fig. 7, Table 1)\n\n"
           "The 2013 report's camera (f = 0.095, sensor 0.1 wide, focused at S1 = 2.9) looks at a sharp emitting edge; "
           "the "
           "10 %-90 % width of the edge in a " +
           std::to_string(scale_.dofWidth) + "-pixel-wide image (" + number(pitch * 1e3, 3) + " mm per pixel, " +
           std::to_string(scale_.dofSpp) +
           " spp) is measured and compared with thin-lens optics: a disk of diameter A |S2 - v| / v convolved "
           "with the pixel. At the focus plane only the pixel blurs the edge (0.8 px); at the near limit DN of the "
           "textbook depth of field the blur circle equals the circle of confusion c = " +
           number(coc * 1e3, 3) +
           " mm (d/1500), by definition. The last two columns are Table 1's depth of field DF - DN from the report's "
           "equations and from the textbook's (`lensfarm dof` prints both).\n\n" +
           table.markdown() + "\n" + link("dof");
  }

  // ---- bounces (2013 report Fig. 8) ------------------------------------------------------------------
  std::string bounces() {
    const int side = scale_.bounceSide;
    Table table({"estimator", "B", "us per path", "rays per path", "light-hit fraction", "energy vs B = 8",
                 "estimated rel. RMSE", "rel. RMSE x sqrt(time)"});
    double energy8 = 0.0;
    {
      Scene scene = seedAt(side, 8);
      scene.render.roulette = RouletteRule::kOff;
      ProgressiveRun run;
      run.firstCheckpoint = scale_.bounceSpp;
      run.maxSamples = scale_.bounceSpp * 4;
      run.threads = options_.threads;
      energy8 = meanValue(renderProgressive(scene, run).image);
    }
    std::string data;
    for (IntegratorKind integrator : {IntegratorKind::kNaive, IntegratorKind::kNeeMis}) {
      for (int b = 1; b <= 5; ++b) {
        Scene scene = seedAt(side, b);
        scene.render.integrator = integrator;
        scene.render.roulette = RouletteRule::kOff;  // Fig. 8 is without roulette: every path reaches B
        ProgressiveRun run;
        run.firstCheckpoint = scale_.bounceSpp;
        run.maxSamples = scale_.bounceSpp;
        run.threads = options_.threads;
        scene.render.samplesPerUnit = uint32_t(std::max<uint64_t>(1, scale_.bounceSpp / 4));
        const Checkpoint c = renderProgressive(scene, run);
        const double paths = double(c.stats.paths);
        const double hit = double(c.stats.lightHits) / paths;
        const double energy = meanValue(c.image) / energy8;
        table.add({integratorName(integrator), std::to_string(b),
                   number(c.seconds / paths * 1e6 * double(std::thread::hardware_concurrency()), 3),
                   number(double(c.stats.rays) / paths, 3), number(100 * hit, 3) + " %", number(energy, 4),
                   number(c.estimate.relativeRmse, 3), number(c.estimate.relativeRmse * std::sqrt(c.seconds), 3)});
        data += std::string(integratorName(integrator)) + " " + std::to_string(b) + " " + number(100 * hit, 5) + " " +
                number(energy, 5) + "\n";
      }
    }
    table.writeCsv(options_.out / "bounces.csv");
    std::string script = "set terminal pngcairo size 800,600 noenhanced\nset output " +
                         gnuplotPath(plotFile("bounces")) +
                         "\nset xlabel 'bounce limit B'\nset ylabel 'naive light-hit fraction (%)'\nset y2label "
                         "'energy relative to B = 8'\nset ytics nomirror\nset y2tics\nset grid\nset key bottom right\n"
                         "plot '-' using 2:3 with linespoints title 'light-hit fraction (naive)', "
                         "'-' using 2:4 axes x1y2 with linespoints title 'energy (NEE + MIS)', "
                         "'-' using 1:2 with points pt 6 ps 2 title 'the report: 6.1, 9.3, 12 %'\n";
    for (const char* want : {"naive", "nee_mis"}) {
      std::istringstream lines(data);
      for (std::string line; std::getline(lines, line);)
        if (line.rfind(want, 0) == 0 && line[std::string(want).size()] == ' ') script += line + "\n";
      script += "e\n";
    }
    script += "1 6.1\n2 9.3\n3 12\ne\n";
    runGnuplot(script);
    return "## Bounces (2013 report Fig. 8)\n\n"
           "cornell-seed, " +
           std::to_string(side) + "x" + std::to_string(side) + ", " + std::to_string(scale_.bounceSpp) +
           " spp. Time per path is per thread (wall time x threads / paths). The light-hit fraction is the share of "
           "paths whose camera or scattered ray reached a light (the report measured 6.1, 9.3 and 12 % for "
           "B = 1, 2, 3 with its light). Energy is the image mean against B = 8: what the bounce limit cuts off (a "
           "bias no sample count removes). The last column is the noise at equal time (lower is better: "
           "relative RMSE x sqrt(seconds) is constant for a Monte Carlo estimator).\n\n" +
           table.markdown() + "\n" + link("bounces");
  }

  // The columns of a table of scene variants, and one variant measured into it (materials and
  // models): at materialsSide, against its own reference, the time per path, rays per path, the
  // image's mean, the error at the budget and the time to 5 %; its effects as the analysis lists
  // them.
  static Table variantTable() {
    return Table({"variant", "effects", "us per path", "rays per path", "image mean", "rel. RMSE at budget",
                  "relMSE at budget", "worst 1 % at budget", "time to 5 % (s)"});
  }
  // The effects a variant table lists (the others are the same in every row).
  static inline const std::set<std::string> kMaterialEffects = {
      "specular reflection",          "glossy materials", "thin walls",  "environment",
      "shading normals and textures", "light tracing",    "path guiding"};
  // `referenceFrom`: the reference is rendered from this variant of the scene instead (another
  // estimator of the same image, where the variant's own would miss what it fails to sample).
  // `budgetScale`: the budget times this, for a scene whose rows need more samples to reach its
  // error checkpoints (the time to 5 % is then measured, not extrapolated).
  void measureVariant(const fs::path& sceneFile, json j, const std::string& name, Table& table,
                      std::vector<Series>& all, const std::set<std::string>& listed = kMaterialEffects,
                      std::optional<json> referenceFrom = std::nullopt, double budgetScale = 1.0) {
    const int side = scale_.materialsSide;
    j["render"]["resolution"] = {side, side};
    j["render"]["samples_per_unit"] = 0;
    Scene scene = parseScene(j.dump(), sceneFile);
    Image reference;
    if (referenceFrom) {
      (*referenceFrom)["render"]["resolution"] = {side, side};
      (*referenceFrom)["render"]["samples_per_unit"] = 0;
      reference = referenceImage(parseScene(referenceFrom->dump(), sceneFile), scale_.materialsReferenceSpp, cache_,
                                 nullptr, options_.threads);
    } else {
      reference = referenceImage(scene, scale_.materialsReferenceSpp, cache_, nullptr, options_.threads);
    }
    ProgressiveRun run;
    run.firstCheckpoint = 4;
    run.budgetSeconds = scale_.materialsBudget * budgetScale;
    run.threads = options_.threads;
    PathStats stats;
    all.push_back(measure(scene, reference, run, name, &stats));
    const Series& s = all.back();
    bool extrapolated = false;
    const double t = timeToError(s, 0.05, &extrapolated);
    const double paths = double(stats.paths);
    const RenderScene rs(scene);
    std::string effects;
    for (const auto& d : rs.effects().decisions)
      if (listed.count(d.effect) && d.simulated)
        effects += (effects.empty() ? "" : "; ") + (d.effect == "environment" ? "environment " + d.reason : d.reason);
    table.add({name, effects.empty() ? (&listed == &kMaterialEffects ? "diffuse only" : "none") : effects,
               number(s.seconds.back() / paths * 1e6 * double(std::thread::hardware_concurrency()), 3),
               number(double(stats.rays) / paths, 3), number(meanValue(reference), 4), number(s.error.back(), 3),
               number(s.details.back().relativeMse, 3), number(s.details.back().worstPercentRelative, 3),
               number(t, 3) + (extrapolated ? " (extrapolated)" : "")});
  }

  // A section of variants measured by measureVariant: the table as CSV, the error-against-time
  // plot, and the section's text around the table. `reference` says what each row is measured
  // against; `text` follows the common preamble.
  std::string variantSection(const std::string& name, const std::string& title, const std::string& scene,
                             const json& base, const Table& table, const std::vector<Series>& all,
                             const std::string& reference, const std::string& text) {
    table.writeCsv(options_.out / (name + ".csv"));
    plotErrorAgainstTime(name, all);
    const std::string side = std::to_string(scale_.materialsSide);
    return "## " + title + "\n\n" + scene + " at " + side + "x" + side +
           ", NEE + MIS, Sobol, B = " + std::to_string(base["render"].value("max_bounces", 2)) + ", " + reference +
           " (" + std::to_string(scale_.materialsReferenceSpp) + " spp). Time per path is per thread. " + text +
           "\n\n" + table.markdown() + "\n" + link(name);
  }

  // ---- models: what smooth shading and textures cost ------------------------------------------
  // textured-spheres (a glTF model with base-colour, normal, metallic-roughness and cut-out
  // textures and smooth vertex normals) as modelled, then with its materials replaced by one
  // untextured principled material, then by one Lambertian: the time textures and the per-point
  // shading cost, and the image they make.
  std::string models() {
    const fs::path sceneFile = options_.scenes / "textured-spheres.json";
    const json base = json::parse(readWholeFileOrThrow(sceneFile, sceneFile.string()));
    Table table = variantTable();
    std::vector<Series> all;
    const auto withMaterial = [&](const json& material) {
      json j = base;
      j["materials"]["override"] = material;
      j["shapes"][0]["material"] = "override";
      return j;
    };
    measureVariant(sceneFile, base, "as modelled: textures, normal maps, cut-outs, smooth normals", table, all);
    measureVariant(sceneFile,
                   withMaterial({{"type", "principled"}, {"base_color", 0.5}, {"metallic", 0.0}, {"roughness", 0.7}}),
                   "one untextured principled material, smooth normals", table, all);
    measureVariant(sceneFile, withMaterial({{"type", "lambertian"}, {"albedo", 0.5}}),
                   "one Lambertian material, smooth normals", table, all);
    return variantSection(
        "models", "Models: textures and smooth shading", "textured-spheres (a glTF model)", base, table, all,
        "each variant against its own reference",
        "Every hit on a textured material or a mesh with vertex normals is "
        "shaded one path at a time (interpolated normal, normal map, texture lookups at the pixel's footprint) "
        "instead of in the 16-wide lane loops: the first row against the other two is what textures and "
        "per-point shading cost; a scene without them pays nothing (the Cornell rows above run the lane "
        "loops).");
  }

  // ---- optics: what the camera's optics cost --------------------------------------------------
  // cornell-seed through each camera model in turn: a pinhole, the 2013 report's thin lens wide open with a
  // round, a six-bladed and a rounded seven-bladed aperture, and real lenses traced surface by surface (the
  // double-Gauss 50 mm at f/2.8; the fast double-Gauss at f/1.4, whose Abbe numbers make it spectral where lateral
  // colour is simulated). Per variant: the time per path, the energy and the time to the same error against its own
  // reference.
  std::string optics() {
    const fs::path seedFile = options_.scenes / "cornell-seed.json";
    const json seed = json::parse(readWholeFileOrThrow(seedFile, seedFile.string()));
    Table table = variantTable();
    std::vector<Series> all;
    const std::set<std::string> listed = {"depth of field", "real lens", "aperture", "spectral", "diffraction"};
    const auto withCamera = [&](const std::function<void(json&)>& edit) {
      json j = seed;
      edit(j["camera"]);
      return j;
    };
    measureVariant(seedFile, withCamera([](json& c) { c["f_number"] = "infinity"; }), "pinhole", table, all, listed);
    measureVariant(seedFile, withCamera([](json& c) { c["f_number"] = 2.8; }), "thin lens f/2.8, round aperture", table,
                   all, listed);
    measureVariant(seedFile, withCamera([](json& c) { c["f_number"] = 2.8, c["aperture_blades"] = 6; }),
                   "thin lens f/2.8, 6 straight blades", table, all, listed);
    measureVariant(seedFile, withCamera([](json& c) {
                     c["f_number"] = 2.8, c["aperture_blades"] = 7, c["aperture_curvature"] = 0.15;
                   }),
                   "thin lens f/2.8, 7 curved blades (curvature 0.15)", table, all, listed);
    for (const char* scene : {"cornell-real-lens.json", "cornell-seed-fast-lens.json"}) {
      const fs::path file = options_.scenes / scene;
      json j = json::parse(readWholeFileOrThrow(file, file.string()));
      const std::string name = std::string("real lens ") + j["camera"]["lens"].get<std::string>() + " at f/" +
                               number(j["camera"]["f_number"].get<double>(), 2) + " (" + scene + ")";
      measureVariant(file, j, name, table, all, listed);
    }
    table.writeCsv(options_.out / "optics.csv");
    plotErrorAgainstTime("optics", all);
    return "## Camera optics\n\n"
           "cornell-seed at " +
           std::to_string(scale_.materialsSide) + "x" + std::to_string(scale_.materialsSide) +
           " through each camera model, NEE + MIS, Sobol, B = " +
           std::to_string(seed["render"].value("max_bounces", 2)) + ", each against its own reference (" +
           std::to_string(scale_.materialsReferenceSpp) +
           " spp). Time per path is per thread. A thin lens costs two random numbers and a few multiplies per camera "
           "ray over the pinhole; a bladed aperture a polygon sample, curved blades a table look-up and an arc; a real "
           "lens traces every camera ray through its "
           "surfaces in double precision (at its own wavelength per sample, spectral, when its glasses carry Abbe "
           "numbers, as both lenses here do), and the rays its rims stop are samples of zero (noise: the real lenses' "
           "time to the same error is longer by more than their time per path). The real-lens rows frame the box "
           "their own way (cornell-real-lens: a 36 mm-equivalent sensor; cornell-seed-fast-lens: the seed's framing, "
           "most of it outside the f/1.4 lens's image circle, docs/figure7.md), so their image means differ.\n\n" +
           table.markdown() + "\n" + link("optics");
  }

  // ---- materials: what glass and metal cost ---------------------------------------------------
  // cornell-glass-metal with its glass ball and tall block in turn diffuse, smooth, rough, and rough
  // without energy compensation: per variant the time per path, the energy against its own
  // reference, and the time to reach the same error.
  std::string materials() {
    const fs::path file = options_.scenes / "cornell-glass-metal.json";
    const json base = json::parse(readWholeFileOrThrow(file, file.string()));
    struct Variant {
      const char* name;
      json glass, metal;
      const char* scene = "cornell-glass-metal.json";
      bool cameraPathsAlone = false;  // light_tracing off, against the reference with light paths
    };
    const json white = {{"type", "lambertian"}, {"albedo", 0.75}};
    const json glass = {{"type", "dielectric"}, {"ior", 1.5}};
    const json roughGlass = {{"type", "dielectric"}, {"ior", 1.5}, {"roughness", 0.3}};
    // A thin wall (glTF glass without a volume): shadow rays cross it, paths cross it as null
    // events (the volume path tracer, one path at a time).
    const json thinGlass = {{"type", "principled"}, {"metallic", 0}, {"roughness", 0}, {"transmission", 1}};
    const json gold = {{"type", "conductor"}, {"metal", "Au"}};
    const json roughGold = {{"type", "conductor"}, {"metal", "Au"}, {"roughness", 0.3}};
    json roughGoldSingle = roughGold;
    roughGoldSingle["energy_compensation"] = false;
    json veryRoughGold = roughGold, veryRoughGoldSingle = roughGoldSingle;
    veryRoughGold["roughness"] = veryRoughGoldSingle["roughness"] = 1.0;
    const std::vector<Variant> variants = {
        {"diffuse stand-ins", white, white},
        {"smooth glass, polished gold", glass, gold},
        {"smooth glass, rough gold 0.3", glass, roughGold},
        {"rough glass 0.3, rough gold 0.3", roughGlass, roughGold},
        {"thin-walled glass (a thin wall), rough gold 0.3", thinGlass, roughGold},
        {"smooth glass, rough gold 1.0", glass, veryRoughGold},
        {"smooth glass, rough gold 1.0, no energy compensation", glass, veryRoughGoldSingle},
        {"outdoors, lit by an environment map (sky and sun)", glass, roughGold, "glass-metal-sky.json"},
        {"outdoors, camera paths alone (no light paths)", glass, roughGold, "glass-metal-sky.json", true},
    };
    Table table = variantTable();
    std::vector<Series> all;
    for (const Variant& v : variants) {
      const fs::path sceneFile = options_.scenes / v.scene;
      json j = json::parse(readWholeFileOrThrow(sceneFile, sceneFile.string()));
      j["materials"]["glass"] = v.glass;
      j["materials"]["brushed-gold"] = v.metal;
      if (!v.cameraPathsAlone) {
        measureVariant(sceneFile, j, v.name, table, all);
        continue;
      }
      json alone = j;
      alone["render"]["light_tracing"] = "off";
      measureVariant(sceneFile, alone, v.name, table, all, kMaterialEffects, j);
    }
    return variantSection(
        "materials", "Glass and metal", "cornell-glass-metal", base, table, all,
        "each variant against its own reference",
        "What a material costs "
        "is its time per path (refraction and microfacet sampling, longer paths through glass, whose bounces do "
        "not count towards B when smooth) and its noise (caustics through smooth glass reach the sensor only on "
        "scattered paths). The image mean shows what energy compensation keeps: without it a rough metal "
        "darkens (59 % of the light lost at roughness 1 with F = 1). The thin-walled ball is a thin wall: its "
        "shadow is its tint, not black, and the scene runs the volume path tracer (its cost per path is that "
        "tracer's). The last two rows are glass-metal-sky: the same "
        "materials outdoors, lit only by an importance-sampled environment map with a small sun, whose caustic "
        "through the glass ball light paths aimed at the glass draw (the effect analysis turns them on there); "
        "then the same with camera paths alone, measured against the reference with light paths (its own would "
        "lack the caustic it rarely finds).");
  }

  // ---- media: what participating media cost ---------------------------------------------------
  // cornell-media without its media, with each of them alone (the fog bank, the marble block's
  // random walk, the glass of milk), with all three, and with all three but a walk cut at 16
  // events: per variant the time per path, rays per path, the image mean (what the cut loses) and
  // the time to the same error against its own reference.
  std::string media() {
    const fs::path sceneFile = options_.scenes / "cornell-media.json";
    const json base = json::parse(readWholeFileOrThrow(sceneFile, sceneFile.string()));
    Table table = variantTable();
    std::vector<Series> all;
    const std::set<std::string> listed = {"participating media", "equiangular sampling"};
    // The variants edit the scene: the fog bank's shape dropped, the marble block Lambertian,
    // the glass emptied.
    const auto variant = [&](bool fog, bool marble, bool milk) {
      json j = base;
      if (!fog) {
        json shapes = json::array();
        for (const json& shape : j["shapes"])
          if (shape.value("material", "") != "fog-bank") shapes.push_back(shape);
        j["shapes"] = shapes;
      }
      if (!marble) j["materials"]["marble"] = {{"type", "lambertian"}, {"albedo", {0.82, 0.8, 0.74}}};
      if (!milk) j["materials"]["milk-glass"].erase("interior_medium");
      if (!fog) {
        j["materials"]["marble"].erase("exterior_medium");
        j["materials"]["milk-glass"].erase("exterior_medium");
      }
      return j;
    };
    measureVariant(sceneFile, variant(false, false, false), "no media (marble block Lambertian, empty glass)", table,
                   all, listed);
    measureVariant(sceneFile, variant(true, false, false), "fog bank only", table, all, listed);
    // Free-flight sampling alone (render.medium_light_sampling "distance"): what equiangular
    // sampling buys where the fog is the noise, and in the whole scene.
    const auto distanceOnly = [](json j) {
      j["render"]["medium_light_sampling"] = "distance";
      return j;
    };
    measureVariant(sceneFile, distanceOnly(variant(true, false, false)), "fog bank only, free-flight sampling alone",
                   table, all, listed);
    measureVariant(sceneFile, variant(false, true, false), "marble block only (random walk)", table, all, listed);
    measureVariant(sceneFile, variant(false, false, true), "glass of milk only", table, all, listed);
    measureVariant(sceneFile, base, "all three (the scene)", table, all, listed);
    measureVariant(sceneFile, distanceOnly(base), "all three, free-flight sampling alone", table, all, listed);
    json cut = base;
    cut["render"]["max_medium_bounces"] = 16;
    measureVariant(sceneFile, cut, "all three, max_medium_bounces 16", table, all, listed);
    return variantSection(
        "media", "Participating media and subsurface scattering", "cornell-media", base, table, all,
        "each variant against its own reference",
        "A scene with a medium is traced by the volume path tracer one path at "
        "a "
        "time (no 16-wide lane loops): the first row runs the surface tracers and is the baseline. Every scattering "
        "event costs a ray (and a shadow ray where light can reach it); a random walk in marble or milk takes many. "
        "The rows with free-flight sampling alone leave out equiangular sampling towards the light (docs/media.md): "
        "the same image, more noise near the light, less time per path. "
        "The last row cuts walks at 16 events: cheaper, and the image mean shows the light it loses (a bias no "
        "sample count removes).");
  }

  // ---- lights: choosing among many lights ------------------------------------------------------
  // night-street (11,461 lit windows and 56 street lamps from a glTF) with the light tree, as
  // shipped, and with lights chosen by power, both against the tree's reference (one reference: the
  // by-power row's error falls to it only if both estimate one image).
  std::string manyLights() {
    const fs::path sceneFile = options_.scenes / "night-street.json";
    const json base = json::parse(readWholeFileOrThrow(sceneFile, sceneFile.string()));
    Table table = variantTable();
    std::vector<Series> all;
    const std::set<std::string> listed = {"light tree"};
    json tree = base, power = base;
    tree["render"]["light_tree"] = "on";
    power["render"]["light_tree"] = "off";
    // Three budgets: both rows then pass 5 % (the directly seen windows' edges, the same noise for
    // both, rule the relative RMSE until 1024 samples or so).
    measureVariant(sceneFile, tree, "light tree (auto: on)", table, all, listed, std::nullopt, 3.0);
    measureVariant(sceneFile, power, "by power (the light tree off)", table, all, listed, tree, 3.0);
    return variantSection(
        "lights", "Many lights: the light tree", "night-street", base, table, all,
        "both rows against the light tree's reference",
        "23,034 emitting triangles: by power, most light samples go to "
        "windows far down the street or facing away from the point; the light tree (docs/performance.md, "
        "\"Many lights\") chooses by the lights' bounds as seen from each point, at the cost of its descent. "
        "The relative RMSE (RMSE over the image's mean) is ruled by the brightest pixels, the edges of the "
        "windows seen directly, whose noise is the pixel sampling's and the same in both rows (it falls as 1/n "
        "with Sobol samples): the two curves meet. Where the choice of light matters, on the walls and the "
        "street, the relMSE and the display error show it (docs/performance.md: 5.1x and 5.5x sooner).");
  }

  // ---- near-lights: a light's points by solid angle near it ----------------------------------
  // cornell-classic with its ceiling lamp (0.01 below the ceiling) made two-sided, as Blender's
  // glTF exporter writes an emissive plane: its back face lights the ceiling above it. The points
  // on it by solid angle near the lamp (auto, as shipped), by area everywhere, by solid angle
  // everywhere; all against auto's reference.
  std::string nearLights() {
    const fs::path sceneFile = options_.scenes / "cornell-classic.json";
    json base = json::parse(readWholeFileOrThrow(sceneFile, sceneFile.string()));
    for (json& light : base["lights"]) light["two_sided"] = true;
    Table table = variantTable();
    std::vector<Series> all;
    const auto with = [&](const char* mode) {
      json j = base;
      j["render"]["triangle_light_sampling"] = mode;
      return j;
    };
    measureVariant(sceneFile, with("auto"), "auto: by solid angle within two radii of a triangle", table, all);
    measureVariant(sceneFile, with("area"), "by area everywhere", table, all, kMaterialEffects, with("auto"));
    measureVariant(sceneFile, with("solid_angle"), "by solid angle everywhere", table, all, kMaterialEffects,
                   with("auto"));
    return variantSection(
        "near-lights", "Light points by solid angle near the light", "cornell-classic with its lamp two-sided", base,
        table, all, "every row against auto's reference",
        "The lamp hangs 0.01 below the ceiling and emits from both faces, as an emissive plane exported to glTF "
        "does: the ceiling above it is lit across a 0.01 gap. A light sample by area weighs cos cos' A / d^2 there, "
        "up to 10^4 times its mean, and every path that reaches that patch carries it on as a firefly; by the solid "
        "angle the triangle covers (Arvo 1995) an estimate is at most L Omega cos (docs/performance.md, \"Lights "
        "sampled by solid angle near them\"). Everywhere by solid angle costs its libm calls at every shading point "
        "for nothing far from the lamp, where the two densities agree.");
  }

  // ---- guiding: path guiding on the 2013 report's mirror caustic -------------------------------
  // cornell-seed with path guiding off (auto) and on, both against the unguided path tracer's
  // reference.
  std::string pathGuiding() {
    const fs::path sceneFile = options_.scenes / "cornell-seed.json";
    const json base = json::parse(readWholeFileOrThrow(sceneFile, sceneFile.string()));
    Table table = variantTable();
    std::vector<Series> all;
    json off = base, on = base;
    off["render"]["path_guiding"] = "off";
    on["render"]["path_guiding"] = "on";
    measureVariant(sceneFile, off, "path tracer (guiding off)", table, all);
    measureVariant(sceneFile, on, "guided (on)", table, all, kMaterialEffects, off);
    return variantSection(
        "guiding", "Path guiding", "cornell-seed", base, table, all, "both rows against the unguided reference",
        "The floor and walls near the rippled mirror are lit light -> mirror -> surface, a path next-event "
        "estimation cannot sample: only a scattered ray that happens to leave towards the lamp's mirror image finds "
        "it. Guiding (docs/performance.md, \"Path guiding\") learns, in training passes before the image, where "
        "the light arriving at each region comes from and draws half of the diffuse directions there; its "
        "training time is part of every guided row's time.");
  }

  // ---- denoise: uniform sampling against uniform sampling + denoise ---------------------------
  // cornell-seed with the denoiser's guides (albedo, normal, variance), NEE + MIS with Sobol
  // samples, rendered progressively; at every checkpoint the raw image and its denoised version
  // are compared with a converged reference (rendered with the same AOVs). The denoised image's
  // error against the reference is split as E|D(I) - R| ~ bias + variance: the bias is D(R) - R,
  // what the denoiser does to a converged image; the variance part is D(I) - D(R), its own noise.
  // The denoised curve is charged the denoiser's time on top of the render's.
  // cornell-seed as the denoise and adaptive experiments render it (the denoise side, B, NEE + MIS,
  // Sobol, no roulette, the denoiser's guide AOVs) and its converged reference, rendered with the
  // same AOVs and cached (both experiments share it).
  struct GuidedSeed {
    Scene scene;
    Image reference;
    double referenceError = 0.0;  // the reference's own estimated relative error
  };
  GuidedSeed guidedSeed() const {
    GuidedSeed g;
    g.scene = seedAt(scale_.denoiseSide, kStudyBounces);
    g.scene.render.integrator = IntegratorKind::kNeeMis;
    g.scene.render.sampler = SamplerKind::kSobol;
    g.scene.render.roulette = RouletteRule::kOff;
    for (Aov a : {Aov::kAlbedo, Aov::kNormal, Aov::kVariance}) g.scene.render.aovs.add(a);
    g.reference = referenceImage(g.scene, scale_.denoiseReferenceSpp, cache_, &g.referenceError, options_.threads);
    return g;
  }

  // The denoised image (film/denoiser.h, default settings) and the seconds it took.
  static Image timedDenoise(const Image& image, double* seconds) {
    const auto start = std::chrono::steady_clock::now();
    Image out = denoise(image);
    *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
  }

  // Long on purpose, as adaptiveSampling: one script, its steps in the report's order.
  std::string denoising() {
    const int side = scale_.denoiseSide;
    const GuidedSeed guided = guidedSeed();
    const Scene& scene = guided.scene;
    const Image& reference = guided.reference;
    const double referenceError = guided.referenceError;
    const ExposureSettings& exposure = scene.render.exposure;
    double referenceDenoiseSeconds = 0.0;
    const Image denoisedReference = timedDenoise(reference, &referenceDenoiseSeconds);
    const ImageError bias = compareImages(denoisedReference, reference, exposure);
    // D(R) - R also holds the reference's own noise, which the denoiser removes: out in quadrature.
    const double biasNet = netError(bias.relativeRmse, referenceError);

    struct Point {
      double spp, seconds, denoiseSeconds;
      ImageError raw, denoised, variance;
    };
    std::vector<Point> points;
    ProgressiveRun run;
    run.firstCheckpoint = 2;  // the variance AOV needs two samples a pixel
    run.budgetSeconds = scale_.denoiseBudget;
    run.threads = options_.threads;
    renderProgressive(scene, run, [&](const Checkpoint& c) {
      Point p{double(c.samplesPerPixel), c.seconds, 0.0, compareImages(c.image, reference, exposure), {}, {}};
      const Image d = timedDenoise(c.image, &p.denoiseSeconds);
      p.denoised = compareImages(d, reference, exposure);
      p.variance = compareImages(d, denoisedReference, exposure);
      points.push_back(p);
      return true;
    });

    Series raw, denoised, variance, biasLine;
    raw.name = "uniform";
    denoised.name = "uniform + denoise";
    variance.name = "uniform + denoise vs denoised reference (variance part)";
    biasLine.name = "denoiser bias at convergence";
    Table csv({"series", "spp", "seconds", "render_seconds", "denoise_seconds", "relative_rmse",
               "relative_rmse_vs_denoised_reference", "worst_1pct_relative_error", "mean_ratio", "display_rmse"});
    Table table({"spp", "render (s)", "denoise (s)", "uniform rel. RMSE", "+ denoise rel. RMSE", "variance part",
                 "uniform worst 1 %", "+ denoise worst 1 %", "lower total error"});
    // The filter's cost depends on the pixel count, not the samples: every checkpoint is charged the
    // median of the measured times (single timings of a few milliseconds jitter on a shared machine,
    // and a denoised curve whose time went backwards could not be interpolated).
    std::vector<double> denoiseTimes;
    for (const Point& p : points) denoiseTimes.push_back(p.denoiseSeconds);
    const double denoiseSeconds = median(denoiseTimes);
    for (const Point& p : points) {
      const double total = p.seconds + denoiseSeconds;
      for (Series* s : {&raw, &denoised, &variance}) s->spp.push_back(p.spp);
      raw.seconds.push_back(p.seconds);
      raw.error.push_back(p.raw.relativeRmse);
      denoised.seconds.push_back(total);
      denoised.error.push_back(p.denoised.relativeRmse);
      variance.seconds.push_back(total);
      variance.error.push_back(p.variance.relativeRmse);
      csv.add({"uniform", number(p.spp, 10), number(p.seconds, 4), number(p.seconds, 4), "0",
               number(p.raw.relativeRmse, 4), "", number(p.raw.worstPercentRelative, 4), number(p.raw.meanRatio, 5),
               number(p.raw.displayRmse, 4)});
      csv.add({"uniform+denoise", number(p.spp, 10), number(total, 4), number(p.seconds, 4),
               number(p.denoiseSeconds, 4), number(p.denoised.relativeRmse, 4), number(p.variance.relativeRmse, 4),
               number(p.denoised.worstPercentRelative, 4), number(p.denoised.meanRatio, 5),
               number(p.denoised.displayRmse, 4)});
      table.add({number(p.spp, 10), number(p.seconds, 3), number(p.denoiseSeconds, 3), number(p.raw.relativeRmse, 3),
                 number(p.denoised.relativeRmse, 3), number(p.variance.relativeRmse, 3),
                 number(p.raw.worstPercentRelative, 3), number(p.denoised.worstPercentRelative, 3),
                 p.denoised.relativeRmse < p.raw.relativeRmse ? "denoised" : "uniform"});
    }
    csv.writeCsv(options_.out / "denoise.csv");
    biasLine.seconds = {std::min(raw.seconds.front(), denoised.seconds.front()), denoised.seconds.back()};
    biasLine.error = {bias.relativeRmse, bias.relativeRmse};

    // The crossover: the first time at which the raw image's error (interpolated on log-log axes)
    // is no larger than the denoised image's at the same total time.
    bool extrapolated = false;
    const double crossover = crossoverTime(raw, denoised, &extrapolated);
    const std::string crossoverText =
        describeCrossover(crossover, extrapolated, denoised.seconds.back(), "uniform alone is already better");
    Table summary({"bias_at_convergence", "bias_at_convergence_net_of_reference_noise", "reference_estimated_error",
                   "reference_spp", "reference_denoise_seconds", "crossover_seconds", "crossover_extrapolated"});
    summary.add({number(bias.relativeRmse, 4), number(biasNet, 4), number(referenceError, 4),
                 number(double(scale_.denoiseReferenceSpp), 10), number(referenceDenoiseSeconds, 4),
                 number(crossover, 4), extrapolated ? "yes" : "no"});
    summary.writeCsv(options_.out / "denoise-summary.csv");
    plotErrorAgainstTime("denoise", {raw, denoised, variance, biasLine});

    return "## Uniform sampling against uniform sampling + denoise\n\n"
           "cornell-seed at " +
           std::to_string(side) + "x" + std::to_string(side) +
           ", NEE + MIS, Sobol, B = " + std::to_string(kStudyBounces) +
           ", rendered with the denoiser's guide AOVs (albedo, normal, variance) and "
           "compared at every power-of-two sample count with a reference of " +
           std::to_string(scale_.denoiseReferenceSpp) +
           " spp rendered the same way (its own estimated relative "
           "error " +
           number(100 * referenceError, 3) +
           " %, a floor under both curves). The denoised image "
           "(film/denoiser.h, default settings) is charged its render time plus the denoiser's, the median of "
           "its measured times, " +
           number(denoiseSeconds, 3) +
           " s (the table gives each). Its error "
           "against the reference (total) has two parts: the **denoiser's bias at convergence**, the relative RMSE "
           "of the denoised reference against the reference itself, " +
           number(bias.relativeRmse, 3) +
           (biasNet > 0.0 ? " (" + number(biasNet, 3) +
                                " with the reference's own noise, which the denoiser removes, taken out in quadrature)"
                          : " (no more than the reference's own noise, which the denoiser removes: an upper bound, "
                            "the bias is not resolved at this reference's sample count)") +
           ", which no sample count removes; and the **variance part**, the error of the denoised image "
           "against the denoised reference. The worst 1 % is the 99th percentile of the per-pixel relative error "
           "(film/error_metrics.h). Crossover, after which uniform sampling alone has the lower total error: " +
           crossoverText + ".\n\n" + table.markdown() + "\n" + link("denoise") +
           "Data: `denoise.csv` (both series), `denoise-summary.csv` (bias, crossover).\n\n";
  }

  // ---- adaptive: uniform sampling against adaptive sampling and uniform + denoise -------------
  // The denoise experiment's scene and reference. Each method is rendered on its own at each mean
  // sample count (an adaptive render of N spp is not a prefix of one of 2N spp), all three in the
  // passes the farm gives an adaptive job of N spp (unitSize()), so that only where the samples go
  // differs: uniform and adaptive without AOVs, uniform + denoise with the guide AOVs the denoiser
  // needs, charged that render's time plus the denoiser's (the median of its times, as in the
  // denoise experiment). Renders cheaper than Scale::cheapSeconds are timed three times (median).
  // Long on purpose, like the study's other experiments: one script read top to bottom, each step
  // printed to the report in the order it runs.
  std::string adaptiveSampling() {
    const GuidedSeed guided = guidedSeed();
    const ExposureSettings& exposure = guided.scene.render.exposure;
    const double floor = guided.referenceError;
    Scene withGuides = guided.scene;
    withGuides.render.tileSize = RenderSettings::kTilesOff;  // adaptive sampling needs passes
    Scene plain = withGuides;
    plain.render.aovs = AovSet{};
    Scene adaptive = plain;
    adaptive.render.adaptive.enabled = true;

    struct Timed {
      Checkpoint last;
      size_t repeats = 0;
    };
    const auto render = [&](Scene scene, uint64_t spp) {
      RenderSettings sized = adaptive.render;
      sized.samplesPerPixel = spp;
      scene.render.samplesPerUnit = unitSize(sized);
      ProgressiveRun run;
      run.firstCheckpoint = run.maxSamples = spp;
      run.threads = options_.threads;
      Timed t;
      std::vector<double> times;
      do {
        t.last = renderProgressive(scene, run);
        times.push_back(t.last.seconds);
      } while (times.size() < 3 && times.front() < scale_.cheapSeconds);
      t.last.seconds = median(times);
      t.repeats = times.size();
      return t;
    };

    Series uniform, adapted, denoised;
    uniform.name = "uniform";
    adapted.name = "adaptive";
    denoised.name = "uniform + denoise";
    std::vector<double> denoiseTimes, passSamples;
    std::vector<size_t> repeats;
    for (uint64_t spp : scale_.adaptiveCounts) {
      const Timed u = render(plain, spp), a = render(adaptive, spp), g = render(withGuides, spp);
      double denoiseSeconds = 0.0;
      const Image d = timedDenoise(g.last.image, &denoiseSeconds);
      denoiseTimes.push_back(denoiseSeconds);
      RenderSettings sized = adaptive.render;
      sized.samplesPerPixel = spp;
      passSamples.push_back(unitSize(sized));
      repeats.push_back(std::min({u.repeats, a.repeats, g.repeats}));
      const auto add = [&](Series& s, const Timed& t, const ImageError& e) {
        s.spp.push_back(double(t.last.samplesPerPixel));
        s.seconds.push_back(t.last.seconds);
        s.error.push_back(e.relativeRmse);
        s.estimate.push_back(t.last.estimate.valid ? t.last.estimate.relativeRmse : -1.0);
        s.details.push_back(e);
      };
      add(uniform, u, compareImages(u.last.image, guided.reference, exposure));
      add(adapted, a, compareImages(a.last.image, guided.reference, exposure));
      add(denoised, g, compareImages(d, guided.reference, exposure));
      denoised.estimate.back() = -1.0;  // the live estimate is the raw image's
      spdlog::info("{} spp: uniform {:.4f} in {:.2f} s, adaptive {:.4f} in {:.2f} s, uniform + denoise {:.4f}", spp,
                   uniform.error.back(), uniform.seconds.back(), adapted.error.back(), adapted.seconds.back(),
                   denoised.error.back());
    }
    const double denoiseSeconds = median(denoiseTimes);
    for (double& t : denoised.seconds) t += denoiseSeconds;

    Table csv({"series", "spp", "seconds", "repeats", "pass_samples", "relative_rmse",
               "relative_rmse_net_of_reference_noise", "estimated_relative_rmse", "worst_1pct_relative_error",
               "mean_ratio", "relative_mse", "display_rmse"});
    for (const Series* s : {&uniform, &adapted, &denoised})
      for (size_t k = 0; k < s->spp.size(); ++k)
        csv.add({s->name, number(s->spp[k], 10), number(s->seconds[k], 4), std::to_string(repeats[k]),
                 number(passSamples[k], 10), number(s->error[k], 4), number(netError(s->error[k], floor), 4),
                 number(s->estimate[k], 4), number(s->details[k].worstPercentRelative, 4),
                 number(s->details[k].meanRatio, 5), number(s->details[k].relativeMse, 4),
                 number(s->details[k].displayRmse, 4)});
    csv.writeCsv(options_.out / "adaptive.csv");

    Table table({"spp", "uniform (s)", "adaptive (s)", "+ denoise (s)", "uniform rel. RMSE", "its estimate",
                 "adaptive rel. RMSE", "its estimate", "+ denoise rel. RMSE", "uniform worst 1 %", "adaptive worst 1 %",
                 "+ denoise worst 1 %", "mean ratio uniform / adaptive"});
    for (size_t k = 0; k < uniform.spp.size(); ++k)
      table.add({number(adapted.spp[k], 10), number(uniform.seconds[k], 3), number(adapted.seconds[k], 3),
                 number(denoised.seconds[k], 3), number(uniform.error[k], 3), number(uniform.estimate[k], 3),
                 number(adapted.error[k], 3), number(adapted.estimate[k], 3), number(denoised.error[k], 3),
                 number(uniform.details[k].worstPercentRelative, 3), number(adapted.details[k].worstPercentRelative, 3),
                 number(denoised.details[k].worstPercentRelative, 3),
                 number(uniform.details[k].meanRatio, 4) + " / " + number(adapted.details[k].meanRatio, 4)});

    // Time (and samples, free of timing noise) to each target error, interpolated on log-log axes.
    const auto inSamples = [](Series s) {
      s.seconds = s.spp;
      return s;
    };
    Table targets({"target relative RMSE", "uniform (s)", "adaptive (s)", "uniform + denoise (s)",
                   "adaptive speed-up over uniform", "in samples", "denoise speed-up over uniform"});
    Table targetsCsv({"target_relative_rmse", "uniform_seconds", "adaptive_seconds", "denoise_seconds",
                      "adaptive_speedup", "adaptive_speedup_in_samples", "denoise_speedup", "extrapolated"});
    std::string acceptance;
    for (double target : {0.10, 0.05, 0.03}) {
      bool eu = false, ea = false, ed = false, su = false, sa = false;
      const double tu = timeToError(uniform, target, &eu), ta = timeToError(adapted, target, &ea),
                   td = timeToError(denoised, target, &ed);
      const double samples =
          timeToError(inSamples(uniform), target, &su) / timeToError(inSamples(adapted), target, &sa);
      const auto t = [](double v, bool e) { return number(v, 3) + (e ? " (extrapolated)" : ""); };
      targets.add({number(100 * target, 3) + " %", t(tu, eu), t(ta, ea), t(td, ed), number(tu / ta, 3) + "x",
                   number(samples, 3) + "x", number(tu / td, 3) + "x"});
      std::string which;
      for (auto [flag, name] : {std::pair{eu, "uniform"}, {ea, "adaptive"}, {ed, "denoise"}})
        if (flag) which += (which.empty() ? "" : ";") + std::string(name);
      targetsCsv.add({number(target, 3), number(tu, 4), number(ta, 4), number(td, 4), number(tu / ta, 4),
                      number(samples, 4), number(tu / td, 4), which});
      acceptance += (acceptance.empty() ? "" : ", ") + number(tu / ta, 3) + "x to " + number(100 * target, 3) + " %" +
                    (eu || ea ? " (extrapolated)" : "");
    }
    targetsCsv.writeCsv(options_.out / "adaptive-targets.csv");

    // The live estimate against the true error net of the reference's noise, where that is known
    // well (the estimate section's rule).
    const auto estimateRatio = [&](const Series& s) {
      std::vector<double> r;
      for (size_t k = 0; k < s.error.size(); ++k)
        if (s.estimate[k] > 0.0 && s.error[k] > 2.0 * floor) r.push_back(s.estimate[k] / netError(s.error[k], floor));
      return r.empty() ? std::string("not measured (no count's error is twice the reference's)")
                       : number(median(r), 3) + " (" + std::to_string(r.size()) + " counts, " +
                             number(*std::min_element(r.begin(), r.end()), 3) + " to " +
                             number(*std::max_element(r.begin(), r.end()), 3) + ")";
    };
    Table crossovers({"series", "against", "its error is no larger from"});
    for (auto [later, earlier] : {std::pair{&adapted, &uniform}, {&uniform, &denoised}, {&adapted, &denoised}}) {
      bool extrapolated = false;
      const double t = crossoverTime(*later, *earlier, &extrapolated);
      crossovers.add(
          {later->name, earlier->name,
           describeCrossover(t, extrapolated, std::min(later->seconds.back(), earlier->seconds.back()), "already")});
    }
    double worstBias = 0.0;
    for (const ImageError& e : adapted.details) worstBias = std::max(worstBias, std::abs(e.meanRatio - 1.0));

    Series floorLine;
    floorLine.name = "reference noise (floor)";
    floorLine.seconds = {std::min(uniform.seconds.front(), adapted.seconds.front()), denoised.seconds.back()};
    floorLine.error = {floor, floor};
    plotErrorAgainstTime("adaptive", {uniform, adapted, denoised, floorLine});

    const AdaptiveSettings defaults;
    const JobLayout layout = JobLayout::of(adaptive.render, std::nullopt);
    const int side = scale_.denoiseSide;
    return "## Adaptive sampling against uniform sampling\n\n"
           "cornell-seed at " +
           std::to_string(side) + "x" + std::to_string(side) +
           ", NEE + MIS, Sobol, B = " + std::to_string(kStudyBounces) + ", the denoise experiment's reference (" +
           std::to_string(scale_.denoiseReferenceSpp) + " spp, its own estimated relative error " +
           number(100 * floor, 3) +
           " %, a floor under every curve). Three ways to spend the same mean samples per "
           "pixel, each rendered on its own at each count (an adaptive render of N spp is not a prefix of one of 2N "
           "spp) in the passes the farm gives an adaptive job of N spp, so that only where the samples go differs: "
           "**uniform** sampling; **adaptive** sampling (`\"render\": {\"adaptive\": true}`, the defaults); and "
           "**uniform + denoise** (rendered with the guide AOVs, charged its render time plus the denoiser's median "
           "time, " +
           number(denoiseSeconds, 3) +
           " s). Times are wall-clock on this machine, the median of three "
           "renders for those under " +
           number(scale_.cheapSeconds, 2) +
           " s, and include the adaptive rounds' "
           "allocation. *Its estimate* is the live error estimate the job reports (`lensfarm render`'s \"estimated "
           "error\", film/convergence.h); the mean ratio is mean(image) / mean(reference), the bias check. The worst "
           "1 % is the 99th percentile of the per-pixel relative error (film/error_metrics.h).\n\n" +
           table.markdown() + "\n" + link("adaptive") +
           "Time to a target relative RMSE, interpolated on log-log axes between counts (extrapolated as "
           "1/sqrt(time) past the ends); *in samples* is the adaptive speed-up in mean samples per pixel, free of "
           "timing noise:\n\n" +
           targets.markdown() + "\nAdaptive against uniform (the goal is 1.3x): " + acceptance +
           ".\n\nCrossovers, on log-log axes between counts (the curves' last segments extended past the end):\n\n" +
           crossovers.markdown() +
           "\nThe live estimate against the true error net of the reference's noise (median ratio, counts whose "
           "error is at least twice the reference's): uniform " +
           estimateRatio(uniform) + ", adaptive " + estimateRatio(adapted) + ". Adaptive's mean ratio is within " +
           number(100 * worstBias, 2) +
           " % of 1 at every count.\n\n"
           "**How it works** (film/adaptive_allocation.h, farm/job_layout.h). An adaptive job renders " +
           number(100 * defaults.uniform, 3) +
           " % of its passes uniformly, then rounds of passes, each round about "
           "half the passes before it. Before each round the coordinator, holding every pass before it, estimates "
           "each block's per-sample standard deviation s_b (blocks of " +
           std::to_string(layout.blockEdge) + "x" + std::to_string(layout.blockEdge) +
           " cells here; the mean over the block's cells of the two half-images' "
           "squared difference, ConvergenceTracker::cellVariance: no reference) and tops each block up towards "
           "lambda * s_b final samples (Neyman's allocation: with a fixed total, sum s_b^2 / N_b is least for N_b "
           "proportional to s_b), with a floor of " +
           number(defaults.floor, 3) +
           " of the mean per block (no region "
           "starves on an early estimate of zero) and a cap of " +
           number(kAllocationCap, 3) +
           "x the mean. Each of "
           "a round's passes gives every cell of a block the same samples, half of the passes in each half-image, "
           "so the halves stay balanced cell by cell and the live estimate stays valid. The samples that chose the "
           "allocation are kept, a selection bias in principle; but a block pools hundreds of cells, so one pixel's "
           "luck barely moves its own count: the mean ratios above measure it.\n\n"
           "Data: `adaptive.csv` (the three series), `adaptive-targets.csv` (time to each target).\n\n";
  }

  // A crossover time (crossoverTime) in words; `already` says that the first series wins from the start.
  static std::string describeCrossover(double crossover, bool extrapolated, double measuredUpTo,
                                       const std::string& already) {
    if (crossover <= 0.0) return already + " at the first checkpoint";
    if (!extrapolated) return number(crossover, 3) + " s";
    return "not within the measured range (up to " + number(measuredUpTo, 3) + " s)" +
           (std::isfinite(crossover) ? "; the two curves, extended along their last segments on log-log axes, would "
                                       "cross near " +
                                           number(crossover, 3) + " s (extrapolated)"
                                     : "; along their last segments on log-log axes the curves do not converge");
  }

  // The first time at which `raw`'s error (log-log interpolation, errorAtTime) is no larger than
  // `denoised`'s, searched over both series' checkpoint times; 0 if raw is already no worse at the
  // start. If they do not cross, `extrapolated` is set and the time is where the lines through each
  // series' last two checkpoints (log-log) cross, or infinity if they do not converge.
  static double crossoverTime(const Series& raw, const Series& denoised, bool* extrapolated) {
    *extrapolated = false;
    std::vector<double> times = raw.seconds;
    times.insert(times.end(), denoised.seconds.begin(), denoised.seconds.end());
    std::sort(times.begin(), times.end());
    const double start = std::max(raw.seconds.front(), denoised.seconds.front());
    const double end = std::min(raw.seconds.back(), denoised.seconds.back());
    const auto gap = [&](double t) { return std::log(errorAtTime(raw, t)) - std::log(errorAtTime(denoised, t)); };
    if (gap(start) <= 0.0) return 0.0;
    double last = start;
    for (double t : times) {
      if (t <= start || t > end) continue;
      const double a = gap(last), b = gap(t);
      if (b <= 0.0) return std::exp(std::log(last) + a / (a - b) * (std::log(t) - std::log(last)));
      last = t;
    }
    *extrapolated = true;
    const auto slope = [](const Series& s) {
      const size_t n = s.seconds.size();
      return n < 2 ? -0.5 : std::log(s.error[n - 1] / s.error[n - 2]) / std::log(s.seconds[n - 1] / s.seconds[n - 2]);
    };
    const double steeper = slope(denoised) - slope(raw);  // > 0: raw falls faster
    if (!(steeper > 0.0)) return std::numeric_limits<double>::infinity();
    return std::max(end, end * std::exp(gap(end) / steeper));
  }

  std::string header(double minutes) const {
    char date[64];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%d", std::gmtime(&now));
    return "# Accuracy and its cost in time\n\n"
           "This page is written by `lensfarm study`; every number and plot below comes from one run of\n\n"
           "    " +
           options_.command +
           "\n\n"
           "on " +
           machineDescription() + ", " + date + ", renderer " + kRendererVersion + ", in " + number(minutes, 3) +
           " minutes. Times are wall-clock on a shared machine: compare rows of one run, not runs.\n\n"
           "**Measures** (film/error_metrics.h): the headline is the *relative RMSE* of the linear image, the RMSE "
           "over pixels and channels divided by the mean of the converged image. Beside it the CSV files hold the "
           "RMSE, relMSE (mean of (I - R)^2 / (R^2 + 0.01)), the mean ratio (bias) and the RMSE of the displayed "
           "8-bit picture with the seed's automatic exposure (what a viewer sees). The reference is cornell-seed at " +
           std::to_string(scale_.referenceSide) + "x" + std::to_string(scale_.referenceSide) + ", " +
           std::to_string(scale_.referenceSpp) +
           " spp, NEE + MIS with Sobol samples; its own estimated relative "
           "error is " +
           number(100 * referenceError_, 3) +
           " %.\n\n"
           "**Live error and stopping rules.** A running job reports the estimated relative RMSE of its image "
           "(`lensfarm watch`, `lensfarm status`), from two half-images of alternating units (film/convergence.h). "
           "`--target-error E` stops a job (render or submit) at the first prefix of units whose estimate is at "
           "most E, or at its `--spp` cap; `--deadline 10m` stops it at the deadline with the whole units done by "
           "then. The estimate section below shows how well the estimate tracks the true error.\n\n";
  }

  const StudyOptions& options_;
  Scale scale_;
  fs::path report_, cache_;
  Scene seed_;
  Image reference_;
  double referenceError_ = 0.0;
  double slope_ = 0.0;
};

}  // namespace

void runStudy(const StudyOptions& options) {
  for (const auto& e : options.experiments)
    if (!kExperiments.count(e))
      throw InputError(
          "--experiments",
          "unknown experiment \"" + e +
              "\" (expected convergence, estimate, resolution, dof, bounces, materials, models, optics, denoise or "
              "adaptive)");
  Study(options).run();
}

}  // namespace lensfarm::study
