// Contact sheet of the benchmark: one rendered view of each of the first K shapes of every category, one row per
// category (labelled with its name and synset id), so a person can see the benchmark at a glance.
#pragma once

#include "camera/image.h"
#include "synth/benchmark.h"

#include <string>

namespace sdfkit {

struct SheetSettings {
  int per_category = 6;       ///< K: shapes shown per category (fewer when the benchmark has fewer)
  int cell = 160;             ///< cell size in pixels (square)
  double azimuth = 35;        ///< view of every cell, degrees (camera/camera.h look_at convention)
  double elevation = 20;
  double distance = 2.5;      ///< unit-sphere frame; >= 2.41 keeps the unit sphere inside the 35/32 field of view
  int label_width = 150;      ///< left margin holding the category names; 0 = no labels
  int supersampling = 3;
};

/// Renders the sheet of the benchmark `settings` describes (the same shapes write_benchmark writes, generated
/// in memory). Each shape is shown in its unit-sphere frame. Parallel over cells, deterministic.
Image contact_sheet(const SynthSettings& settings, const SheetSettings& sheet = {});

/// contact_sheet() written to `path` (.png recommended).
void write_contact_sheet(const std::string& path, const SynthSettings& settings, const SheetSettings& sheet = {});

}  // namespace sdfkit
