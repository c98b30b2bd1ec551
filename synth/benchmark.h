// Writing the procedural benchmark to disk: one binary PLY per shape in DIR/<category>/<shape-id>.ply,
// categories.json, and deterministic 80/10/10 train/val/test lists (DIR/train.lst, val.lst, test.lst).
#pragma once

#include "core/files.h"

#include <cstdint>
#include <string>
#include <vector>

namespace sdfkit {

struct SynthSettings {
  int per_category = 3;                 ///< shapes per category (presets: ci = 3, full = 100)
  uint64_t seed = 0;                    ///< everything written is a function of this seed
  std::vector<std::string> categories;  ///< names or synset ids; empty = all 13
  int jobs = 0;                         ///< worker threads; 0 = all cores (output does not depend on it)
  /// Val and test are drawn from the first `split_base` shapes of each category as for a benchmark of that size;
  /// shapes from index `split_base` on all go to train. 0 = per_category. A larger training set then keeps the
  /// val and test shapes of the smaller benchmark (e.g. 300 per category with split_base 100 scores on the same
  /// test shapes as the 100-shape benchmark).
  int split_base = 0;
};

/// One shape of the benchmark.
struct PlannedShape {
  size_t category = 0;  ///< index into categories()
  int index = 0;        ///< 0-based index within the category
  std::string id;       ///< "<name>_<index, 4 digits>", e.g. "chair_0007" (the PLY's file stem)
  uint64_t seed = 0;    ///< the generator seed of this shape
};

/// Seed of shape `index` of `category`: independent of how many shapes or which categories are generated, so a
/// larger benchmark extends a smaller one with the same seed.
uint64_t shape_seed(uint64_t seed, size_t category, int index);
/// "<name>_<index, 4 digits>".
std::string shape_id(size_t category, int index);

/// The shapes `settings` asks for, in category order (DISN's Table 1) then index order.
std::vector<PlannedShape> plan_benchmark(const SynthSettings& settings);

/// Indices 0..n-1 of one category split into train / val / test: a seeded shuffle, then 80% / 10% / 10%
/// (rounded; val and test get at least one shape each when n >= 3, test gets one when n == 2). Each list is
/// sorted.
struct Split {
  std::vector<int> train, val, test;
};
Split split_indices(int n, uint64_t seed, size_t category);
/// The split of `settings` for one category: split_indices(split_base) plus indices split_base..per_category-1 in
/// train.
Split category_split(const SynthSettings& settings, size_t category);

struct SynthSummary {
  long shapes = 0;
  long faces = 0;     ///< total triangles written
  long max_faces = 0; ///< largest shape
  long removed_stale = 0;  ///< old shape files of an earlier run removed from DIR
};

/// Generate and write the benchmark into `dir`. `dir` must be absent, empty or an earlier synth output
/// (holding categories.json); in the last case shape files of the earlier run that are not part of this one are
/// removed so that DIR holds exactly this benchmark. Same settings -> byte-identical files, whatever `jobs` is.
/// Throws InvalidInput for bad settings or a foreign non-empty `dir`, IoError when writing fails.
SynthSummary write_benchmark(const std::string& dir, const SynthSettings& settings, const ProgressFn& progress = {});

}  // namespace sdfkit
