// Training data of the foreground segmenter (`sdfkit train seg`): renders of a prepared dataset (views/NN.png, RGBA,
// the object's alpha is the label) composited onto backgrounds at random places, sizes and canvas shapes, as photos
// show objects.
//
// One composite (make_composite), every random choice drawn in a fixed order from Rng::derived(seed, stream) only:
//  1. canvas: aspect ratio log-uniform in [1, max_aspect], landscape or portrait (coin); its longer side is the
//     network size S, so the letterbox only pads (the composite is made at the resolution the network reads);
//  2. object: the render's alpha box scaled so that its longer side is U(object_min, object_max) x the canvas's longer
//     side (capped so that it fits the canvas's shorter side at object_max of it), its centre uniform over the places that keep the box inside the canvas up to `overflow` of its size on
//     each side (objects may touch or cross the border a little); resampled from the premultiplied render
//     (bilinear, up to 4 x 4 samples per pixel when shrinking);
//  3. object photometric jitter: brightness U(1 - j, 1 + j) times a tint U(1 - j/2, 1 + j/2) per channel;
//  4. background: with probability `procedural` (always, without background images) a procedural one, else a random
//     crop (aspect of the canvas, 40-100% of the largest that fits, uniform place, mirrored on a coin) of a random
//     background image, with brightness U(1 - b, 1 + b) and a tint U(1 - b/3, 1 + b/3) per channel. Procedural
//     kinds (uniform): flat colour (white-ish, near the object's mean colour, or random: a third each), linear
//     gradient between two colours, two-octave value noise at a random scale, stripes at a random angle and period,
//     a rotated checkerboard; Gaussian pixel noise of U(0, procedural_noise) on top.
//  5. clutter (drawn only when `clutter` > 0): with probability `clutter`, 1..clutter_shapes dead-leaves shapes over the
//     background, later ones on top: ellipses, rotated rectangles and triangles, longer extent log-uniform in 4-50%
//     of the canvas diagonal, shorter/longer 0.15-1, each filled with a random colour shaded by a linear ramp or (half
//     of them, with background photos) a crop of a random photo; edges anti-aliased (4 x 4 coverage). Busy photos
//     show many object-like things the segmenter must leave out; the object's label is unchanged (it is in front).
//  6. cut-outs (drawn only when `cutouts` > 0 and a cut-out set is given): with probability `cutouts`, 1..cutouts_max
//     cut-out objects (RGBA images: animals, tools, vehicles, people) pasted over the background, later ones on top,
//     each scaled so that its longer side is U(cutout_min, cutout_max) x the canvas's longer side, its centre
//     uniform over the canvas, mirrored on a coin, its brightness jittered as a photo's. The salient things of a
//     busy photograph (a horse, a face, a fruit) that the segmenter takes for the object are objects, not the
//     dead-leaves shapes of step 5.
// image = object (premultiplied, jittered) + (1 - alpha) background; label = the resampled alpha; both letterboxed.
#pragma once

#include "camera/image.h"
#include "core/json.h"
#include "core/random.h"
#include "models/seg_net.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace sdfkit {

/// Procedural background kinds (SegCompositeSettings::kinds).
enum class ProceduralBackground { kFlat, kGradient, kNoise, kStripes, kChecker };
std::string procedural_name(ProceduralBackground k);

struct SegCompositeSettings {
  int size = 128;               ///< S: the network input side (the canvas's longer side)
  double procedural = 0.3;      ///< probability of a procedural background (1 without background images)
  double object_min = 0.2;      ///< object box longer side / canvas longer side, smallest
  double object_max = 0.95;     ///< largest
  double max_aspect = 16.0 / 9.0;  ///< canvas aspect ratios in [1, max_aspect], either orientation
  double overflow = 0.05;       ///< share of the object's box that may lie outside the canvas on a side
  double object_jitter = 0.25;  ///< j of the object's brightness/tint
  double background_jitter = 0.25;  ///< b of a photo background's brightness/tint
  double procedural_noise = 0.03;   ///< largest standard deviation of a procedural background's pixel noise
  double clutter = 0;           ///< probability of dead-leaves clutter over the background (step 5; 0 = never drawn)
  int clutter_shapes = 24;      ///< most clutter shapes in one composite
  double cutouts = 0;           ///< probability of pasting cut-out objects (step 6; 0 = never drawn)
  int cutouts_max = 3;          ///< most cut-outs in one composite
  double cutout_min = 0.15, cutout_max = 0.7;  ///< a cut-out's longer side / the canvas's longer side
  /// Procedural kinds drawn from (uniformly); all by default.
  std::vector<ProceduralBackground> kinds = {ProceduralBackground::kFlat, ProceduralBackground::kGradient,
                                             ProceduralBackground::kNoise, ProceduralBackground::kStripes,
                                             ProceduralBackground::kChecker};

  [[nodiscard]] Json to_json() const;
  /// InvalidInput naming the setting out of range.
  void validate() const;
};

/// Background photographs, loaded once and shrunk (area averaging) so that their longer side is at most
/// `max_side` px (the composites are made at the network's size, so more resolution is never read).
class BackgroundSet {
 public:
  BackgroundSet() = default;
  /// `source`: a folder (every image in it and its sub-folders with an extension OpenImageIO reads: png, jpg, jpeg,
  /// tif, tiff, bmp, exr, webp; sorted by path) or a list file (.txt/.lst: one path per line, relative to the list's
  /// folder; blank lines and '#' comments skipped). IoError naming the folder/list when it is missing or holds no
  /// image, or naming the image that cannot be read.
  /// `alpha`: keep each image's alpha (RGBA, premultiplied; an image without alpha is opaque): the cut-outs of
  /// SegCompositeSettings::cutouts. Otherwise RGB, composited on white.
  explicit BackgroundSet(const std::string& source, int max_side = 256, bool alpha = false);
  [[nodiscard]] size_t size() const { return images_.size(); }
  [[nodiscard]] bool empty() const { return images_.empty(); }
  [[nodiscard]] const Image& image(size_t i) const { return images_.at(i); }
  [[nodiscard]] const std::string& path(size_t i) const { return paths_.at(i); }

 private:
  std::vector<Image> images_;  // RGB, or premultiplied RGBA
  std::vector<std::string> paths_;
};

/// The image files of a background folder or list (BackgroundSet's rules), without reading them.
std::vector<std::string> list_background_files(const std::string& source);

/// One composite: the letterboxed S x S RGB image, its S x S label (object coverage in [0, 1]), the canvas's place in
/// the letterbox, and what the background was.
struct SegSample {
  Image image;  ///< S x S x 3
  Image label;  ///< S x S x 1
  int canvas_x0 = 0, canvas_y0 = 0, canvas_width = 0, canvas_height = 0;
  /// "flat", "gradient", "noise", "stripes", "checker", or "photo:<index>"; "+clutter" appended when step 5 drew
  /// clutter, "+cutouts" when step 6 pasted cut-outs.
  std::string background;
};

/// A background as make_composite's steps 4 and 5 draw it (see the header comment), width x height RGB, drawn from
/// `rng` in that order: a random crop of a photo of `backgrounds` (may be null or empty) or a procedural background
/// whose colours may lie near `near` (the object's mean colour), then clutter when settings.clutter > 0, then
/// cut-outs of `cutouts` (RGBA BackgroundSet; may be null) when settings.cutouts > 0. `name` (optional) receives what
/// it was, as SegSample::background names it.
Image draw_background(int width, int height, const BackgroundSet* backgrounds, const SegCompositeSettings& settings,
                      const std::array<float, 3>& near, Rng& rng, std::string* name = nullptr,
                      const BackgroundSet* cutouts = nullptr);

/// Composite `render` (RGBA; RGB or grey is taken as opaque) onto a background, drawing every choice from
/// Rng::derived(seed, stream) (see the header comment). `backgrounds` may be null or empty (procedural only);
/// `cutouts` (RGBA, may be null) are step 6's objects.
SegSample make_composite(const Image& render, const BackgroundSet* backgrounds, const SegCompositeSettings& settings,
                         uint64_t seed, uint64_t stream, const BackgroundSet* cutouts = nullptr);

}  // namespace sdfkit
