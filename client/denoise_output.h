#pragma once
// What `--denoise` (render, download) and `lensfarm denoise` share (docs/aovs.md "Denoising"): the
// guide check with its one clear error, and the denoised image as it is written — the denoised
// beauty, every layer kept, the raw beauty as the layer "noisy", and lensfarm/denoised in the header.
#include <string>

#include "common/film/aov_layout.h"
#include "common/film/denoiser.h"
#include "common/film/image_io.h"

namespace lensfarm::cli {

// The AOVs the denoiser's guides need.
AovSet denoiseGuideAovs();

// Throws InputError naming `source` (a file, a job) if `image` lacks a guide layer.
void requireDenoiseGuides(const Image& image, const std::string& source);

// Denoises `image` in place and marks `metadata` (lensfarm/denoised: what guided it).
void denoiseForOutput(Image& image, ImageMetadata& metadata, const DenoiseOptions& options = {});

}  // namespace lensfarm::cli
