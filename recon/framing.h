// Framing an arbitrary input image like the training renders: find the object (alpha, a given mask, a plain
// background detected from the image border, or GrabCut), composite it on the training background (white), and
// crop a square around it scaled so that the object fills the image as the training renders' objects do.
//
// The 137 px network image is the square crop [x0, x0 + side] x [y0, y0 + side] of the input (in the input's
// continuous pixel coordinates, camera/camera.h) resampled to 137 x 137; a camera of the network image maps back
// to the input image by camera_in_input().
#pragma once

#include "camera/camera.h"
#include "camera/image.h"
#include "models/net_input.h"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace sdfkit {

/// How the object is told from the background when the input has no alpha and no mask is given.
enum class Segmentation {
  kAuto,     ///< a plain background (detected from the image border) when there is one, else the segmenter network's
             ///< mask refined by GrabCut (seeded with it) when FramingSettings::segmenter is set, else GrabCut
  kNone,     ///< none: the image is used as it is (its non-white pixels are the object)
  kGrabCut,  ///< OpenCV's GrabCut seeded from the border (or from FramingSettings::box)
  kNet,      ///< the segmenter network (FramingSettings::segmenter, models/seg_net.h)
};
/// "auto", "none", "grabcut", "net" <-> Segmentation; InvalidInput for another name.
Segmentation parse_segmentation(const std::string& name);
std::string segmentation_name(Segmentation s);

/// How the crop is chosen.
enum class Reframing {
  kAuto,    ///< keep the image as it is when it is framed like a training render, else crop around the object
  kAlways,  ///< always crop a square around the object at the training renders' scale
  kNone,    ///< never: the whole image is resampled to 137 x 137 (the aspect ratio is kept by padding)
};
Reframing parse_reframing(const std::string& name);
std::string reframing_name(Reframing r);

/// An axis-aligned pixel box: columns [x, x + w), rows [y, y + h).
struct PixelBox {
  int x = 0, y = 0, w = 0, h = 0;
};
/// "X,Y,W,H" -> PixelBox; InvalidInput naming the text otherwise.
PixelBox parse_pixel_box(const std::string& text);

struct FramingSettings {
  Segmentation segment = Segmentation::kAuto;
  Reframing reframe = Reframing::kAuto;
  std::optional<PixelBox> box;  ///< the object lies inside this box (GrabCut's rectangle; pixels outside are background)
  TrainingFraming training;
  /// A border pixel belongs to a plain background when every channel is within this of the border's median
  /// colour; the background is plain when at least `plain_share` of the border pixels do.
  double background_tolerance = 0.1;
  double plain_share = 0.9;
  /// Smallest object: its box's longer side in input pixels.
  int min_object_px = 12;
  /// Refused as "only background" below this share of the (cropped) image covered by the object.
  double min_object_share = 0.002;
  /// GrabCut's segmentation is refused when the colour histograms of its object and background overlap more than
  /// this (Bhattacharyya coefficient; a noise image gives about 1).
  double max_colour_overlap = 0.95;
  /// GrabCut runs on the image shrunk to at most this many pixels on its longer side.
  int grabcut_max_side = 400;
  int grabcut_iterations = 5;
  /// The segmenter network (`recon --segment net`, models/seg_net.h predict_foreground): the foreground probability
  /// of every pixel of an RGB image (1 channel, the image's size). Used by kNet, and by kAuto to seed GrabCut
  /// when set. Called from several threads at once when recon runs images in parallel. Empty = no network.
  std::function<Image(const Image& rgb)> segmenter;
  /// Optional: the same network reading several images in one call (models/seg_net.h's batch predict_foreground),
  /// the answers in order, each as `segmenter` would give it. The window scan's readings go through it, round by
  /// round (seven images at a time on a photo); empty = `segmenter` one image at a time.
  std::function<std::vector<Image>(const std::vector<Image>& rgbs)> segmenter_batch;
  /// The network's probability p becomes the coverage clamp((p - lo) / (hi - lo), 0, 1): over 0.5 exactly where
  /// p > (lo + hi) / 2 = 0.7 (the object's pixels), soft edges kept between lo and hi. 0.7 rather than 0.5: on the
  /// validation composites of docs/results/framing.md the masks GrabCut makes from it match the objects better.
  double segmenter_low = 0.5, segmenter_high = 0.9;
  /// kAuto with the segmenter: GrabCut's mask, seeded with the network's, replaces it only when the two agree at
  /// least this much (IoU of their pixels over 0.5); otherwise the network's mask is kept (source "net"). GrabCut
  /// follows the edges of large objects in the photo's colours, but on a busy photo it also swallows background the
  /// colour of the object or drops thin parts whose colours the background shares. 0 = GrabCut's mask whenever it
  /// keeps an object.
  double grabcut_min_agreement = 0.6;
  /// kAuto with the segmenter: labels GrabCut may not change, so that it moves the network's outline rather than
  /// redrawing it. Pixels where the network's probability is at least grabcut_sure_object are surely object (> 1:
  /// none); pixels farther from the network's object than grabcut_sure_background times its box's longer side are
  /// surely background (0: none). On the busy validation composites of docs/results/framing.md (mask IoU, stage 6
  /// segmenter): none 82.4; 0.9 with 0.025 / 0.05 / 0.1: 83.5 / 83.9 / 83.3; 0.8 with 0.05: 83.9; 0.97 with 0.15: 83.2.
  double grabcut_sure_object = 0.9;
  double grabcut_sure_background = 0.05;
  /// Rounds of zooming the segmenter in on its own answer (zoomed_foreground; 0 = read the whole image once).
  int segmenter_zoom_rounds = 2;
  /// The object's box's longer side / the side of the square each round reads.
  double segmenter_zoom_fill = 0.7;
  /// Also read windows of the image and keep the answer most readings agree on (zoomed_foreground's `windows`;
  /// `recon --seg-scan`). Needs segmenter_zoom_rounds > 0.
  bool segmenter_scan = true;
};

/// What zoomed_foreground's window scan did.
struct SegmenterScan {
  int candidates = 0;     ///< readings compared: the whole image and each window (0 = no scan)
  int chosen = 0;         ///< the one kept (0 = the whole image's)
  double agreement = 0;   ///< its mean mask IoU with the others
};

struct FramedInput {
  Image image;      ///< 137 x 137 RGBA: the crop, object alpha = mask (composited on white by network_image)
  Image mask;       ///< input size, 1 channel: object coverage in [0, 1] (what was used)
  std::string mask_source;  ///< "alpha", "mask", "plain-background", "grabcut", "net", "net+grabcut", "none"
  double x0 = 0, y0 = 0, side = 0;  ///< the crop in input pixel coordinates
  bool reframed = false;            ///< false: the whole (square-padded) image
  PixelBox object_box;              ///< the object's box in input pixels
  std::vector<std::string> warnings;  ///< why the input is far from the training renders (empty = not far)
  double extent = 0;                ///< the object's longer side / crop side
  int segmenter_zooms = 0;          ///< rounds of FramingSettings::segmenter_zoom_rounds the segmenter ran
  SegmenterScan segmenter_scan;     ///< FramingSettings::segmenter_scan's choice
};

/// The segmenter's foreground probability of `rgb`, read again closer up: the network reads a letterbox of fixed
/// size (128 px), where an object a third of a photo wide is 40 px across and thin parts vanish. Each round cuts the
/// square in which the box of the current answer's object (p > 0.5) has its longer side `fill` of the side, centred
/// on the box (pixels outside the image repeat its edge), lets the segmenter read it, and takes its answer there and
/// 0 elsewhere (which also drops detached false detections). A round stops the zoom when the answer has no object
/// or the square would be no smaller than the image's longer side. `zooms` (may be null) receives the rounds run.
/// `windows` (with rounds > 0): the same again from each square window of kScanWindow of the image's longer side,
/// placed at most half a window apart along each axis (3 x 2 windows on a 320 x 224 photo), each window's answer
/// zoomed in on like the whole image's; of these candidates (the whole image's first) the one whose object
/// (p > 0.5) has the highest mean IoU with the other candidates' is returned (ties: the earlier). A small object the
/// whole image's reading misses for a salient part of the photo is found by the windows that show it larger, and
/// agreed on. No scan when the whole image's answer covers more than kMaxObjectCover of it. `scan` (may be null)
/// receives the candidates' count, the choice and its agreement.
/// `batch` (may be empty): reads several images at once, as `segmenter` reads each (FramingSettings::
/// segmenter_batch); the candidates' readings of each round then go through one call.
/// InvalidInput naming `what` when the segmenter answers with a map of another size.
Image zoomed_foreground(const std::function<Image(const Image& rgb)>& segmenter, const Image& rgb, int rounds,
                        double fill, const std::string& what, int* zooms = nullptr, bool windows = false,
                        SegmenterScan* scan = nullptr,
                        const std::function<std::vector<Image>(const std::vector<Image>& rgbs)>& batch = {});

/// Side of zoomed_foreground's scan windows, as a share of the image's longer side.
inline constexpr double kScanWindow = 0.6;
/// A segmentation covering more than this share of the image is refused (no object stands out); zoomed_foreground
/// does not scan an image whose whole reading covers more.
inline constexpr double kMaxObjectCover = 0.9;

/// Frame `image` (any size, 1-4 channels). `mask` (optional, the image's size; its alpha, else its luminance =
/// object) replaces the alpha and any segmentation. `what` names the input in messages. Throws InvalidInput (one
/// line naming `what`) for an empty image, a mask of another size, an object smaller than
/// settings.min_object_px, or an image with no object.
FramedInput frame_input(const Image& image, const Image* mask, const FramingSettings& settings,
                        const std::string& what);

/// Intersection over union of two object masks of one size (1-4 channels each: the alpha when there is one, else
/// the luminance, is the coverage; a pixel is object where it is over 0.5). 1 when neither has an object pixel.
/// InvalidInput when the sizes differ.
double mask_iou(const Image& a, const Image& b);

/// How a mask agrees with a reference mask of the same size (pixels over 0.5 as mask_iou reads them): their IoU,
/// the share of the reference's object the mask misses (|truth \ mask| / |truth|) and the area it adds outside it
/// (|mask \ truth| / |truth|); both 0 when the reference has no object pixel. InvalidInput when the sizes differ.
struct MaskAgreement {
  double iou = 1, missed = 0, extra = 0;
};
MaskAgreement mask_agreement(const Image& mask, const Image& truth);

/// A square crop of an input image: [x0, x0 + side] x [y0, y0 + side] in its continuous pixel coordinates.
struct SquareCrop {
  double x0 = 0, y0 = 0, side = 0;
};

/// The crop that shows the object as the training renders show theirs, from a camera of the network image of
/// `framed`: the origin of the object's unit-sphere frame (centre `centre`, radius `radius` in the camera's object
/// frame; 0 and 1 for a shape already in that frame) at the image centre, and the size a unit sphere has in a
/// DISN render (focal kDisnFocal) at the render distance in [d_min, d_max] nearest to the camera's. A render
/// shows the origin at the centre and the object at its distance's size; frame_input's crop centres the object's
/// box at one size for every object instead. Bounded by the renders' framing (`tf`): the object's box keeps an
/// extent in [extent_min, extent_max] and its centre within centre_tolerance of the renders' median place.
/// InvalidInput for a non-positive radius, an inverted range or a camera that sees the centre from behind.
SquareCrop training_crop(const Camera& network_camera, const FramedInput& framed, const Vec3& centre, double radius,
                         double d_min, double d_max, const TrainingFraming& tf = {});

/// `framed` (frame_input's answer for `image`) cut again at `crop`: its network image resampled from `image` as
/// frame_input resamples it (same colours and mask), x0/y0/side/extent updated, reframed set.
void recrop(FramedInput& framed, const Image& image, const SquareCrop& crop);

/// A 1-channel image of the input's size (e.g. a missing-data mask) taken through the framing's crop to 137 x 137, as
/// the network image was (the crop's part outside the input is 0). InvalidInput when the sizes differ.
Image frame_channel(const Image& channel, const FramedInput& framed);

/// The unmasked network input of `framed` (frame_input's answer for `image`), as an SDF network whose fourth channel
/// is the object's mask reads it (SdfNetConfig::MaskChannel::kObject, train/context.h): 4 x 137 x 137 channels-first,
/// the input's pixels through the crop (RGB, an alpha composited on white, the crop's part outside the input white)
/// and the object's coverage (framed.image's alpha). InvalidInput when `image` is not the one framed.
Eigen::VectorXf context_input(const Image& image, const FramedInput& framed);

/// A camera of the 137 px network image of `framed` as a camera of the input image (intrinsics mapped through the
/// crop; same R, t), and its inverse.
Camera camera_in_input(const Camera& network_camera, const FramedInput& framed, int input_width, int input_height);
Camera camera_in_network(const Camera& input_camera, const FramedInput& framed);

/// How GrabCut's colour models start.
enum class GrabCutSeed {
  kRect,            ///< OpenCV's rectangle: outside it background, inside it probably object
  kColour,          ///< outside the rectangle background; inside it, pixels whose colour (8 bins per channel) is rare
                    ///< outside it (under 0.1% of the outside pixels) probably object, the rest probably background
  kRectThenColour,  ///< kRect, and kColour when it leaves no object (its models can converge to "all background"
                    ///< when the object is a small part of a busy rectangle); what frame_input uses
  kMask,            ///< outside the rectangle background; inside it, the pixels over 0.5 in a given mask (the
                    ///< segmenter network's) probably object, the rest probably background
};

/// OpenCV's GrabCut on `rgb` shrunk to at most max_side pixels on its longer side, seeded with `rect` (input pixels)
/// as `seed` says; the object's coverage (0 or 1, interpolated where shrunk) at the input's size. Its k-means
/// initialisation draws from cv::theRNG(), which is seeded here: the same image gives the same mask.
/// `seed_mask`: the mask of GrabCutSeed::kMask (1 channel, the image's size; ignored otherwise).
/// With kMask, labels GrabCut may not change: `sure_object` (optional, 1 channel, the image's size): its pixels over
/// 0.5 that the seed also has are surely object; `sure_background_px` > 0: pixels farther than this (input pixels)
/// from every seed pixel are surely background.
Image grabcut_mask(const Image& rgb, const PixelBox& rect, int max_side, int iterations, GrabCutSeed seed,
                   const Image* seed_mask = nullptr, const Image* sure_object = nullptr,
                   double sure_background_px = 0);

/// Coverage of the object in a plain-background image: 0 where every channel is within `tolerance` of
/// `background`, rising to 1 at twice that distance. 1 channel, the image's size.
Image plain_background_mask(const Image& rgb, const float background[3], double tolerance);

}  // namespace sdfkit
