// Batch results: per-shape records, per-category aggregation, and the three report formats of `sdfkit eval` on
// dataset folders (per-shape CSV, a Markdown table in DISN's Table 1 layout, a JSON summary).
//
// Aggregation (docs/eval.md): a category's value of a metric is the mean over its scored shapes that have the
// metric (null metrics are left out and counted); for the disn protocol's F-scores, precision and recall are
// pooled first (category means) and F = 2PR / (P + R) is computed from them, as DISN does. The "mean" column is
// the mean of the category values (every category weighs the same, as in DISN's tables).
#pragma once

#include "core/files.h"
#include "metrics/protocols.h"

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace sdfkit {

struct ShapeRecord {
  std::string category, shape;
  std::string status;  ///< "ok", "missing" (no prediction), "failed" (reason says why)
  std::string reason;
  std::string pred_path, gt_path;
  EvalResult result;   ///< valid when status == "ok"
};

struct CategorySummary {
  std::string category;
  long total = 0, ok = 0, missing = 0, failed = 0;
  double seconds_per_shape = 0;                          ///< mean evaluation time of the scored shapes
  std::map<std::string, std::optional<double>> values;  ///< key -> aggregated value (empty: no shape had it)
};

struct Summary {
  Protocol protocol = Protocol::kDisn;
  std::vector<CategorySummary> categories;  ///< sorted by name
  CategorySummary mean;                     ///< "mean" column: mean of category values; counts are totals
};

Summary summarize(const std::vector<ShapeRecord>& records, Protocol protocol);
/// One row per shape: category,shape,status,<metric keys...>,seconds,reason (empty cells for null values).
std::string per_shape_csv(const std::vector<ShapeRecord>& records, Protocol protocol);
/// Rows = metric blocks (labels), columns = categories + mean; then counts and seconds per shape.
std::string markdown_table(const Summary& summary);
Json summary_json(const Summary& summary, const std::vector<ShapeRecord>& records);

}  // namespace sdfkit
