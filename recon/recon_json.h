// The JSON record `sdfkit recon --json` prints for one reconstructed image: where its files went, how the image
// was framed, the cameras (of the input image and of the network image), the camera refinement rounds, the size
// of the mesh and the seconds per stage.
#pragma once

#include "core/json_fwd.h"
#include "recon/recon.h"

#include <string>
#include <vector>

namespace sdfkit {

/// The files of one reconstructed image.
struct ReconOutputPaths {
  std::string input;    ///< the image read
  std::string mesh;     ///< the mesh written
  std::string preview;  ///< the preview PNG (named only when settings.preview)
  std::string mask;     ///< the object mask PNG (written with the preview)
  std::vector<std::string> views;  ///< a multi-view reconstruction's images (Reconstructor::run_views), in order
};

/// The segmenter's window scan (recon/framing.h SegmenterScan): {"candidates", "chosen", "agreement"}, or null when
/// no scan ran.
Json segmenter_scan_json(const SegmenterScan& scan);

/// The record of `result`, what Reconstructor::run returned for an image of image_width x image_height with
/// `settings` (for run_views: the first image's size; the record adds "views", one camera record per image). The
/// refinement's initial camera is given as a camera of the input image (camera_in_input).
Json recon_result_json(const ReconResult& result, const ReconSettings& settings, const ReconOutputPaths& paths,
                       int image_width, int image_height);

}  // namespace sdfkit
