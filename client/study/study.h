#pragma once
// `lensfarm study`: what accuracy costs in time, measured (docs/accuracy.md is its output).
//
// Experiments, each a table (Markdown and CSV) and a plot:
//  - convergence: error against a converged reference vs time for every estimator (naive, NEE,
//    NEE + MIS), sampler (independent, stratified, Sobol) and Russian roulette on/off, and the
//    time each needs to reach the same error (2013 report Fig. 5, progressive rendering);
//  - estimate: the live error estimate (film/convergence.h) against the true error;
//  - resolution: error at a fixed time and time to a fixed error vs pixel count (2013 report Fig. 6);
//  - dof: the blur of a sharp edge at and off the focus plane vs f-number, measured in the image
//    and predicted by thin-lens optics, beside the depth of field of Table 1 (2013 report Fig. 7);
//  - bounces: time per path, light-hit fraction, energy and noise vs the bounce limit B (Fig. 8);
//  - materials: glass and metal (smooth, rough, with and without energy compensation) in
//    cornell-glass-metal: time per path, energy and the time to reach the same error;
//  - models: a textured glTF model against untextured stand-ins;
//  - optics: cornell-seed through a pinhole, the thin lens (round and bladed apertures) and real
//    lenses: time per path, energy and the time to reach the same error;
//  - denoise: uniform sampling against uniform sampling + the denoiser (film/denoiser.h) at every
//    checkpoint, its error split into the denoiser's bias at convergence and the rest, and the
//    time after which the raw image is the better one;
//  - adaptive: uniform sampling against adaptive sampling (film/adaptive_allocation.h) and uniform
//    sampling + the denoiser, each rendered on its own at power-of-two mean sample counts: time to
//    target errors, the worst 1 % of pixels, the bias check (mean ratio), the live estimate beside
//    the true error, and the crossovers;
//  - media: cornell-media without its media, with each alone and with all (the fog bank, the
//    marble block's random walk, the glass of milk), the fog and the whole scene without
//    equiangular sampling, and with walks cut short: time per path, rays per path, energy and the
//    time to the same error.
#include <filesystem>
#include <set>
#include <string>

namespace lensfarm::study {

struct StudyOptions {
  std::filesystem::path out = "study";  // CSV files, plots, and the reference cache
  std::filesystem::path report;         // the Markdown report; default out/accuracy.md
  std::filesystem::path scenes;         // the folder holding cornell-seed.json and cornell-glass-metal.json
  std::set<std::string> experiments;    // empty: all
  bool quick = false;                   // tiny images and budgets (seconds, for tests)
  unsigned threads = 0;                 // 0: every core
  std::string command;                  // how it was invoked, quoted in the report
};

inline const std::set<std::string> kExperiments = {"convergence", "estimate", "resolution",  "dof",     "bounces",
                                                   "materials",   "models",   "optics",      "denoise", "adaptive",
                                                   "media",       "lights",   "near-lights", "guiding"};

// Runs the experiments and writes the outputs; throws InputError for bad options and
// std::runtime_error when a tool (gnuplot) fails.
void runStudy(const StudyOptions& options);

}  // namespace lensfarm::study
