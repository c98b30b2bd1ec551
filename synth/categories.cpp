#include "synth/categories.h"

#include "core/error.h"
#include "synth/generators.h"

#include <algorithm>

namespace sdfkit {

const std::vector<Category>& categories() {
  static const std::vector<Category> kList = {
      {"02691156", "plane"},   {"02828884", "bench"},   {"02933112", "cabinet"}, {"02958343", "car"},
      {"03001627", "chair"},   {"03211117", "display"}, {"03636649", "lamp"},    {"03691459", "speaker"},
      {"04090263", "rifle"},   {"04256520", "sofa"},    {"04379243", "table"},   {"04401088", "phone"},
      {"04530566", "watercraft"}};
  return kList;
}

size_t category_index(const std::string& key) {
  const auto& c = categories();
  for (size_t i = 0; i < c.size(); ++i)
    if (c[i].name == key || c[i].synset == key) return i;
  std::string names;
  for (const auto& x : c) names += (names.empty() ? "" : ", ") + x.name;
  throw InvalidInput("unknown category '" + key + "' (expected a name or synset id of: " + names + ")");
}

SynthShape generate_shape(size_t category, uint64_t seed) {
  using Maker = SynthShape (*)(Gen&);
  static const Maker kMakers[] = {make_plane, make_bench,   make_cabinet, make_car,   make_chair,
                                 make_display, make_lamp,  make_speaker, make_rifle, make_sofa,
                                 make_table, make_phone,   make_watercraft};
  require(category < categories().size(), "generate_shape: category index out of range");
  Gen g(seed);
  return kMakers[category](g);
}

int Gen::choose(const std::vector<double>& weights) {
  double total = 0;
  for (const double w : weights) total += w;
  double x = rng.uniform() * total;
  for (size_t i = 0; i < weights.size(); ++i) {
    if (x < weights[i]) return static_cast<int>(i);
    x -= weights[i];
  }
  return static_cast<int>(weights.size()) - 1;
}

Vec3f Gen::jitter(const Vec3f& base, double amount) {
  Vec3f c = base;
  for (int k = 0; k < 3; ++k) c[k] = static_cast<float>(std::clamp(c[k] + u(-amount, amount), 0.0, 1.0));
  return c;
}

Vec3f Gen::pick(const std::vector<Vec3f>& pal, double amount) {
  return jitter(pal[rng.below(pal.size())], amount);
}

namespace palette {
const std::vector<Vec3f> kWood = {{0.55f, 0.36f, 0.2f}, {0.75f, 0.58f, 0.38f}, {0.36f, 0.22f, 0.12f},
                                  {0.85f, 0.72f, 0.52f}};
const std::vector<Vec3f> kMetal = {{0.62f, 0.63f, 0.66f}, {0.45f, 0.46f, 0.5f}, {0.78f, 0.76f, 0.7f}};
const std::vector<Vec3f> kFabric = {{0.7f, 0.2f, 0.18f}, {0.2f, 0.32f, 0.6f}, {0.3f, 0.5f, 0.3f},
                                    {0.78f, 0.72f, 0.6f}, {0.45f, 0.45f, 0.47f}, {0.55f, 0.4f, 0.6f}};
const std::vector<Vec3f> kPlastic = {{0.9f, 0.9f, 0.88f}, {0.15f, 0.15f, 0.16f}, {0.85f, 0.3f, 0.2f},
                                     {0.25f, 0.5f, 0.75f}, {0.95f, 0.8f, 0.3f}};
const std::vector<Vec3f> kDark = {{0.08f, 0.08f, 0.1f}, {0.12f, 0.14f, 0.18f}, {0.18f, 0.18f, 0.2f}};
const std::vector<Vec3f> kPaint = {{0.75f, 0.1f, 0.1f}, {0.1f, 0.25f, 0.6f}, {0.9f, 0.9f, 0.9f},
                                   {0.2f, 0.2f, 0.22f}, {0.85f, 0.75f, 0.2f}, {0.3f, 0.55f, 0.35f},
                                   {0.6f, 0.62f, 0.65f}};
const std::vector<Vec3f> kLight = {{0.95f, 0.93f, 0.85f}, {0.98f, 0.9f, 0.6f}, {0.9f, 0.95f, 1.0f}};
}  // namespace palette

}  // namespace sdfkit
