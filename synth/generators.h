// Internal to synth/: the per-category generators and the small toolkit they share.
#pragma once

#include "core/random.h"
#include "synth/parts.h"
#include "synth/shape.h"

#include <string>
#include <vector>

namespace sdfkit {

/// Random choices and part collection for one shape.
struct Gen {
  explicit Gen(uint64_t seed) : rng(seed) {}
  Rng rng;
  ShapeBuilder b;

  double u(double lo, double hi) { return rng.uniform(lo, hi); }
  /// Integer in [lo, hi] (both included).
  int n(int lo, int hi) { return lo + static_cast<int>(rng.below(static_cast<uint64_t>(hi - lo + 1))); }
  bool p(double probability) { return rng.uniform() < probability; }
  /// Index drawn with the given (unnormalised) weights.
  int choose(const std::vector<double>& weights);
  /// `base` with each channel moved by up to +-amount.
  Vec3f jitter(const Vec3f& base, double amount = 0.05);
  /// One of the palette's colours, jittered.
  Vec3f pick(const std::vector<Vec3f>& palette, double amount = 0.05);
  void add(const std::string& name, const Mesh& part, const Vec3f& color) { b.add(name, part, color); }
};

namespace palette {
extern const std::vector<Vec3f> kWood, kMetal, kFabric, kPlastic, kDark, kPaint, kLight;
}

SynthShape make_plane(Gen& g);
SynthShape make_bench(Gen& g);
SynthShape make_cabinet(Gen& g);
SynthShape make_car(Gen& g);
SynthShape make_chair(Gen& g);
SynthShape make_display(Gen& g);
SynthShape make_lamp(Gen& g);
SynthShape make_speaker(Gen& g);
SynthShape make_rifle(Gen& g);
SynthShape make_sofa(Gen& g);
SynthShape make_table(Gen& g);
SynthShape make_phone(Gen& g);
SynthShape make_watercraft(Gen& g);

}  // namespace sdfkit
