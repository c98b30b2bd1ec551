#include "synth/sheet.h"

#include "camera/camera.h"
#include "camera/render.h"
#include "core/error.h"
#include "sdf/normalize.h"
#include "synth/categories.h"

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace sdfkit {

Image contact_sheet(const SynthSettings& settings, const SheetSettings& sheet) {
  require(sheet.per_category >= 1 && sheet.cell >= 16 && sheet.cell <= 2048 && sheet.label_width >= 0,
          "contact sheet: need per_category >= 1, 16 <= cell <= 2048, label_width >= 0");
  require(sheet.distance > 1.0, "contact sheet: the camera distance must exceed the unit sphere's radius");
  SynthSettings s = settings;
  s.per_category = std::min(settings.per_category, sheet.per_category);
  s.split_base = 0;  // the sheet shows shapes, not splits
  const std::vector<PlannedShape> plan = plan_benchmark(s);
  std::vector<size_t> rows;
  for (const auto& e : plan)
    if (rows.empty() || rows.back() != e.category) rows.push_back(e.category);
  const int cols = s.per_category, cell = sheet.cell;
  Image out(sheet.label_width + cols * cell, static_cast<int>(rows.size()) * cell, 3, 1.0f);
  const Camera cam = look_at(sheet.azimuth, sheet.elevation, sheet.distance, cell, cell);
  RenderSettings rs;
  rs.supersampling = sheet.supersampling;
  tbb::parallel_for(size_t(0), plan.size(), [&](size_t k) {
    const PlannedShape& e = plan[k];
    const SynthShape shape = generate_shape(e.category, e.seed);
    const Mesh m = apply_normalization(shape.mesh, unit_sphere_normalization(shape.mesh));
    const Image rgba = MeshRenderer(m, rs).render(cam).rgba;
    const int row = static_cast<int>(std::find(rows.begin(), rows.end(), e.category) - rows.begin());
    const int x0 = sheet.label_width + e.index * cell, y0 = row * cell;
    for (int y = 0; y < cell; ++y)
      for (int x = 0; x < cell; ++x) {
        const float a = rgba.at(x, y, 3);
        for (int c = 0; c < 3; ++c) out.at(x0 + x, y0 + y, c) = a * rgba.at(x, y, c) + (1 - a) * 1.0f;
      }
  });
  // Thin grid lines between rows, and the labels.
  for (size_t r = 1; r < rows.size(); ++r)
    for (int x = 0; x < out.width; ++x)
      for (int c = 0; c < 3; ++c) out.at(x, static_cast<int>(r) * cell, c) = 0.85f;
  if (sheet.label_width > 0) {
    cv::Mat label(out.height, sheet.label_width, CV_8UC1, cv::Scalar(255));
    const double scale = std::clamp(sheet.label_width / 150.0, 0.3, 3.0);
    for (size_t r = 0; r < rows.size(); ++r) {
      const int yc = static_cast<int>(r) * cell + cell / 2;
      cv::putText(label, categories()[rows[r]].name, cv::Point(8, yc - 2), cv::FONT_HERSHEY_SIMPLEX, 0.6 * scale,
                  cv::Scalar(0), 2, cv::LINE_AA);
      cv::putText(label, categories()[rows[r]].synset, cv::Point(8, yc + static_cast<int>(20 * scale)),
                  cv::FONT_HERSHEY_SIMPLEX, 0.45 * scale, cv::Scalar(90), 1, cv::LINE_AA);
    }
    for (int y = 0; y < out.height; ++y)
      for (int x = 0; x < sheet.label_width; ++x)
        for (int c = 0; c < 3; ++c) out.at(x, y, c) = label.at<uint8_t>(y, x) / 255.0f;
  }
  return out;
}

void write_contact_sheet(const std::string& path, const SynthSettings& settings, const SheetSettings& sheet) {
  write_image(path, contact_sheet(settings, sheet));
}

}  // namespace sdfkit
