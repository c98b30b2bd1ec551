// The 13 categories of DISN's Table 1 as procedural families, with ShapeNet's synset ids, and the
// generator of one shape from (category, seed).
#pragma once

#include "synth/shape.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sdfkit {

struct Category {
  std::string synset;  ///< ShapeNet synset id, e.g. "03001627"
  std::string name;    ///< short name, e.g. "chair" (the folder name in a generated benchmark)
};

/// The 13 categories in DISN's Table 1 order: plane, bench, cabinet, car, chair, display, lamp, speaker, rifle,
/// sofa, table, phone, watercraft.
const std::vector<Category>& categories();

/// Index into categories() of a name or synset id; throws InvalidInput naming the valid choices otherwise.
size_t category_index(const std::string& name_or_synset);

/// One shape of category `category` (index into categories()), entirely determined by `seed`.
/// Units are metre-like; +y is up, the floor is y = 0 for standing objects and the front faces +z.
SynthShape generate_shape(size_t category, uint64_t seed);

}  // namespace sdfkit
