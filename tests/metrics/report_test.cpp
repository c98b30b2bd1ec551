#include "metrics/report.h"

#include "core/json.h"

#include <doctest/doctest.h>

using namespace sdfkit;

namespace {

ShapeRecord record(const std::string& cat, const std::string& shape, double cd, double p1, double r1) {
  ShapeRecord r;
  r.category = cat;
  r.shape = shape;
  r.status = "ok";
  r.result.protocol = Protocol::kDisn;
  r.result.seconds = 1.0;
  for (const auto& [key, label] : metric_keys(Protocol::kDisn)) r.result.metrics.push_back({key, label, 0.0, ""});
  for (auto& m : r.result.metrics) {
    if (m.key == "cd") m.value = cd;
    if (m.key == "p_1") m.value = p1;
    if (m.key == "r_1") m.value = r1;
    if (m.key == "iou") m.value = std::nullopt;
  }
  return r;
}

}  // namespace

TEST_CASE("summary: category means, DISN's pooled F-score, mean of categories, missing counted") {
  std::vector<ShapeRecord> recs = {record("chair", "a", 2.0, 100, 0), record("chair", "b", 4.0, 0, 100),
                                   record("plane", "c", 10.0, 50, 50)};
  ShapeRecord missing;
  missing.category = "plane";
  missing.shape = "d";
  missing.status = "missing";
  recs.push_back(missing);
  const Summary s = summarize(recs, Protocol::kDisn);
  REQUIRE(s.categories.size() == 2);
  const CategorySummary& chair = s.categories[0];
  CHECK(chair.values.at("cd").value() == doctest::Approx(3.0));
  // pooled: P = 50, R = 50 -> F = 50 (the mean of the per-shape F-scores would be 0)
  CHECK(chair.values.at("f_1").value() == doctest::Approx(50.0));
  CHECK_FALSE(chair.values.at("iou").has_value());
  CHECK(s.categories[1].missing == 1);
  CHECK(s.categories[1].ok == 1);
  CHECK(s.mean.values.at("cd").value() == doctest::Approx((3.0 + 10.0) / 2));
  CHECK(s.mean.total == 4);
  const std::string md = markdown_table(s);
  CHECK(md.find("| disn | chair | plane | mean |") == 0);
  CHECK(md.find("| CD (x1000) | 3.000 | 10.000 | 6.500 |") != std::string::npos);
  CHECK(md.find("| missing predictions | 0 | 1 | 1 |") != std::string::npos);
  const std::string csv = per_shape_csv(recs, Protocol::kDisn);
  CHECK(csv.find("plane,d,missing,") != std::string::npos);
  CHECK(summary_json(s, recs)["problems"].size() == 1);
}
