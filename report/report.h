// `sdfkit report` (docs/report.md): one self-contained folder of static pages showing a batch of reconstructions:
// per item the input image, the reconstruction beside its ground truth in one turnable 3D view (model-viewer,
// vendored), the scores, the seconds and the warnings; a table sortable by any column, the means per category and
// the loss curves given. Nothing is fetched from the network when the page is viewed, and it opens from the disk
// (file://): the models are embedded in small scripts loaded when their row scrolls into view.
#pragma once

#include "core/json_fwd.h"

#include <string>
#include <vector>

namespace sdfkit {

struct ReportSettings {
  std::string title = "sdfkit report";
  std::string viewer_dir;          ///< folder holding model-viewer-umd.min.js and its LICENSE
  std::string gt_dir;              ///< ground truths as <gt_dir>/<input stem>.{obj,ply,off,stl,glb,gltf}; "" = none
  std::vector<std::string> curves; ///< SVG loss curves to show (train, refine)
  long max_faces = 3000;           ///< faces per mesh in the pages (decimated beyond)
  int thumbnail = 192;             ///< longest side of the input images in the pages, in pixels
};

struct ReportSummary {
  long items = 0, failed = 0;     ///< failed: recon failed, or the mesh or its ground truth could not be read
  long scored = 0;                ///< items scored against a ground truth
  unsigned long long bytes = 0;   ///< the folder's size
  unsigned long long first_view_bytes = 0;  ///< what opening the page loads before any model: index.html + viewer + images
};

/// Writes the report of `records` (recon's --json records: one object or an array; relative paths are tried as
/// given, then from `base_dir`) into `dir` (created; files of an earlier report are replaced). An item whose
/// files cannot be read is shown as failed, named on stderr, and the others go on. InvalidInput when `records` is
/// not recon's JSON or the viewer is missing.
ReportSummary write_report(const Json& records, const std::string& base_dir, const std::string& dir,
                           const ReportSettings& settings);

/// The viewer folder's script, or InvalidInput naming the folder and the fix when it is missing.
std::string require_viewer(const std::string& viewer_dir);

}  // namespace sdfkit
